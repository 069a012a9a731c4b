// What the feature map's source files share (src/feature_map*.cpp, one idea a
// file: the store and extraction, the terrain, the segmentation, the priors and
// shared maps, the merged output). Internal: not a public header.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "zonemap/features/feature_map.hpp"

namespace zonemap {
inline constexpr std::int16_t kNoHeight = -1;
// A measured band's run tops scatter about its quantile by about a cell.
inline constexpr int kBandScatterCells = 1;
// PeakTrim compares a cell with the planes one above and below it: beside a
// stronger part it takes a cell of a thin thing; two leave a cell of margin.
inline constexpr int kTrimReachZ = 2;

inline std::int64_t overlap_volume(const CellIndex& a0, const CellIndex& a1, const CellIndex& b0,
                                   const CellIndex& b1) {
  const std::int64_t dx = std::min(a1.x, b1.x) - std::max(a0.x, b0.x) + 1;
  const std::int64_t dy = std::min(a1.y, b1.y) - std::max(a0.y, b0.y) + 1;
  const std::int64_t dz = std::min(a1.z, b1.z) - std::max(a0.z, b0.z) + 1;
  return dx > 0 && dy > 0 && dz > 0 ? dx * dy * dz : 0;
}

// Sum over the window [x0, x1] x [y0, y1] of a summed-area table with `stride`
// entries per row (row and column 0 are zero).
inline std::int32_t window_sum(const std::int32_t* table, std::size_t stride, int x0, int y0,
                               int x1, int y1) {
  return table[static_cast<std::size_t>(y1 + 1) * stride + x1 + 1] -
         table[static_cast<std::size_t>(y0) * stride + x1 + 1] -
         table[static_cast<std::size_t>(y1 + 1) * stride + x0] +
         table[static_cast<std::size_t>(y0) * stride + x0];
}

// Whether the x-y boxes of a and b overlap by more than half the smaller one.
inline bool mostly_overlap_xy(const Feature& a, const Feature& b) {
  const std::int64_t dx = std::min(a.max.x, b.max.x) - std::max(a.min.x, b.min.x) + 1;
  const std::int64_t dy = std::min(a.max.y, b.max.y) - std::max(a.min.y, b.min.y) + 1;
  if (dx <= 0 || dy <= 0) return false;
  const auto area = [](const Feature& f) {
    return static_cast<std::int64_t>(f.max.x - f.min.x + 1) * (f.max.y - f.min.y + 1);
  };
  return 2 * dx * dy > std::min(area(a), area(b));
}

inline std::size_t band_table_size(const MapConfig& config) {
  return static_cast<std::size_t>(config.zone_cells[0] + 1) * (config.zone_cells[1] + 1);
}

inline std::uint32_t find_root(std::uint32_t* parent, std::uint32_t i) {
  while (parent[i] != i) {  // path halving: bounded by the tree height
    parent[i] = parent[parent[i]];
    i = parent[i];
  }
  return i;
}

}  // namespace zonemap
