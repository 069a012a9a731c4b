// Min/max depth over any image rectangle in O(1), for the projective (fast)
// integration path: a 2-D sparse table of the depth frame (for each level l and
// pixel, the minimum and maximum over the 2^l x 2^l square starting there). A
// rectangle is covered by a few overlapping squares. Raw 16-bit depth values
// keep it small; reserved once for the camera size.
//
// Layout, chosen for the query: each level above 0 stores per pixel the pair
// (min, 0xFFFF - max), so one 32-bit load answers a square and the build is one
// element-wise minimum over plain uint16 arrays (vectorises on SSE2 and NEON).
// Level 0 is the frame's codes themselves.
#pragma once

#include <algorithm>
#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <memory>

#include "zonemap/common/work_split.hpp"

namespace zonemap {

class DepthRangeTable {
 public:
  // Codes in the raw domain. A real depth is 1..kMaxDepthCode.
  static constexpr std::uint16_t kFar = 0xFFFE;      // free up to d_max (sky, > d_max)
  static constexpr std::uint16_t kMissing = 0xFFFF;  // no usable ray
  static constexpr std::uint16_t kMaxDepthCode = 0xFFFD;
  static constexpr int kMaxLevels =
      5;  // squares up to 16 x 16 pixels (larger rectangles: a few more)

  DepthRangeTable(int width, int height);

  // Level 0: one code per pixel. Then build() makes the other levels, each
  // shared among the split's parts (bands of rows) when one is given.
  std::uint16_t* base() { return codes_.get(); }
  const std::uint16_t* codes() const { return codes_.get(); }
  void build(WorkSplit* split = nullptr);
  static constexpr int kMaxBuildParts = 8;

  // Minimum and maximum code over [x0, x1] x [y0, y1] (inclusive, inside the
  // image), missing pixels left out: lo > hi when every pixel is missing.
  // Inline: the fast path is a handful of loads, called ~10^5 times a frame.
  void range(int x0, int y0, int x1, int y1, std::uint16_t* lo, std::uint16_t* hi) const {
    const int w = x1 - x0 + 1;
    const int h = y1 - y0 + 1;
    // The largest square that fits: side = 2^l <= min(w, h).
    const int l = std::min(
        static_cast<int>(std::bit_width(static_cast<unsigned>(std::min(w, h)))) - 1, levels_ - 1);
    if (l > 0 && w <= 2 << l && h <= 2 << l) {
      // The common case: the four corner squares cover the rectangle.
      const int side = 1 << l;
      const std::uint16_t* table = pairs_[static_cast<std::size_t>(l)];
      const std::size_t row = 2 * static_cast<std::size_t>(width_);
      const std::uint16_t* p00 = table + static_cast<std::size_t>(y0) * row + 2 * x0;
      const std::size_t dx = 2 * static_cast<std::size_t>(x1 - side + 1 - x0);
      const std::size_t dy = static_cast<std::size_t>(y1 - side + 1 - y0) * row;
      *lo = std::min(std::min(p00[0], p00[dx]), std::min(p00[dy], p00[dy + dx]));
      *hi = static_cast<std::uint16_t>(0xFFFF - std::min(std::min(p00[1], p00[dx + 1]),
                                                         std::min(p00[dy + 1], p00[dy + dx + 1])));
      return;
    }
    if (l > 0 && w <= 3 << l && h <= 3 << l) {
      // Elongated footprints (and tiles cut at a footprint's edge): three squares
      // per axis, first, middle and last (coinciding when two suffice).
      const int side = 1 << l;
      const std::uint16_t* table = pairs_[static_cast<std::size_t>(l)];
      const std::size_t row = 2 * static_cast<std::size_t>(width_);
      const std::size_t xs[3] = {2 * static_cast<std::size_t>(x0),
                                 2 * static_cast<std::size_t>(std::min(x0 + side, x1 - side + 1)),
                                 2 * static_cast<std::size_t>(x1 - side + 1)};
      const std::size_t ys[3] = {static_cast<std::size_t>(y0) * row,
                                 static_cast<std::size_t>(std::min(y0 + side, y1 - side + 1)) * row,
                                 static_cast<std::size_t>(y1 - side + 1) * row};
      std::uint16_t mn = 0xFFFF, inv_mx = 0xFFFF;
      for (const std::size_t y : ys) {
        for (const std::size_t x : xs) {
          mn = std::min(mn, table[y + x]);
          inv_mx = std::min(inv_mx, table[y + x + 1]);
        }
      }
      *lo = mn;
      *hi = static_cast<std::uint16_t>(0xFFFF - inv_mx);
      return;
    }
    range_slow(x0, y0, x1, y1, l, lo, hi);
  }

  int width() const { return width_; }
  int height() const { return height_; }
  std::size_t reserved_bytes() const { return bytes_; }

 private:
  void first_level_rows(int first, int end);
  void square_rows(const std::uint16_t* in, std::uint16_t* out, int half, int first, int end);
  // Thin rectangles (one pixel wide) and rectangles larger than two squares of
  // the largest level.
  void range_slow(int x0, int y0, int x1, int y1, int l, std::uint16_t* lo,
                  std::uint16_t* hi) const;

  int width_;
  int height_;
  int levels_;
  std::unique_ptr<std::uint16_t[]> codes_;
  // pairs_[l]: 2 * width * height values, (min, 0xFFFF - max) per pixel; l >= 1.
  std::array<std::uint16_t*, kMaxLevels> pairs_{};
  std::unique_ptr<std::uint16_t[]> storage_;
  std::size_t bytes_;
};

}  // namespace zonemap
