#include "zonemap/outputs/height_profile.hpp"

#include <algorithm>

namespace zonemap {

HeightProfile::HeightProfile(std::int32_t min_x, std::int32_t min_y, std::int32_t max_x,
                             std::int32_t max_y, FusedCell occupied_threshold, bool world_z_up)
    : min_x_(min_x),
      min_y_(min_y),
      width_(std::max(1, max_x - min_x + 1)),
      height_(std::max(1, max_y - min_y + 1)),
      threshold_(occupied_threshold),
      z_up_(world_z_up),
      tops_(static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_), kNoTop) {}

void HeightProfile::fold(const ZoneView& zone) {
  // It runs on the mapping thread when a zone leaves: plane by plane along
  // contiguous x rows (a column-by-column scan strides a whole plane per step,
  // 10-20 ms a zone). A column's top is the largest "up" coordinate of its
  // occupied cells, so the planes may come in any order.
  const auto clip = [](std::int32_t v, int n) { return static_cast<int>(std::clamp(v, 0, n)); };
  const int x0 = clip(min_x_ - zone.origin.x, zone.dims[0]);
  const int x1 = clip(min_x_ + width_ - zone.origin.x, zone.dims[0]);  // exclusive
  const int y0 = clip(min_y_ - zone.origin.y, zone.dims[1]);
  const int y1 = clip(min_y_ + height_ - zone.origin.y, zone.dims[1]);
  for (int z = 0; z < zone.dims[2]; ++z) {
    const std::int32_t world_z = zone.origin.z + z;
    const std::int32_t up = z_up_ ? world_z : -world_z;
    for (int y = y0; y < y1; ++y) {
      const FusedCell* row = zone.cells + zone.index(x0, y, z);
      std::int32_t* tops = tops_.data() +
                           static_cast<std::size_t>(zone.origin.y + y - min_y_) * width_ +
                           (zone.origin.x + x0 - min_x_);
      for (int x = 0; x < x1 - x0; ++x) {
        tops[x] = row[x] > threshold_ ? std::max(tops[x], up) : tops[x];
      }
    }
  }
  // Columns outside the picture (none while the rectangle covers the flight):
  // counted, once per zone column holding an occupied cell.
  if (x0 == 0 && x1 == zone.dims[0] && y0 == 0 && y1 == zone.dims[1]) return;
  for (int y = 0; y < zone.dims[1]; ++y) {
    for (int x = 0; x < zone.dims[0]; ++x) {
      if (x >= x0 && x < x1 && y >= y0 && y < y1) continue;
      for (int z = 0; z < zone.dims[2]; ++z) {
        if (zone.cells[zone.index(x, y, z)] > threshold_) {
          ++columns_outside_;
          break;
        }
      }
    }
  }
}

bool HeightProfile::top(std::int32_t x, std::int32_t y, std::int32_t* top_cell) const {
  const std::int32_t cx = x - min_x_;
  const std::int32_t cy = y - min_y_;
  if (cx < 0 || cy < 0 || cx >= width_ || cy >= height_) return false;
  const std::int32_t t = tops_[static_cast<std::size_t>(cy) * width_ + cx];
  if (t == kNoTop) return false;
  *top_cell = t;
  return true;
}

}  // namespace zonemap
