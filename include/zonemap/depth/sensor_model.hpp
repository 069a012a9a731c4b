// The stereo sensor model of paper §III-B, eq. (4) and (5), and what one ray
// contributes to a cell it crosses.
#pragma once

#include <algorithm>
#include <cmath>

namespace zonemap {

// One pixel's ray, parametrised by δ, the depth-plane distance along the optical
// axis (the paper's δ).
struct RayProfile {
  float delta_begin = 0.0f;       // d_min
  float delta_end = 0.0f;         // where the ray stops influencing the map
  float depth = 0.0f;             // measured d; ignored when free_only
  float range_resolution = 1.0f;  // Δd of eq. (1)
  bool free_only = false;         // sky pixels and depths beyond d_max: free up to d_max
};

// Eq. (4) and (5): m̂(δ) for a measurement d with uncertainty Δd.
inline float sensor_model_value(float delta, float depth, float range_resolution) {
  if (delta < depth - 2.0f * range_resolution) return -1.0f;  // eq. (4)
  if (delta < depth + range_resolution) {
    return 1.0f - std::fabs(delta - depth) / range_resolution;  // eq. (5)
  }
  return 0.0f;  // behind the obstacle: no influence
}

// The largest m̂ over the part [a, b] of the ray that lies in one cell. The paper
// samples δ and keeps the maximum per cell (max-write); taking the supremum over
// the cell's whole δ interval is that rule without the sampling step, so a thin
// peak (small Δd at short range) is never stepped over. m̂ rises to its peak at
// δ = d and falls after it, so the supremum is at d clamped into [a, b].
inline float max_value_in_interval(const RayProfile& ray, float a, float b) {
  if (ray.free_only) return -1.0f;
  return sensor_model_value(std::clamp(ray.depth, a, b), ray.depth, ray.range_resolution);
}

}  // namespace zonemap
