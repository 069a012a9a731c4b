#include "zonemap/depth/depth_range_table.hpp"

#include <algorithm>
#include <bit>
#include <cstring>

#include "common/simd_u16.hpp"

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

void DepthRangeTable::build(WorkSplit* split) {
  if (levels_ < 2) return;
  // A level at a time (each reads the one below it whole), its rows shared
  // among the split's parts in bands: every level is the same for any split.
  const int parts = split == nullptr ? 1 : std::min(split->parts(), kMaxBuildParts);
  for (int level = 1; level < levels_; ++level) {
    for_each_part(split, parts, [&](int part, int all) {
      // Parts write disjoint rows of each level.
      const int first = height_ * part / all, end = height_ * (part + 1) / all;
      if (level == 1) {
        first_level_rows(first, end);
      } else {
        square_rows(pairs_[static_cast<std::size_t>(level - 1)],
                    pairs_[static_cast<std::size_t>(level)], 1 << (level - 1), first, end);
      }
    });
  }
}

namespace {

// A code's half of a (min, 0xFFFF - max) pair: a missing pixel is 0xFFFF in
// both halves, so that neither minimum counts it.
inline U16x8 inverse_of(U16x8 c) {
  const auto missing = reinterpret_cast<U16x8>(c == simd::splat_u16(DepthRangeTable::kMissing));
  return (simd::splat_u16(0xFFFF) - c) | missing;
}

}  // namespace

// Level 1 straight from the codes: the pair of each 2x2 square (cut at the
// image's right and bottom edges), rows [first, end).
void DepthRangeTable::first_level_rows(int first, int end) {
  std::uint16_t* out = pairs_[1];
  const std::uint16_t* c = codes_.get();
  const std::size_t w = static_cast<std::size_t>(width_);
  for (int y = first; y < end; ++y) {
    const std::uint16_t* a = c + static_cast<std::size_t>(y) * w;
    const std::uint16_t* b = c + static_cast<std::size_t>(std::min(y + 1, height_ - 1)) * w;
    std::uint16_t* o = out + 2 * static_cast<std::size_t>(y) * w;
    std::size_t x = 0;
    for (; x + 9 <= w; x += 8) {
      const U16x8 a0 = load_u16(a + x), a1 = load_u16(a + x + 1);
      const U16x8 b0 = load_u16(b + x), b1 = load_u16(b + x + 1);
      const U16x8 mn = min_u16(min_u16(a0, a1), min_u16(b0, b1));
      const U16x8 inv =
          min_u16(min_u16(inverse_of(a0), inverse_of(a1)), min_u16(inverse_of(b0), inverse_of(b1)));
      const U16x8 lo = __builtin_shufflevector(mn, inv, 0, 8, 1, 9, 2, 10, 3, 11);
      const U16x8 hi = __builtin_shufflevector(mn, inv, 4, 12, 5, 13, 6, 14, 7, 15);
      std::memcpy(o + 2 * x, &lo, sizeof lo);
      std::memcpy(o + 2 * x + 8, &hi, sizeof hi);
    }
    for (; x < w; ++x) {
      const std::size_t x1 = std::min(x + 1, w - 1);
      const std::uint16_t v[4] = {a[x], a[x1], b[x], b[x1]};
      std::uint16_t mn = 0xFFFF, inv = 0xFFFF;
      for (const std::uint16_t code : v) {
        mn = std::min(mn, code);
        inv = std::min(inv, code == kMissing ? std::uint16_t{0xFFFF}
                                             : static_cast<std::uint16_t>(0xFFFF - code));
      }
      o[2 * x] = mn;
      o[2 * x + 1] = inv;
    }
  }
}

// out(x, y) = min of in at (x, y), (x + half, y), (x, y + half), (x + half, y + half),
// cut at the image's right and bottom edges; element-wise over (min, ~max)
// pairs, rows [first, end).
void DepthRangeTable::square_rows(const std::uint16_t* in, std::uint16_t* out, int half, int first,
                                  int end) {
  const std::size_t row_values = 2 * static_cast<std::size_t>(width_);
  const std::size_t inner = 2 * static_cast<std::size_t>(std::max(width_ - half, 0));
  const std::size_t shift = 2 * static_cast<std::size_t>(half);
  for (int y = first; y < end; ++y) {
    const std::uint16_t* a = in + static_cast<std::size_t>(y) * row_values;
    const std::uint16_t* b =
        in + static_cast<std::size_t>(std::min(y + half, height_ - 1)) * row_values;
    std::uint16_t* o = out + static_cast<std::size_t>(y) * row_values;
    std::size_t i = 0;
    for (; i + 8 <= inner; i += 8) {
      const U16x8 m = min_u16(min_u16(load_u16(a + i), load_u16(a + i + shift)),
                              min_u16(load_u16(b + i), load_u16(b + i + shift)));
      std::memcpy(o + i, &m, sizeof m);
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
