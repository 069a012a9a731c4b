// What the core's tests share, from the core alone: a small deterministic
// generator, busy work that shakes threads' interleavings, a split that runs its parts last first,
// a small centred config and a valid INS solution.
#pragma once

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>

#include <Eigen/Geometry>

#include "zonemap/common/config.hpp"
#include "zonemap/common/work_split.hpp"
#include "zonemap/pose/ins_gate.hpp"

namespace zonemap::testing {

class Lcg {
 public:
  explicit Lcg(std::uint64_t seed) : state_(seed * 2862933555777941757ULL + 3037000493ULL) {}
  double uniform() {  // [0, 1)
    state_ = state_ * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<double>(state_ >> 11) * (1.0 / 9007199254740992.0);
  }
  double gaussian() {  // N(0, 1), Box-Muller
    const double u1 = std::max(uniform(), 1e-300);
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
  }

 private:
  std::uint64_t state_;
};

// A random amount of busy work (not a sleep): shakes the interleavings.
inline void jitter(Lcg& rng, int max_spins) {
  const int spins = static_cast<int>(rng.uniform() * max_spins);
  std::atomic<int> sink{0};
  for (int i = 0; i < spins; ++i) sink.fetch_add(1, std::memory_order_relaxed);
}

// A split whose parts run one after another, the last first: a part that read
// what another part writes would see it unwritten.
class BackwardsSplit final : public WorkSplit {
 public:
  explicit BackwardsSplit(int parts) : parts_(parts) {}
  int parts() const override { return parts_; }
  void run(Job job, void* context) override {
    for (int p = parts_ - 1; p >= 0; --p) job(context, p, parts_);
  }

 private:
  int parts_;
};

// A small map in the paper's geometry (environment centred on the camera, as the
// zone and mapper tests draw it): 1 m cells, 10 x 10 x 4 zones, d 1..8 m.
inline MapConfig small_centred_config() {
  MapConfig config;
  config.cell_size_m = 1.0;
  config.zone_cells = {10, 10, 4};
  config.d_min_m = 1.0;
  config.d_max_m = 8.0;
  config.placement = MapConfig::Placement::kCentred;
  return config;
}

// A plausible INS solution at time t and position p (valid flags, 0.3 m sigma).
inline InsSolution valid_at(double t, const Eigen::Vector3d& p) {
  InsSolution s;
  s.time_s = t;
  s.position_m = p;
  s.attitude_valid = s.position_valid = true;
  s.position_sigma_m = 0.3;
  return s;
}

}  // namespace zonemap::testing
