#include "zonemap/depth_range_table.hpp"

#include <algorithm>
#include <bit>

#include "simd_u16.hpp"

namespace zonemap {
using simd::load_u16;
using simd::min_u16;
using simd::U16x8;

DepthRangeTable::DepthRangeTable(int width, int height) : width_(width), height_(height) {
  levels_ = 1;
  while (levels_ < kMaxLevels && (1 << levels_) <= std::max(width, height)) ++levels_;
  const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  const std::size_t pair_values = 2 * n * static_cast<std::size_t>(levels_ - 1);
  codes_.reset(new std::uint16_t[n]());
  storage_.reset(new std::uint16_t[std::max<std::size_t>(pair_values, 1)]());
  bytes_ = (n + pair_values) * sizeof(std::uint16_t);
  for (int l = 1; l < levels_; ++l) {
    pairs_[static_cast<std::size_t>(l)] = storage_.get() + 2 * n * static_cast<std::size_t>(l - 1);
  }
}

void DepthRangeTable::build() {
  if (levels_ < 2) return;
  // Level 1: the pixels' own pairs are written into level 1's storage first,
  // then turned into 2x2 squares in place (every read is at or after the write
  // position, so the pass may run forwards). A missing pixel is 0xFFFF in both
  // halves: min ignores it, and 0xFFFF - max must not count it either.
  {
    std::uint16_t* out = pairs_[1];
    const std::uint16_t* c = codes_.get();
    const std::size_t n = static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_);
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint16_t v = c[i];
      out[2 * i] = v;
      out[2 * i + 1] = static_cast<std::uint16_t>((0xFFFF - v) | (v == kMissing ? 0xFFFF : 0));
    }
    square_pass(out, out, 1);
  }
  // Level l from level l-1: the minimum of four pairs, element-wise.
  for (int l = 2; l < levels_; ++l) {
    square_pass(pairs_[static_cast<std::size_t>(l - 1)], pairs_[static_cast<std::size_t>(l)],
                1 << (l - 1));
  }
}

// out(x, y) = min of in at (x, y), (x + half, y), (x, y + half), (x + half, y + half),
// cut at the image's right and bottom edges; element-wise over (min, ~max) pairs.
void DepthRangeTable::square_pass(const std::uint16_t* in, std::uint16_t* out, int half) const {
  const std::size_t row_values = 2 * static_cast<std::size_t>(width_);
  const std::size_t inner = 2 * static_cast<std::size_t>(std::max(width_ - half, 0));
  const std::size_t shift = 2 * static_cast<std::size_t>(half);
  for (int y = 0; y < height_; ++y) {
    const std::uint16_t* a = in + static_cast<std::size_t>(y) * row_values;
    const std::uint16_t* b =
        in + static_cast<std::size_t>(std::min(y + half, height_ - 1)) * row_values;
    std::uint16_t* o = out + static_cast<std::size_t>(y) * row_values;
    std::size_t i = 0;
    for (; i + 8 <= inner; i += 8) {
      const U16x8 m = min_u16(min_u16(load_u16(a + i), load_u16(a + i + shift)),
                              min_u16(load_u16(b + i), load_u16(b + i + shift)));
      std::memcpy(o + i, &m, sizeof m);  // o may be a: every read above is at or after i
    }
    for (; i < inner; ++i) {
      o[i] = std::min(std::min(a[i], a[i + shift]), std::min(b[i], b[i + shift]));
    }
    // The last columns: the square is cut at the image's right edge.
    const std::size_t last = row_values - 2;
    for (std::size_t k = inner; k < row_values; ++k) {
      const std::size_t j = std::min(k + shift, last + (k & 1));
      o[k] = std::min(std::min(a[k], a[j]), std::min(b[k], b[j]));
    }
  }
}

void DepthRangeTable::range_slow(int x0, int y0, int x1, int y1, int l, std::uint16_t* lo,
                                 std::uint16_t* hi) const {
  std::uint16_t mn = kMissing;
  std::uint16_t inv_mx = 0xFFFF;
  if (l == 0) {  // a one-pixel-wide rectangle: read the codes
    for (int y = y0; y <= y1; ++y) {
      const std::uint16_t* row = codes_.get() + static_cast<std::size_t>(y) * width_;
      for (int x = x0; x <= x1; ++x) {
        const std::uint16_t v = row[x];
        mn = std::min(mn, v);
        inv_mx = std::min(inv_mx, static_cast<std::uint16_t>(v == kMissing ? 0xFFFF : 0xFFFF - v));
      }
    }
  } else {
    const int side = 1 << l;
    const std::uint16_t* table = pairs_[static_cast<std::size_t>(l)];
    // Squares at x0, x0 + side, ..., and one ending at x1 (overlaps are harmless).
    for (int y = y0;; y += side) {
      const int sy = std::min(y, y1 - side + 1);
      for (int x = x0;; x += side) {
        const int sx = std::min(x, x1 - side + 1);
        const std::uint16_t* p = table + 2 * (static_cast<std::size_t>(sy) * width_ + sx);
        mn = std::min(mn, p[0]);
        inv_mx = std::min(inv_mx, p[1]);
        if (sx + side > x1) break;
      }
      if (sy + side > y1) break;
    }
  }
  *lo = mn;
  *hi = static_cast<std::uint16_t>(0xFFFF - inv_mx);
}

}  // namespace zonemap
