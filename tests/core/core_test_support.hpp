// What the core's tests share, from the core alone: a small deterministic
// generator and a split that runs its parts last first.
#pragma once

#include <cstdint>

#include "zonemap/common/work_split.hpp"

namespace zonemap::testing {

class Lcg {
 public:
  explicit Lcg(std::uint64_t seed) : state_(seed * 2862933555777941757ULL + 3037000493ULL) {}
  double uniform() {  // [0, 1)
    state_ = state_ * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<double>(state_ >> 11) * (1.0 / 9007199254740992.0);
  }

 private:
  std::uint64_t state_;
};

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

}  // namespace zonemap::testing
