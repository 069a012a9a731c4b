// The paper's height profile (fig. 11): for each (x, y) column the highest
// occupied cell. Covers a fixed rectangle of columns reserved at construction;
// zones are folded in when they are discarded (it is a ZoneObserver) and once
// more at the end. Pure computation; hal/output draws it (height.png).
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

#include "zonemap/common/cell.hpp"
#include "zonemap/zones/zone_map.hpp"

namespace zonemap {

class HeightProfile : public ZoneObserver {
 public:
  static constexpr std::int32_t kNoTop = std::numeric_limits<std::int32_t>::min();

  HeightProfile(std::int32_t min_x, std::int32_t min_y, std::int32_t max_x, std::int32_t max_y,
                FusedCell occupied_threshold, bool world_z_up);

  void fold(const ZoneView& zone);
  void on_zone_allocated(ZoneView&) override {}
  void on_zone_discarding(const ZoneView& zone) override { fold(zone); }

  // Columns seen while folding that fell outside the reserved rectangle.
  std::int64_t columns_outside() const { return columns_outside_; }
  // Highest occupied cell index (in "up" terms: z, or -z for NED) or false if none.
  bool top(std::int32_t x, std::int32_t y, std::int32_t* top_cell) const;

  // The rectangle (cell indices from min_x, min_y) and the top of its column
  // (cx, cy) counted from there: kNoTop when none.
  std::int32_t min_x() const { return min_x_; }
  std::int32_t min_y() const { return min_y_; }
  std::int32_t width() const { return width_; }
  std::int32_t height() const { return height_; }
  bool world_z_up() const { return z_up_; }
  std::int32_t top_in_rectangle(std::int32_t cx, std::int32_t cy) const {
    return tops_[static_cast<std::size_t>(cy) * static_cast<std::size_t>(width_) +
                 static_cast<std::size_t>(cx)];
  }
  const std::vector<std::int32_t>& tops() const { return tops_; }

 private:
  std::int32_t min_x_, min_y_, width_, height_;
  FusedCell threshold_;
  bool z_up_;
  std::vector<std::int32_t> tops_;
  std::int64_t columns_outside_ = 0;
};

}  // namespace zonemap
