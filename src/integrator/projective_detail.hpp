// What the projective path's source files share (src/projective_*.cpp, one idea
// a file: the frame's walk and a cell's tiers, the block classes, the bounds
// from a footprint's depth range, the ray-by-ray passes): the block classes, a
// cell's rays, and the small per-code functions every tier inlines. Internal to
// src/: not a public header.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "integrator/projective_lanes.hpp"
#include "zonemap/depth/sensor_model.hpp"
#include "zonemap/integrator/projective_integrator.hpp"

namespace zonemap {

// Block classes (see classify_blocks).
inline constexpr std::uint8_t kBlockMixed = 0;   // look at each cell
inline constexpr std::uint8_t kBlockFree = 1;    // every ray near it is free across it
inline constexpr std::uint8_t kBlockUnseen = 2;  // no ray reaches it (or no pixel sees it)

// The pixel rays of one cell (see RayLanes).
struct ProjectiveIntegrator::CellRays {
  RayLanes rays{};           // lo, hi: the cell's world box minus the camera centre
  float a = 0.0f, b = 0.0f;  // the cell's δ-support (camera-frame z range, from d_min)
  int enough_fixed = 0;      // the ray-by-ray search may stop at this cell value
};

// m̂ maximised over the part of [a, b] the ray covers: the ray of depth d runs
// from d_min to min(d + Δd, d_max) (free-only rays to d_max).
inline float ProjectiveIntegrator::value_for_code(std::uint16_t code, float a, float b) const {
  if (code == DepthRangeTable::kFar) return a <= d_max_ ? -1.0f : kNoRay;
  const float d = static_cast<float>(code) * code_to_m_;
  const float resolution = std::max(d * d * resolution_factor_, 1e-6f);
  const float end = std::min(d + resolution, d_max_);
  if (a > end) return kNoRay;
  return sensor_model_value(std::clamp(d, a, std::min(b, end)), d, resolution);
}

// The value of a range's largest depth, for depths above b where m̂(b; d) may
// rise again: a kFar largest hides the largest real depth when there is one (lo
// real), bounded then by d_max's.
inline float ProjectiveIntegrator::far_end(std::uint16_t lo, std::uint16_t hi, float a,
                                           float b) const {
  if (hi != DepthRangeTable::kFar || lo == DepthRangeTable::kFar) return value_for_code(hi, a, b);
  return std::max(value_for_code(hi, a, b), value_for_code(max_real_code_, a, b));
}

// The depth codes [*lo, *hi] whose rays can reach into a cell's δ-support
// [a, b] far enough: d + s_lo Δd(d) >= a and d - s_hi Δd(d) <= b (Δd = d²
// factor; s = 1 - m̂ for "m̂ at least ..."), from the roots of the two
// quadratics in d, widened by a code each way: a filter, never the decision.
// d - s Δd(d) falls again past its second root (large Δd): when
// `open_past_second_root` and that root is within d_max, no upper limit.
inline void ProjectiveIntegrator::codes_reaching(float a, float b, float s_lo, float s_hi,
                                                 bool open_past_second_root, std::uint16_t* lo,
                                                 std::uint16_t* hi) const {
  const float top_code = static_cast<float>(DepthRangeTable::kMaxDepthCode);
  const float k_lo = resolution_factor_ * s_lo;
  const float reach_a = (std::sqrt(1.0f + 4.0f * k_lo * a) - 1.0f) / (2.0f * k_lo);
  *lo = static_cast<std::uint16_t>(
      std::clamp(std::floor(reach_a / code_to_m_) - 1.0f, 0.0f, top_code));
  *hi = DepthRangeTable::kMaxDepthCode;
  const float k_hi = resolution_factor_ * s_hi;
  const float disc = 1.0f - 4.0f * k_hi * b;
  if (disc <= 0.0f) return;  // d - s Δd(d) <= b for every d
  const float root = std::sqrt(disc);
  if (open_past_second_root && (1.0f + root) / (2.0f * k_hi) <= d_max_ * (129.0f / 128.0f))
    return;  // (d_max widened as the roots are)
  const float reach_b = (1.0f - root) / (2.0f * k_hi);
  *hi = static_cast<std::uint16_t>(
      std::clamp(std::ceil(reach_b / code_to_m_) + 1.0f, 0.0f, top_code));
}

inline bool ProjectiveIntegrator::free_across(std::uint16_t lo_code, std::uint16_t hi_code,
                                              float far_end) const {
  if (lo_code > hi_code) return false;  // every pixel missing
  if (lo_code == DepthRangeTable::kFar) return far_end <= d_max_;
  // d - 2 Δd(d), where a ray of depth d stops being free; concave in d, so over
  // any set of depths its minimum is at the smallest or the largest.
  const auto free_until = [this](float d) { return d - 2.0f * d * d * resolution_factor_; };
  const float d_lo = static_cast<float>(lo_code) * code_to_m_;
  const float d_hi =
      hi_code == DepthRangeTable::kFar ? d_max_ : static_cast<float>(hi_code) * code_to_m_;
  return std::min(free_until(d_lo), free_until(d_hi)) > far_end;
}

// Where the ray of a depth code stops: min(d + Δd, d_max); grows with d.
inline float ProjectiveIntegrator::reach(std::uint16_t code) const {
  const float d = static_cast<float>(code) * code_to_m_;
  return std::min(d + d * d * resolution_factor_, d_max_);
}

}  // namespace zonemap
