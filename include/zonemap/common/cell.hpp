// Fixed-point cell values and integer cell coordinates.
#pragma once

#include <cstdint>

namespace zonemap {

// Sensor-model values m̂ ∈ [-1, 1] (paper eq. 4, 5) are stored as integers in Q6:
// 1.0 is 64. A local-grid cell fits in int8 (|v| <= 64); the fused zone cells of
// eq. (7) are int16 and saturate at a configured limit (at most kMaxFusedUnits).
inline constexpr int kCellScale = 64;
inline constexpr int kMaxFusedUnits = 500;  // 500 * 64 = 32000 < INT16_MAX

using LocalCell = std::int8_t;
using FusedCell = std::int16_t;

// Local-grid marker for "no ray touched this cell" so that max-write can tell a
// free observation (-64) from an unobserved cell. Replaced by 0 before the blur.
inline constexpr LocalCell kUntouched = INT8_MIN;

constexpr int to_fixed(float units) {
  const float scaled = units * static_cast<float>(kCellScale);
  return static_cast<int>(scaled >= 0.0f ? scaled + 0.5f : scaled - 0.5f);
}
constexpr float to_units(int fixed) {
  return static_cast<float>(fixed) / static_cast<float>(kCellScale);
}
// A sensor-model value as a local-grid cell: Q6, clamped to [-1, 1] (both
// integration paths write through this, so their cells agree).
constexpr LocalCell to_local_cell(float units) {
  const int fixed = to_fixed(units);
  return static_cast<LocalCell>(fixed < -kCellScale  ? -kCellScale
                                : fixed > kCellScale ? kCellScale
                                                     : fixed);
}

struct CellIndex {
  std::int32_t x = 0;
  std::int32_t y = 0;
  std::int32_t z = 0;
  friend constexpr bool operator==(const CellIndex&, const CellIndex&) = default;
};

// Floor division that is correct for negative numerators (world cells can be negative).
constexpr std::int32_t floor_div(std::int32_t a, std::int32_t b) {
  const std::int32_t q = a / b;
  return (a % b != 0 && ((a < 0) != (b < 0))) ? q - 1 : q;
}

}  // namespace zonemap
