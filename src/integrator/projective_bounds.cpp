// The bounds from a footprint's depth range: the largest m̂ its pixels' rays
// can give a cell (the tiers' upper bound U).
#include <algorithm>
#include <cmath>

#include "integrator/projective_detail.hpp"

namespace zonemap {
namespace {

// Where a rectangle's codes lie around the codes [lo, hi] of a cell's depth
// interval: whether one is inside, the largest below and the smallest above
// (kFar counts as above, missing pixels nowhere). Eight codes at a time.
struct CodeSides {
  bool inside = false;
  bool any_below = false, any_above = false;
  std::uint16_t below = 0, above = 0;
};

CodeSides code_sides(const std::uint16_t* codes, int width, int x0, int y0, int x1, int y1,
                     std::uint16_t lo, std::uint16_t hi) {
  using simd::U16x8;
  const U16x8 lo_v = simd::splat_u16(lo), hi_v = simd::splat_u16(hi);
  const U16x8 missing_v = simd::splat_u16(DepthRangeTable::kMissing);
  const U16x8 one = simd::splat_u16(1);
  // Per lane: lo - c for codes below (else 0) and c - hi for codes above (else 0),
  // minus one so that "none" is 0xFFFF; minima over all lanes. A code is inside
  // when both are 0 (missing codes are above, then masked off).
  U16x8 below_gap = missing_v, above_gap = missing_v, inside = U16x8{};
  const auto add = [&](U16x8 c) {
    const U16x8 below = simd::saturating_sub(lo_v, c);
    const U16x8 above = simd::saturating_sub(c, hi_v);
    const auto is_missing = reinterpret_cast<U16x8>(c == missing_v);
    below_gap = simd::min_u16(below_gap, below - one);
    above_gap = simd::min_u16(above_gap, (above - one) | is_missing);
    inside |= reinterpret_cast<U16x8>((below | above) == U16x8{});
  };
  const U16x8 lane = {0, 1, 2, 3, 4, 5, 6, 7};
  if (width < 8) {
    // An image narrower than one load: a code at a time.
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        U16x8 c = missing_v;
        c[0] = codes[static_cast<std::size_t>(y) * width + x];
        add(c);
      }
    }
  } else if (x1 - x0 + 1 < 8) {
    // Narrow: one load inside the image, lanes outside the rectangle made missing.
    const int start = std::min(x0, width - 8);
    const U16x8 outside =
        reinterpret_cast<U16x8>((lane < simd::splat_u16(static_cast<std::uint16_t>(x0 - start))) |
                                (lane > simd::splat_u16(static_cast<std::uint16_t>(x1 - start))));
    for (int y = y0; y <= y1; ++y) {
      add(simd::load_u16(codes + static_cast<std::size_t>(y) * width + start) | outside);
    }
  } else {
    // Loads of eight, the last one ending at x1 (overlaps change no minimum).
    // Rows from the middle out: a code inside [lo, hi] ends the scan, and on a
    // noisy surface one is usually found in the first rows.
    const int middle = (y0 + y1) / 2;
    for (int k = 0, up = middle, down = middle - 1; up <= y1 || down >= y0; ++k) {
      const bool take_up = up <= y1 && ((k & 1) == 0 || down < y0);
      const int y = take_up ? up++ : down--;
      const std::uint16_t* row = codes + static_cast<std::size_t>(y) * width;
      for (int x = x0;; x += 8) {
        const int start = std::min(x, x1 - 7);
        add(simd::load_u16(row + start));
        if (start + 8 > x1) break;
      }
      if (simd::any_u16(inside)) {
        CodeSides sides;
        sides.inside = true;
        return sides;
      }
    }
  }
  CodeSides sides;
  std::uint16_t b = 0xFFFF, u = 0xFFFF;
  for (int i = 0; i < 8; ++i) {
    b = std::min(b, below_gap[i]);
    u = std::min(u, above_gap[i]);
    sides.inside = sides.inside || inside[i] != 0;
  }
  sides.any_below = b != 0xFFFF;
  sides.any_above = u != 0xFFFF;
  sides.below = static_cast<std::uint16_t>(lo - 1 - b);
  sides.above = static_cast<std::uint16_t>(hi + 1 + u);
  return sides;
}

}  // namespace

float ProjectiveIntegrator::best_value(const DepthRangeTable& depths, int x0, int y0, int x1,
                                       int y1, std::uint16_t lo, std::uint16_t hi, float a,
                                       float b) const {
  // Over a set of depths entirely below a the largest one decides (m̂(a; d)
  // rises with d); entirely above b, m̂(b; d) falls with d and, when Δd is large
  // (d past 2b), rises again: the larger of its two ends decides.
  if (lo > hi) return kNoRay;  // no usable pixel
  const float a_code = a / code_to_m_;
  const float b_code = b / code_to_m_;
  if (static_cast<float>(hi) < a_code) return value_for_code(hi, a, b);
  if (static_cast<float>(lo) > b_code)
    return std::max(value_for_code(lo, a, b), far_end(lo, hi, a, b));
  // lo <= b and hi >= a. A pixel with its depth inside [a, b] is the peak.
  if (static_cast<float>(lo) >= a_code || static_cast<float>(hi) <= b_code) return 1.0f;
  // lo < a <= b < hi. On a continuous surface (depths spread over less than
  // half Δd) the depths next to a and b are within Δd/2 of them, so the
  // largest m̂ is in [0.5, 1]: take the peak.
  const float lo_m = static_cast<float>(lo) * code_to_m_;
  const float hi_m = hi == DepthRangeTable::kFar ? 1e30f : static_cast<float>(hi) * code_to_m_;
  if (hi_m - lo_m <= 0.5f * lo_m * lo_m * resolution_factor_) return 1.0f;
  // Depths on both sides of [a, b] (a noisy surface, or an edge with the cell
  // between its sides): the codes themselves say which are nearest on each side.
  const float top = static_cast<float>(DepthRangeTable::kMaxDepthCode);
  const auto inside_lo = static_cast<std::uint16_t>(std::clamp(std::ceil(a_code), 1.0f, top));
  const auto inside_hi = static_cast<std::uint16_t>(std::clamp(std::floor(b_code), 0.0f, top));
  const CodeSides sides =
      code_sides(depths.codes(), depths.width(), x0, y0, x1, y1, inside_lo, inside_hi);
  if (sides.inside) return 1.0f;
  float best = kNoRay;
  if (sides.any_below) best = value_for_code(sides.below, a, b);
  if (sides.any_above) {
    // The depths above b run from the smallest found to hi, the range's largest.
    best = std::max(best, std::max(value_for_code(sides.above, a, b), far_end(lo, hi, a, b)));
  }
  return best;
}

}  // namespace zonemap
