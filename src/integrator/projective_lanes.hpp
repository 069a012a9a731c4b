// The pixel rays of the projective path four at a time (GCC/Clang vector
// extensions: SSE on x86-64, NEON on Arm): a ray of pixel (u, v) clipped to one
// cell's box and its largest m̂ there, and the footprint's rows and tiles the
// ray-by-ray passes walk. Internal to src/: not a public header.
#pragma once

#include <bit>
#include <climits>
#include <cstdint>
#include <cstring>

#include "common/simd_u16.hpp"
#include "zonemap/common/cell.hpp"
#include "zonemap/depth/depth_range_table.hpp"

namespace zonemap {

inline constexpr float kNoRay = -2.0f;

using Lanes = float __attribute__((vector_size(16)));
inline Lanes lanes_min(Lanes a, Lanes b) {
  return a < b ? a : b;
}
inline Lanes lanes_max(Lanes a, Lanes b) {
  return a > b ? a : b;
}
inline Lanes splat(float v) {
  return Lanes{v, v, v, v};
}

// What clipping pixel rays against one cell needs, each value in four equal
// lanes (set once per frame or per cell, not per four rays). Rays relative to
// the camera centre, in world axes: the ray of pixel (u, v) is δ ↦ δ (w00 + u du
// + v dv) (δ: depth along the optical axis); the cell is the box [lo, hi].
struct RayLanes {
  Lanes w00[3], du[3], dv[3];
  Lanes lo[3], hi[3];
  Lanes d_min, d_max, code_to_m, resolution_factor;
  Lanes min_through;  // see_through: the least δ a ray crosses a cell for (kMinSeenThrough)
};

// see_through's ties (four_rays_any_free_across): a sixteenth of a Q6 step, and
// a thousandth of a cell.
inline constexpr float kFreeAcrossMargin = 1.0f / (16.0f * kCellScale);
inline constexpr float kMinSeenThrough = 1e-3f;

// The float whose bits are `magnitude_bits` with x's sign, a lane each (-0 and
// +0 too: the sign bit alone decides).
inline Lanes with_sign_of(Lanes x, std::int32_t magnitude_bits) {
  using Ints = std::int32_t __attribute__((vector_size(16)));
  const Ints sign = reinterpret_cast<Ints>(x) & std::int32_t{INT32_MIN};
  return reinterpret_cast<Lanes>(sign | magnitude_bits);
}
inline constexpr std::int32_t kTinyBits = 0x1e3ce508;
static_assert(std::bit_cast<float>(kTinyBits) == 1e-20f, "the bits of 1e-20f");

// Four pixel rays clipped to the box [lo, hi] (camera centre at the origin; the
// ray of pixel (u, v) is δ ↦ δ (w00 + u du + v dv)): the δ at which each enters
// and leaves it (from d_min on), written without branches.
struct Clipped {
  Lanes enter, leave;
};
inline Clipped clip_to_cell(Lanes u, Lanes v, const RayLanes& r) {
  Lanes enter = r.d_min, leave = splat(1e30f);
  for (int k = 0; k < 3; ++k) {
    const Lanes w = r.w00[k] + u * r.du[k] + v * r.dv[k];
    // A ray parallel to a slab: a tiny offset of w's sign keeps the products
    // finite (its sign bit on 1e-20's bits: two logic operations, no blend).
    const Lanes safe = w + with_sign_of(w, kTinyBits);
    const Lanes inv = 1.0f / safe;
    const Lanes ta = r.lo[k] * inv, tb = r.hi[k] * inv;
    enter = lanes_max(enter, lanes_min(ta, tb));
    leave = lanes_min(leave, lanes_max(ta, tb));
  }
  return {enter, leave};
}

// The largest m̂ over each clipped ray's part inside the box, kNoRay where a ray
// does not cross it. Same rule as the reference (value_for_code over the part
// inside).
inline Lanes values_in_cell(Lanes code, Clipped clipped, const RayLanes& r) {
  const Lanes enter = clipped.enter, leave = clipped.leave;
  const auto far = code == static_cast<float>(DepthRangeTable::kFar);
  const auto missing = code == static_cast<float>(DepthRangeTable::kMissing);
  const Lanes d = code * r.code_to_m;
  const Lanes resolution = lanes_max(d * d * r.resolution_factor, splat(1e-6f));
  const Lanes end = far ? r.d_max : lanes_min(d + resolution, r.d_max);
  const Lanes delta = lanes_min(lanes_max(d, enter), lanes_min(leave, end));
  const Lanes offset = delta - d;
  // Eq. (4)/(5) as one expression: continuous, -1 up to d - 2Δd, peak at d, 0
  // at d + Δd (delta never goes past the ray's end).
  const Lanes peak = 1.0f - (offset < 0.0f ? -offset : offset) / resolution;
  Lanes value = lanes_max(peak, splat(-1.0f));
  value = far ? splat(-1.0f) : value;
  const auto crosses = (missing == 0) & (enter < leave) & (enter <= end);
  return crosses ? value : splat(kNoRay);
}

inline Lanes rays_best(Lanes u, Lanes v, Lanes code, const RayLanes& r) {
  return values_in_cell(code, clip_to_cell(u, v, r), r);
}

inline float lanes_hmax(Lanes v) {
  return std::max(std::max(v[0], v[1]), std::max(v[2], v[3]));
}

// Which halves of row y's columns [x0, x0 + count) (count <= 8) hold a code in
// [lo, hi]: bit 0 for columns x0..x0+3, bit 1 for x0+4.. (one load of eight codes
// inside the image, lanes outside masked).
__attribute__((always_inline)) inline int row_halves_with_code_in(const std::uint16_t* codes,
                                                                  int width, int x0, int count,
                                                                  int y, std::uint16_t lo,
                                                                  std::uint16_t hi) {
  using simd::U16x8;
  if (width < 8) {  // an image narrower than one load
    int halves = 0;
    for (int x = x0; x < x0 + count; ++x) {
      const std::uint16_t c = codes[static_cast<std::size_t>(y) * width + x];
      if (c >= lo && c <= hi) halves |= x - x0 < 4 ? 1 : 2;
    }
    return halves;
  }
  const int start = std::min(x0, width - 8);
  const U16x8 c = simd::load_u16(codes + static_cast<std::size_t>(y) * width + start);
  const U16x8 lane = {0, 1, 2, 3, 4, 5, 6, 7};
  const auto first = static_cast<std::uint16_t>(x0 - start);
  const auto middle = static_cast<std::uint16_t>(first + std::min(count, 4));
  const auto end = static_cast<std::uint16_t>(first + count);
  const U16x8 out_of_range =
      simd::saturating_sub(simd::splat_u16(lo), c) | simd::saturating_sub(c, simd::splat_u16(hi));
  const auto in_range = reinterpret_cast<U16x8>(out_of_range == U16x8{});
  const auto first_half =
      reinterpret_cast<U16x8>((lane >= simd::splat_u16(first)) & (lane < simd::splat_u16(middle)));
  const auto second_half =
      reinterpret_cast<U16x8>((lane >= simd::splat_u16(middle)) & (lane < simd::splat_u16(end)));
  return (simd::any_u16(in_range & first_half) ? 1 : 0) |
         (simd::any_u16(in_range & second_half) ? 2 : 0);
}

// m, m + 1, m - 1, m + 2, ...: the i-th of [0, n) from the middle out (i, n >= 0).
inline int middle_out(int i, int n) {
  const auto offset = static_cast<int>((static_cast<unsigned>(i) + 1) >> 1);
  return static_cast<int>((static_cast<unsigned>(n) - 1) >> 1) + ((i & 1) ? offset : -offset);
}

// Footprints are looked at in tiles kTileW pixels wide (one range query each,
// rows of at most eight codes: one load). The searches for one ray (exact_value's
// first pass, any_ray_crosses) use a tile's range only to pass it over: tall
// tiles, fewer queries. The exact maximum may take a tile's range as the bound of
// its rays: short tiles, tighter bounds. exact_value keeps the search tiles'
// ranges of up to kKeptTileRanges tiles for its second pass (as a first filter;
// a 4 cm cell at 1 m: ~24 x 24 px).
inline constexpr int kTileW = 8, kSearchTileH = 8, kBoundTileH = 4;
static_assert(kSearchTileH % kBoundTileH == 0, "each bound tile lies in one search tile");
inline constexpr int kKeptTileRanges = 64;

// Calls visit(tx, ty, ex, ey) on the tiles of [x0, x1] x [y0, y1], rows and
// columns of tiles from the middle out (the rays near a footprint's centre cross
// the cell: its silhouette leaves the rectangle's corners empty), until it
// returns true; then true. Inlined with its visitor (the ray-by-ray passes' hot
// loop: a call per tile costs 1.5% of a frame).
template <class Visit>
__attribute__((always_inline)) inline bool tiles_middle_out(int x0, int y0, int x1, int y1,
                                                            Visit&& visit) {
  const int tile_rows = (y1 - y0) / kSearchTileH + 1, tile_cols = (x1 - x0) / kTileW + 1;
  for (int row_i = 0; row_i < tile_rows; ++row_i) {
    const int ty = y0 + kSearchTileH * middle_out(row_i, tile_rows);
    for (int col_i = 0; col_i < tile_cols; ++col_i) {
      const int tx = x0 + kTileW * middle_out(col_i, tile_cols);
      if (visit(tx, ty, std::min(tx + kTileW - 1, x1), std::min(ty + kSearchTileH - 1, y1)))
        return true;
    }
  }
  return false;
}

// The codes of row pixels u0 .. u0 + count - 1 (count <= 4), a lane each: one
// load of four when they lie inside the row, lanes past count missing.
__attribute__((always_inline)) inline Lanes four_codes(const std::uint16_t* row, int width, int u0,
                                                       int count) {
  using U16x4 = std::uint16_t __attribute__((vector_size(8)));
  using Ints = std::int32_t __attribute__((vector_size(16)));
  Lanes code;
  if (u0 + 4 <= width) {
    U16x4 four;
    std::memcpy(&four, row + u0, sizeof four);
    const Ints lane = {0, 1, 2, 3};
    // Widened to 32 bits first: one unpack (SSE2, NEON) instead of four scalar
    // conversions.
    const Ints wide = __builtin_convertvector(four, Ints);
    code = __builtin_convertvector(lane < count ? wide : Ints{} + DepthRangeTable::kMissing, Lanes);
  } else {
    code = splat(static_cast<float>(DepthRangeTable::kMissing));
    for (int i = 0; i < count; ++i) code[i] = static_cast<float>(row[u0 + i]);
  }
  return code;
}

inline Lanes four_columns(int u0) {
  return splat(static_cast<float>(u0)) + Lanes{0.0f, 1.0f, 2.0f, 3.0f};
}

// m̂ of row v's rays u0 .. u0 + count - 1 (count <= 4) in the cell, a lane each
// (kNoRay where a ray misses it).
__attribute__((always_inline)) inline Lanes four_rays_values(const std::uint16_t* row, int width,
                                                             int u0, int v, int count,
                                                             const RayLanes& rays) {
  return rays_best(four_columns(u0), splat(static_cast<float>(v)),
                   four_codes(row, width, u0, count), rays);
}

// The largest of them.
__attribute__((always_inline)) inline float four_rays_best(const std::uint16_t* row, int width,
                                                           int u0, int v, int count,
                                                           const RayLanes& rays) {
  return lanes_hmax(four_rays_values(row, width, u0, v, count, rays));
}

// Whether one of them crosses the cell wholly in its free part: m̂ at most -1 in
// Q6 (what the reference's cell would hold for that ray alone).
// A tie goes to max-write (the safe side, where the two paths' float rounding
// may differ in the last bit): a ray whose m̂ lies within kFreeAcrossMargin of
// the Q6 step's edge, or that crosses less than kMinSeenThrough cells (an edge
// or a corner grazed), does not count.
__attribute__((always_inline)) inline bool four_rays_any_free_across(const std::uint16_t* row,
                                                                     int width, int u0, int v,
                                                                     int count,
                                                                     const RayLanes& rays) {
  const Clipped clipped = clip_to_cell(four_columns(u0), splat(static_cast<float>(v)), rays);
  const Lanes values = values_in_cell(four_codes(row, width, u0, count), clipped, rays);
  const auto free = (values >= -1.0f) &
                    (values <= (0.5f - kCellScale) / kCellScale - kFreeAcrossMargin) &
                    (clipped.leave - clipped.enter >= rays.min_through);
  return (free[0] | free[1] | free[2] | free[3]) != 0;
}

// Whether one of them ended before the cell (its measured depth at most where
// it enters) and keeps m̂ >= near_peak (Q6) in it. A tie goes to keeping the
// cell: the bar is lowered by kFreeAcrossMargin (as four_rays_any_free_across).
__attribute__((always_inline)) inline bool four_rays_near_peak_behind(const std::uint16_t* row,
                                                                      int width, int u0, int v,
                                                                      int count, int near_peak,
                                                                      const RayLanes& rays) {
  const Clipped clipped = clip_to_cell(four_columns(u0), splat(static_cast<float>(v)), rays);
  const Lanes code = four_codes(row, width, u0, count);
  const Lanes values = values_in_cell(code, clipped, rays);
  const float bar = (static_cast<float>(near_peak) - 0.5f) / kCellScale - kFreeAcrossMargin;
  const auto kept = (values >= bar) & (clipped.leave >= code * rays.code_to_m);
  return (kept[0] | kept[1] | kept[2] | kept[3]) != 0;
}

}  // namespace zonemap
