#include "zonemap/depth_range_table.hpp"

#include <algorithm>

namespace zonemap {

DepthRangeTable::DepthRangeTable(int width, int height) : width_(width), height_(height) {
  levels_ = 1;
  while (levels_ < kMaxLevels && (1 << levels_) <= std::max(width, height)) ++levels_;
  const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  storage_.reset(new std::uint16_t[2 * n * static_cast<std::size_t>(levels_)]());
  bytes_ = 2 * n * static_cast<std::size_t>(levels_) * sizeof(std::uint16_t);
  for (int l = 0; l < levels_; ++l) {
    min_[static_cast<std::size_t>(l)] = storage_.get() + 2 * n * static_cast<std::size_t>(l);
    max_[static_cast<std::size_t>(l)] = min_[static_cast<std::size_t>(l)] + n;
  }
}

void DepthRangeTable::build() {
  const std::size_t n = static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint16_t v = min_[0][i];
    max_[0][i] = v == kMissing ? 0 : v;
  }
  for (int l = 1; l < levels_; ++l) {
    const int half = 1 << (l - 1);
    const std::uint16_t* pmin = min_[static_cast<std::size_t>(l - 1)];
    const std::uint16_t* pmax = max_[static_cast<std::size_t>(l - 1)];
    std::uint16_t* cmin = min_[static_cast<std::size_t>(l)];
    std::uint16_t* cmax = max_[static_cast<std::size_t>(l)];
    for (int y = 0; y < height_; ++y) {
      const int y2 = std::min(y + half, height_ - 1);
      const std::size_t r0 = static_cast<std::size_t>(y) * width_;
      const std::size_t r1 = static_cast<std::size_t>(y2) * width_;
      for (int x = 0; x < width_; ++x) {
        const int x2 = std::min(x + half, width_ - 1);
        cmin[r0 + x] =
            std::min(std::min(pmin[r0 + x], pmin[r0 + x2]), std::min(pmin[r1 + x], pmin[r1 + x2]));
        cmax[r0 + x] =
            std::max(std::max(pmax[r0 + x], pmax[r0 + x2]), std::max(pmax[r1 + x], pmax[r1 + x2]));
      }
    }
  }
}

void DepthRangeTable::range(int x0, int y0, int x1, int y1, std::uint16_t* lo,
                            std::uint16_t* hi) const {
  const int w = x1 - x0 + 1;
  const int h = y1 - y0 + 1;
  int l = 0;
  while (l + 1 < levels_ && (2 << l) <= std::min(w, h)) ++l;
  const int side = 1 << l;
  const std::uint16_t* tmin = min_[static_cast<std::size_t>(l)];
  const std::uint16_t* tmax = max_[static_cast<std::size_t>(l)];
  std::uint16_t mn = kMissing;
  std::uint16_t mx = 0;
  // Squares at x0, x0 + side, ..., and one ending at x1 (overlaps are harmless).
  for (int y = y0;; y += side) {
    const int sy = std::min(y, y1 - side + 1);
    for (int x = x0;; x += side) {
      const int sx = std::min(x, x1 - side + 1);
      const std::size_t i = static_cast<std::size_t>(sy) * width_ + sx;
      mn = std::min(mn, tmin[i]);
      mx = std::max(mx, tmax[i]);
      if (sx + side > x1) break;
    }
    if (sy + side > y1) break;
  }
  *lo = mn;
  *hi = mx;
}

}  // namespace zonemap
