#include "zonemap/projective_integrator.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

#include "simd_u16.hpp"
#include "zonemap/sensor_model.hpp"

namespace zonemap {
namespace {

constexpr float kNoRay = -2.0f;
// Block classes (see classify_blocks).
constexpr std::uint8_t kBlockMixed = 0;   // look at each cell
constexpr std::uint8_t kBlockFree = 1;    // every ray near it is free across it
constexpr std::uint8_t kBlockUnseen = 2;  // no ray reaches it (or no pixel sees it)

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
constexpr float kFreeAcrossMargin = 1.0f / (16.0f * kCellScale);
constexpr float kMinSeenThrough = 1e-3f;

// The camera's frustum (image borders, d_min, d_max) as six world-frame
// half-spaces n . p >= c, widened so that a cube of side `side` whose centre is
// outside cannot reach into it.
struct Frustum {
  Eigen::Vector3d normals[6];
  double offsets[6];
  double inv_nx[6];  // 1 / n.x (0 for planes parallel to x), set by make_frustum

  // The indices i of the centres (base_x + i * step, wy, wz), 0 <= i < count,
  // inside every half-space: [*lo, *hi]; false when there are none. (Once per
  // row of cells: products with reciprocals, no divisions.)
  bool row(double wy, double wz, double base_x, double inv_step, int count, int* lo,
           int* hi) const {
    double x_lo = 0.0, x_hi = count - 1;
    for (int i = 0; i < 6 && x_lo <= x_hi; ++i) {
      const Eigen::Vector3d& n = normals[i];
      const double rest = n.y() * wy + n.z() * wz - offsets[i];  // n.x * X + rest >= 0
      if (inv_nx[i] == 0.0) {
        if (rest < 0.0) x_hi = -1.0;
        continue;
      }
      const double bound = (-rest * inv_nx[i] - base_x) * inv_step;  // in indices
      if (n.x() > 0.0) {
        x_lo = std::max(x_lo, std::ceil(bound));
      } else {
        x_hi = std::min(x_hi, std::floor(bound));
      }
    }
    if (x_lo > x_hi) return false;
    *lo = static_cast<int>(x_lo);
    *hi = static_cast<int>(x_hi);
    return true;
  }
};

Frustum make_frustum(const Eigen::Isometry3d& world_T_camera, const CameraModel& camera,
                     double d_min, double d_max, double side) {
  const Eigen::Matrix3d r = world_T_camera.linear();
  const Eigen::Vector3d t = world_T_camera.translation();
  // Half extent of the cube along the optical axis, and its half diagonal.
  const double half_z = 0.5 * side * r.col(2).cwiseAbs().sum();
  const double margin = 0.5 * side * std::sqrt(3.0);
  const double kl = (0.0 - camera.cx) / camera.fx, kr = (camera.width - 1 - camera.cx) / camera.fx;
  const double kt = (0.0 - camera.cy) / camera.fy, kb = (camera.height - 1 - camera.cy) / camera.fy;
  Frustum f{{{1, 0, -kl}, {-1, 0, kr}, {0, 1, -kt}, {0, -1, kb}, {0, 0, 1}, {0, 0, -1}},
            {0, 0, 0, 0, d_min - half_z, -(d_max + half_z)},
            {}};
  for (int i = 0; i < 6; ++i) {
    const double len = f.normals[i].norm();
    f.normals[i] /= len;
    f.offsets[i] /= len;
    f.offsets[i] -= margin;
    // To the world frame: n_c . R^T (p - t) >= c  <=>  (R n_c) . p >= c + (R n_c) . t
    f.normals[i] = r * f.normals[i];
    f.offsets[i] += f.normals[i].dot(t);
    f.inv_nx[i] = std::fabs(f.normals[i].x()) < 1e-12 ? 0.0 : 1.0 / f.normals[i].x();
  }
  return f;
}

}  // namespace

// The pixel rays of one cell (see RayLanes).
struct ProjectiveIntegrator::CellRays {
  RayLanes rays{};           // lo, hi: the cell's world box minus the camera centre
  float a = 0.0f, b = 0.0f;  // the cell's δ-support (camera-frame z range, from d_min)
  int enough_fixed = 0;      // the ray-by-ray search may stop at this cell value
};

ProjectiveIntegrator::ProjectiveIntegrator(const MapConfig& config, const CameraModel& camera)
    : cell_size_m_(config.cell_size_m),
      blocks_{(config.zone_cells[0] + kBlock - 1) / kBlock,
              (config.zone_cells[1] + kBlock - 1) / kBlock,
              (config.zone_cells[2] + kBlock - 1) / kBlock},
      block_count_(static_cast<std::size_t>(blocks_[0]) * static_cast<std::size_t>(blocks_[1]) *
                   static_cast<std::size_t>(blocks_[2])),
      block_class_(new std::uint8_t[block_count_]()),
      d_min_(static_cast<float>(config.d_min_m)),
      d_max_(static_cast<float>(config.d_max_m)),
      resolution_factor_(
          static_cast<float>(camera.match_sigma_px / (camera.baseline_m * camera.fx))),
      code_to_m_(static_cast<float>(1.0 / camera.depth_scale)),
      see_through_(config.see_through > 0.0),
      near_peak_fixed_(to_fixed(static_cast<float>(config.see_through))),
      near_peak_behind_fixed_(
          std::min(near_peak_fixed_, to_fixed(static_cast<float>(config.near_peak_behind())))),
      max_real_code_(static_cast<std::uint16_t>(
          std::clamp(std::floor(config.d_max_m * camera.depth_scale), 1.0,
                     static_cast<double>(DepthRangeTable::kMaxDepthCode)))),
      camera_(camera) {}

// m̂ maximised over the part of [a, b] the ray covers: the ray of depth d runs
// from d_min to min(d + Δd, d_max) (free-only rays to d_max).
inline float ProjectiveIntegrator::value_for_code(std::uint16_t code, float a, float b) const {
  if (code == DepthRangeTable::kFar) return a <= d_max_ ? -1.0f : kNoRay;
  const float d = static_cast<float>(code) * code_to_m_;
  const float resolution = std::max(d * d * resolution_factor_, 1e-6f);
  const float end = std::min(d + resolution, d_max_);
  if (a > end) return kNoRay;
  return sensor_model_value(std::clamp(d, a, std::min(b, end)), d, resolution);
}

namespace {

// The pixel rectangle a cube covers: the image box of its eight corners, given
// four at a time as (x, y, z) offsets from its centre (camera frame), clamped
// into the image; x0 > x1 or y0 > y1 when no pixel sees it. All four bounds in
// one vector: the horizontal minima and maxima by two transposing steps, the
// rounding by truncation and a correction (|values| < 2^31 after clamping).
struct PixelRect {
  int x0, y0, x1, y1;
};

struct Projection {
  Lanes corner_x[2], corner_y[2], corner_z[2];
  Lanes scale;   // {fx, fx, fy, fy}
  Lanes offset;  // {-cx, cx, -cy, cy}
  Lanes limit;   // {0, w - 1, 0, h - 1}
};

inline Projection projection_for(const CameraModel& camera) {
  Projection p{};
  const auto fx = static_cast<float>(camera.fx), fy = static_cast<float>(camera.fy);
  const auto cx = static_cast<float>(camera.cx), cy = static_cast<float>(camera.cy);
  p.scale = Lanes{fx, fx, fy, fy};
  p.offset = Lanes{-cx, cx, -cy, cy};
  p.limit = Lanes{0.0f, static_cast<float>(camera.width - 1), 0.0f,
                  static_cast<float>(camera.height - 1)};
  return p;
}

inline PixelRect project_cube(const Projection& p, float px, float py, float pz) {
  using Ints = std::int32_t __attribute__((vector_size(16)));
  const Lanes qz0 = splat(pz) + p.corner_z[0], qz1 = splat(pz) + p.corner_z[1];
  const auto behind = (qz0 < 1e-6f) | (qz1 < 1e-6f);
  Lanes g = p.limit;  // a corner behind the camera: the whole image
  if (!(behind[0] | behind[1] | behind[2] | behind[3])) {
    const Lanes u_a = (splat(px) + p.corner_x[0]) / qz0, u_b = (splat(px) + p.corner_x[1]) / qz1;
    const Lanes v_a = (splat(py) + p.corner_y[0]) / qz0, v_b = (splat(py) + p.corner_y[1]) / qz1;
    // Minima of u, -u, v, -v over the eight corners.
    const Lanes mu = lanes_min(u_a, u_b), nu = -lanes_max(u_a, u_b);
    const Lanes mv = lanes_min(v_a, v_b), nv = -lanes_max(v_a, v_b);
    const Lanes t1 = lanes_min(__builtin_shufflevector(mu, nu, 0, 4, 1, 5),
                               __builtin_shufflevector(mu, nu, 2, 6, 3, 7));
    const Lanes t2 = lanes_min(__builtin_shufflevector(mv, nv, 0, 4, 1, 5),
                               __builtin_shufflevector(mv, nv, 2, 6, 3, 7));
    const Lanes m = lanes_min(__builtin_shufflevector(t1, t2, 0, 1, 4, 5),
                              __builtin_shufflevector(t1, t2, 2, 3, 6, 7));
    // {-u_min - cx, u_max + cx, ...} in pixels: floor of each gives
    // {-ceil(u0), floor(u1), -ceil(v0), floor(v1)}; clamped into the image.
    g = lanes_min(splat(0.0f) - m * p.scale + p.offset, p.limit);
    g = lanes_max(g, splat(-1e6f));
  }
  const Ints truncated = __builtin_convertvector(g, Ints);
  const Ints floored = truncated + (__builtin_convertvector(truncated, Lanes) > g);  // -1 if above
  return PixelRect{-floored[0], -floored[2], floored[1], floored[3]};
}

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
    // A ray parallel to a slab: a tiny offset keeps the products finite.
    const Lanes safe = w < 0.0f ? w - 1e-20f : w + 1e-20f;
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
constexpr int kTileW = 8, kSearchTileH = 8, kBoundTileH = 4;
static_assert(kSearchTileH % kBoundTileH == 0, "each bound tile lies in one search tile");
constexpr int kKeptTileRanges = 64;

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

}  // namespace

// The value of a range's largest depth, for depths above b where m̂(b; d) may
// rise again: a kFar largest hides the largest real depth when there is one (lo
// real), bounded then by d_max's.
inline float ProjectiveIntegrator::far_end(std::uint16_t lo, std::uint16_t hi, float a,
                                           float b) const {
  if (hi != DepthRangeTable::kFar || lo == DepthRangeTable::kFar) return value_for_code(hi, a, b);
  return std::max(value_for_code(hi, a, b), value_for_code(max_real_code_, a, b));
}

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

// The depth codes [*lo, *hi] whose rays can reach into a cell's δ-support
// [a, b] far enough: d + s_lo Δd(d) >= a and d - s_hi Δd(d) <= b (Δd = d²
// factor; s = 1 - m̂ for "m̂ at least ..."), from the roots of the two
// quadratics in d, widened by a code each way: a filter, never the decision.
// d - s Δd(d) falls again past its second root (large Δd): when
// `open_past_second_root` and that root is within d_max, no upper limit.
inline void ProjectiveIntegrator::codes_reaching(float a, float b, float s_lo, float s_hi,
                                                 bool open_past_second_root, std::uint16_t* lo,
                                                 std::uint16_t* hi) const {
  const float top_code = static_cast<float>(DepthRangeTable::kMaxDepthCode);
  const float k_lo = resolution_factor_ * s_lo;
  const float reach_a = (std::sqrt(1.0f + 4.0f * k_lo * a) - 1.0f) / (2.0f * k_lo);
  *lo = static_cast<std::uint16_t>(
      std::clamp(std::floor(reach_a / code_to_m_) - 1.0f, 0.0f, top_code));
  *hi = DepthRangeTable::kMaxDepthCode;
  const float k_hi = resolution_factor_ * s_hi;
  const float disc = 1.0f - 4.0f * k_hi * b;
  if (disc <= 0.0f) return;  // d - s Δd(d) <= b for every d
  const float root = std::sqrt(disc);
  if (open_past_second_root && (1.0f + root) / (2.0f * k_hi) <= d_max_ * (129.0f / 128.0f))
    return;  // (d_max widened as the roots are)
  const float reach_b = (1.0f - root) / (2.0f * k_hi);
  *hi = static_cast<std::uint16_t>(
      std::clamp(std::ceil(reach_b / code_to_m_) + 1.0f, 0.0f, top_code));
}

float ProjectiveIntegrator::exact_value(const DepthRangeTable& depths, int x0, int y0, int x1,
                                        int y1, const CellRays& cell, float best,
                                        std::int64_t* rays) const {
  // The first pass clips only the rays whose depth can reach the sign sought
  // (cell.enough_fixed), found by tile and then by row, and stops at the first
  // that does; when none does, the sign is lower and the second pass takes the
  // exact maximum, each tile bounded by its depth range (the cell's δ-support
  // bounds every ray's part in it).
  // The depths whose rays can reach the value sought, cell.enough_fixed in Q6
  // (0 or 1: the sign; see_through's near peak): m̂ >= (enough - 1/2) / 64, the
  // rounding's edge.
  const float margin =
      1.0f - (static_cast<float>(cell.enough_fixed) - 0.5f) / static_cast<float>(kCellScale);
  std::uint16_t sign_lo = 0, sign_hi = 0;
  codes_reaching(cell.a, cell.b, margin, margin, false, &sign_lo, &sign_hi);
  std::int64_t clipped = 0;
  const auto scan_row = [&](int tx, int v, int count) __attribute__((always_inline)) {
    clipped += count;
    const std::uint16_t* row = depths.codes() + static_cast<std::size_t>(v) * depths.width();
    best = std::max(best, four_rays_best(row, depths.width(), tx, v, count, cell.rays));
  };
  // Pass 1: only rows of tiles with a depth in [sign_lo, sign_hi], and of those
  // only the rows holding such a depth (one vector compare per row), until a ray
  // reaches the sign; tiles from the middle out.
  bool passed_over = false;  // some ray was not clipped in pass 1
  // The tiles' depth ranges, kept for the second pass when the footprint has few
  // enough tiles (the first pass visits them all when it does not stop early).
  const int tile_cols = (x1 - x0) / kTileW + 1;
  const bool keep_ranges = tile_cols * ((y1 - y0) / kSearchTileH + 1) <= kKeptTileRanges;
  std::array<std::uint32_t, kKeptTileRanges> kept_ranges;
  const auto tile_at = [&](int tx, int ty) {
    return static_cast<std::size_t>((ty - y0) / kSearchTileH * tile_cols + (tx - x0) / kTileW);
  };
  const bool reached = tiles_middle_out(
      x0, y0, x1, y1, [&](int tx, int ty, int ex, int ey) __attribute__((always_inline)) {
        std::uint16_t lo_code = 0, hi_code = 0;
        depths.range(tx, ty, ex, ey, &lo_code, &hi_code);
        if (keep_ranges) kept_ranges[tile_at(tx, ty)] = lo_code | std::uint32_t{hi_code} << 16;
        if (lo_code > hi_code) return false;  // every pixel missing: no ray
        if (hi_code < sign_lo || lo_code > sign_hi) {
          passed_over = true;
          return false;
        }
        const int count = ex - tx + 1;
        for (int v = ty; v <= ey; ++v) {
          // Only the halves of the row (four rays each) holding such a depth.
          const int halves = row_halves_with_code_in(depths.codes(), depths.width(), tx, count, v,
                                                     sign_lo, sign_hi);
          if (halves != (count > 4 ? 3 : 1)) passed_over = true;
          if (halves == 0) continue;
          if (halves & 1) scan_row(tx, v, std::min(count, 4));
          if (halves & 2) scan_row(tx + 4, v, count - 4);
          if (best >= -1.0f && to_fixed(best) >= cell.enough_fixed) return true;
        }
        return false;
      });
  if (reached) {
    *rays += clipped;
    return best;
  }
  // Pass 2 (the sign is lower than U's): the exact maximum over every tile that
  // can beat the best so far; once a ray is known to cross the cell, a tile that
  // can only add a free value gives its bound instead (it keeps the sign and
  // stays above the reference's value).
  if (passed_over) {
    // Only depths whose rays can beat the best so far need clipping: before any
    // ray crosses, those reaching a at all (d + Δd(d) >= a; kFar rays are free
    // across); after, also d - (1 - best) Δd(d) <= b (m̂ = 1 - |δ - d| / Δd above
    // best somewhere in [a, b]). Widened; the best only grows, so each interval
    // holds the next.
    std::uint16_t beat_lo = 0, beat_hi = DepthRangeTable::kFar;
    const float widen = 129.0f / 128.0f;
    float beat_for = kNoRay;  // the best the interval was computed for
    const auto narrow = [&] {
      beat_for = best;
      if (best >= -1.0f) {
        codes_reaching(cell.a, cell.b, widen, (1.0f - best) * widen, true, &beat_lo, &beat_hi);
      } else {
        std::uint16_t unused = 0;
        codes_reaching(cell.a, cell.b, widen, widen, false, &beat_lo, &unused);
        beat_hi = DepthRangeTable::kFar;
      }
    };
    narrow();
    for (int ty = y0; ty <= y1; ty += kBoundTileH) {
      for (int tx = x0; tx <= x1; tx += kTileW) {
        const int ex = std::min(tx + kTileW - 1, x1), ey = std::min(ty + kBoundTileH - 1, y1);
        if (keep_ranges) {
          // The search tile holding this one: nothing to clip in it, nothing here.
          const std::uint32_t kept = kept_ranges[tile_at(tx, ty)];
          const auto lo = static_cast<std::uint16_t>(kept);
          const auto hi = static_cast<std::uint16_t>(kept >> 16);
          if (lo > hi || hi < beat_lo || lo > beat_hi) continue;
        }
        std::uint16_t lo_code = 0, hi_code = 0;
        depths.range(tx, ty, ex, ey, &lo_code, &hi_code);
        if (lo_code > hi_code || hi_code < beat_lo || lo_code > beat_hi) continue;
        float bound = std::max(value_for_code(lo_code, cell.a, cell.b),
                               far_end(lo_code, hi_code, cell.a, cell.b));
        if (static_cast<float>(hi_code) * code_to_m_ >= cell.a &&
            static_cast<float>(lo_code) * code_to_m_ <= cell.b)
          bound = 1.0f;
        if (bound <= best) continue;
        if (best >= -1.0f && to_fixed(bound) < 0) {
          best = bound;
          narrow();
          continue;
        }
        const int count = ex - tx + 1;
        // The first pass clipped every half-row holding a code in [sign_lo, sign_hi].
        const bool seen = hi_code >= sign_lo && lo_code <= sign_hi;
        for (int v = ty; v <= ey; ++v) {
          int halves = row_halves_with_code_in(depths.codes(), depths.width(), tx, count, v,
                                               beat_lo, beat_hi);
          if (seen && halves != 0) {
            halves &= ~row_halves_with_code_in(depths.codes(), depths.width(), tx, count, v,
                                               sign_lo, sign_hi);
          }
          if (halves & 1) scan_row(tx, v, std::min(count, 4));
          if (halves & 2) scan_row(tx + 4, v, count - 4);
          if (best > beat_for) narrow();
        }
      }
    }
  }
  *rays += clipped;
  return best;
}

bool ProjectiveIntegrator::any_ray_crosses(const DepthRangeTable& depths, int x0, int y0, int x1,
                                           int y1, const CellRays& cell) const {
  // As exact_value's first pass: tiles from the middle out, only the rows (four
  // rays each half) holding a code whose ray reaches the cell's near end a.
  std::uint16_t reach_lo = 0, unused_hi = 0;
  codes_reaching(cell.a, cell.b, 1.0f, 1.0f, false, &reach_lo, &unused_hi);
  return tiles_middle_out(
      x0, y0, x1, y1, [&](int tx, int ty, int ex, int ey) __attribute__((always_inline)) {
        std::uint16_t lo_code = 0, hi_code = 0;
        depths.range(tx, ty, ex, ey, &lo_code, &hi_code);
        if (lo_code > hi_code || hi_code < reach_lo) return false;  // no ray, or all end before
        const int count = ex - tx + 1;
        for (int v = ty; v <= ey; ++v) {
          const int halves = row_halves_with_code_in(depths.codes(), depths.width(), tx, count, v,
                                                     reach_lo, DepthRangeTable::kFar);
          const std::uint16_t* row = depths.codes() + static_cast<std::size_t>(v) * depths.width();
          const int width = depths.width();
          if ((halves & 1) &&
              four_rays_best(row, width, tx, v, std::min(count, 4), cell.rays) >= -1.0f)
            return true;
          if ((halves & 2) && four_rays_best(row, width, tx + 4, v, count - 4, cell.rays) >= -1.0f)
            return true;
        }
        return false;
      });
}

// The smallest depth code whose ray can be free up to δ = b: d - 2 Δd(d) >= b
// (the reference rounds a ray's value to -1 at d - 1.99 Δd), widened by a code;
// kFar when no real depth is (then only rays with no depth within d_max are).
std::uint16_t ProjectiveIntegrator::first_code_free_beyond(float b) const {
  const float k = resolution_factor_ * 1.99f;
  const float disc = 1.0f - 4.0f * k * b;
  if (disc < 0.0f) return DepthRangeTable::kFar;
  const float root = (1.0f - std::sqrt(disc)) / (2.0f * k);
  const float top = static_cast<float>(DepthRangeTable::kMaxDepthCode);
  return static_cast<std::uint16_t>(std::clamp(std::floor(root / code_to_m_) - 1.0f, 0.0f, top));
}

bool ProjectiveIntegrator::any_ray_free_across(const DepthRangeTable& depths, int x0, int y0,
                                               int x1, int y1, std::uint16_t hi_code,
                                               const CellRays& cell) const {
  // As any_ray_crosses, over the rows holding a depth that can be free across.
  // (A ray leaves the cell at most at b, at least at a: its depth d - 2 Δd(d)
  // lies past a.)
  const std::uint16_t free_lo = first_code_free_beyond(cell.a);
  if (hi_code < free_lo) return false;  // every depth of the footprint ends nearer
  return tiles_middle_out(
      x0, y0, x1, y1, [&](int tx, int ty, int ex, int ey) __attribute__((always_inline)) {
        std::uint16_t lo_code = 0, tile_hi = 0;
        depths.range(tx, ty, ex, ey, &lo_code, &tile_hi);
        if (lo_code > tile_hi || tile_hi < free_lo) return false;
        const int count = ex - tx + 1;
        const int width = depths.width();
        for (int v = ty; v <= ey; ++v) {
          const int halves = row_halves_with_code_in(depths.codes(), width, tx, count, v, free_lo,
                                                     DepthRangeTable::kFar);
          const std::uint16_t* row = depths.codes() + static_cast<std::size_t>(v) * width;
          if ((halves & 1) &&
              four_rays_any_free_across(row, width, tx, v, std::min(count, 4), cell.rays))
            return true;
          if ((halves & 2) &&
              four_rays_any_free_across(row, width, tx + 4, v, count - 4, cell.rays))
            return true;
        }
        return false;
      });
}

bool ProjectiveIntegrator::free_across(std::uint16_t lo_code, std::uint16_t hi_code,
                                       float far_end) const {
  if (lo_code > hi_code) return false;  // every pixel missing
  if (lo_code == DepthRangeTable::kFar) return far_end <= d_max_;
  // d - 2 Δd(d), where a ray of depth d stops being free; concave in d, so over
  // any set of depths its minimum is at the smallest or the largest.
  const auto free_until = [this](float d) { return d - 2.0f * d * d * resolution_factor_; };
  const float d_lo = static_cast<float>(lo_code) * code_to_m_;
  const float d_hi =
      hi_code == DepthRangeTable::kFar ? d_max_ : static_cast<float>(hi_code) * code_to_m_;
  return std::min(free_until(d_lo), free_until(d_hi)) > far_end;
}

// Where the ray of a depth code stops: min(d + Δd, d_max); grows with d.
float ProjectiveIntegrator::reach(std::uint16_t code) const {
  const float d = static_cast<float>(code) * code_to_m_;
  return std::min(d + d * d * resolution_factor_, d_max_);
}

// classify_blocks()'s constants for one frame, shared by its parts.
struct ProjectiveIntegrator::BlockSetup {
  double side = 0.0, half_z = 0.0;
  Eigen::Matrix3d rt;
  Eigen::Vector3d t, base, step_x_camera;
  Projection projection;
  Frustum frustum;
};

void ProjectiveIntegrator::classify_blocks(const DepthRangeTable& depths,
                                           const Eigen::Isometry3d& world_T_camera,
                                           const CellIndex& origin, WorkSplit* split) {
  const double side = cell_size_m_ * kBlock;
  const Eigen::Matrix3d rt = world_T_camera.linear().transpose();
  const Eigen::Vector3d t = world_T_camera.translation();
  const double half_z = 0.5 * side * rt.row(2).cwiseAbs().sum();
  // Corner offsets from a block's centre in the camera frame, four at a time.
  Projection projection = projection_for(camera_);
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3d o =
        rt * Eigen::Vector3d((k & 1) ? 0.5 * side : -0.5 * side, (k & 2) ? 0.5 * side : -0.5 * side,
                             (k & 4) ? 0.5 * side : -0.5 * side);
    projection.corner_x[k / 4][k % 4] = static_cast<float>(o.x());
    projection.corner_y[k / 4][k % 4] = static_cast<float>(o.y());
    projection.corner_z[k / 4][k % 4] = static_cast<float>(o.z());
  }
  // Blocks outside the frustum hold no cell that draw() visits: they stay mixed.
  std::fill_n(block_class_.get(), block_count_, kBlockMixed);
  const Frustum frustum = make_frustum(world_T_camera, camera_, d_min_, d_max_, side);
  const Eigen::Vector3d base = Eigen::Vector3d(origin.x, origin.y, origin.z) * cell_size_m_ +
                               Eigen::Vector3d::Constant(0.5 * side);  // centre of block (0, 0, 0)
  const Eigen::Vector3d step_x_camera = rt.col(0) * side;
  const BlockSetup b{side, half_z, rt, t, base, step_x_camera, projection, frustum};
  const int parts = split == nullptr ? 1 : std::min(split->parts(), kMaxParts);
  for_each_part(split, parts,
                [&](int part, int all) { classify_block_rows(depths, b, share_of(part, all)); });
}

void ProjectiveIntegrator::classify_block_rows(const DepthRangeTable& depths, const BlockSetup& b,
                                               RowShare share) const {
  const double side = b.side, half_z = b.half_z;
  const Eigen::Matrix3d& rt = b.rt;
  const Eigen::Vector3d& t = b.t;
  const Eigen::Vector3d& base = b.base;
  const Eigen::Vector3d& step_x_camera = b.step_x_camera;
  const Projection& projection = b.projection;
  const Frustum& frustum = b.frustum;
  for (int bz = share.first; bz < blocks_[2]; bz += share.step) {
    for (int by = 0; by < blocks_[1]; ++by) {
      const double wy = base.y() + by * side, wz = base.z() + bz * side;
      int bx_lo = 0, bx_hi = -1;
      if (!frustum.row(wy, wz, base.x(), 1.0 / side, blocks_[0], &bx_lo, &bx_hi)) continue;
      std::size_t i = static_cast<std::size_t>(bx_lo) +
                      static_cast<std::size_t>(blocks_[0]) *
                          (static_cast<std::size_t>(by) +
                           static_cast<std::size_t>(blocks_[1]) * static_cast<std::size_t>(bz));
      Eigen::Vector3d pc = rt * (Eigen::Vector3d(base.x() + bx_lo * side, wy, wz) - t);
      for (int bx = bx_lo; bx <= bx_hi; ++bx, ++i, pc += step_x_camera) {
        const double zc = pc.z();
        if (zc + half_z < d_min_ || zc - half_z > d_max_) continue;
        const PixelRect rect = project_cube(projection, static_cast<float>(pc.x()),
                                            static_cast<float>(pc.y()), static_cast<float>(zc));
        const int px0 = rect.x0, px1 = rect.x1, py0 = rect.y0, py1 = rect.y1;
        if (px0 > px1 || py0 > py1) {
          block_class_[i] = kBlockUnseen;
          continue;
        }
        std::uint16_t lo_code = 0, hi_code = 0;
        depths.range(px0, py0, px1, py1, &lo_code, &hi_code);
        if (lo_code > hi_code || (hi_code != DepthRangeTable::kFar &&
                                  reach(hi_code) < static_cast<float>(zc - half_z))) {
          block_class_[i] = kBlockUnseen;  // every pixel missing, or every ray ends before it
        } else if (free_across(lo_code, hi_code, static_cast<float>(zc + half_z))) {
          block_class_[i] = kBlockFree;
        }
      }
    }
  }
}

// draw()'s constants for one frame: the camera-frame geometry of a grid cell,
// the frustum's rows, the probes and the pixel rays.
struct ProjectiveIntegrator::FrameSetup {
  double s = 0.0, inv_s = 0.0;
  CellIndex origin;
  Eigen::Matrix3d rt;
  Eigen::Vector3d t;
  Eigen::Vector3d half;  // half extents of a cell along the camera axes
  int w = 0, h = 0;
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  float fx_f = 0.0f, fy_f = 0.0f, cx_f = 0.0f, cy_f = 0.0f, cell_size = 0.0f;
  Frustum frustum;
  Eigen::Vector3d base;           // cell (x, y, z) has its centre at base + (x, y, z) * s
  Eigen::Vector3d step_x_camera;  // one cell along x, in the camera frame
  Projection projection;
  Lanes probe_x{}, probe_y{}, probe_z{};
  double quick_max_depth = 0.0;
  CellRays cell;  // the pixel rays in world axes (each cell sets its box)
};

// Inlined too, so that the frame's constants stay draw's own locals (the cell
// writes are bytes, which may alias anything the compiler cannot see is private).
__attribute__((always_inline)) inline ProjectiveIntegrator::FrameSetup
ProjectiveIntegrator::prepare_frame(const Eigen::Isometry3d& world_T_camera,
                                    const LocalGrid& grid) const {
  FrameSetup f;
  f.s = cell_size_m_;
  f.inv_s = 1.0 / f.s;
  const double s = f.s;
  f.origin = grid.origin();
  const Eigen::Matrix3d r = world_T_camera.linear();
  f.rt = r.transpose();
  f.t = world_T_camera.translation();
  // The camera-frame AABB of a cube.
  f.half = 0.5 * s * r.cwiseAbs().colwise().sum().transpose();
  f.w = camera_.width;
  f.h = camera_.height;
  f.fx = camera_.fx;
  f.fy = camera_.fy;
  f.cx = camera_.cx;
  f.cy = camera_.cy;
  // The frustum, widened by a cell's half diagonal: the cells worth a look.
  f.frustum = make_frustum(world_T_camera, camera_, d_min_, d_max_, s);
  f.base =
      (Eigen::Vector3d(f.origin.x, f.origin.y, f.origin.z) + Eigen::Vector3d::Constant(0.5)) * s;
  Eigen::Vector3d corners[8];
  for (int k = 0; k < 8; ++k) {
    corners[k] = f.rt * Eigen::Vector3d((k & 1) ? 0.5 * s : -0.5 * s, (k & 2) ? 0.5 * s : -0.5 * s,
                                        (k & 4) ? 0.5 * s : -0.5 * s);
  }
  f.step_x_camera = f.rt.col(0) * s;
  int far_corner = 0;  // the corner offset with the largest camera-frame z
  for (int k = 1; k < 8; ++k) {
    if (corners[k].z() > corners[far_corner].z()) far_corner = k;
  }
  f.projection = projection_for(camera_);
  for (int k = 0; k < 8; ++k) {
    f.projection.corner_x[k / 4][k % 4] = static_cast<float>(corners[k].x());
    f.projection.corner_y[k / 4][k % 4] = static_cast<float>(corners[k].y());
    f.projection.corner_z[k / 4][k % 4] = static_cast<float>(corners[k].z());
  }
  // Probe points relative to a cell's centre (camera frame): the centre, 3/4 of
  // the way to the farthest and to the nearest corner; lane 3 is replaced by the
  // footprint's centre.
  for (int i = 1; i < 3; ++i) {
    const Eigen::Vector3d o = (i == 1 ? 0.75 : -0.75) * corners[far_corner];
    f.probe_x[i] = static_cast<float>(o.x());
    f.probe_y[i] = static_cast<float>(o.y());
    f.probe_z[i] = static_cast<float>(o.z());
  }
  // Pixel rays in world axes, for the ray-by-ray rule.
  const Eigen::Matrix3f rf = r.cast<float>();
  const Eigen::Vector3f du = rf.col(0) / static_cast<float>(f.fx);
  const Eigen::Vector3f dv = rf.col(1) / static_cast<float>(f.fy);
  const Eigen::Vector3f w00 = rf * Eigen::Vector3f(static_cast<float>(-f.cx / f.fx),
                                                   static_cast<float>(-f.cy / f.fy), 1.0f);
  for (int k = 0; k < 3; ++k) {
    f.cell.rays.w00[k] = splat(w00[k]);
    f.cell.rays.du[k] = splat(du[k]);
    f.cell.rays.dv[k] = splat(dv[k]);
  }
  f.cell.rays.d_min = splat(d_min_);
  f.cell.rays.d_max = splat(d_max_);
  f.cell.rays.code_to_m = splat(code_to_m_);
  f.cell.rays.resolution_factor = splat(resolution_factor_);
  f.cell.rays.min_through = splat(kMinSeenThrough * static_cast<float>(s));
  f.cell_size = static_cast<float>(s);
  // The ray of the pixel nearest to a cell's projected centre passes within
  // 0.75 pixel of the centre: it crosses the cell while the cell spans > 1.5 px.
  f.quick_max_depth = s * std::min(f.fx, f.fy) / 1.5;
  f.fx_f = static_cast<float>(f.fx);
  f.fy_f = static_cast<float>(f.fy);
  f.cx_f = static_cast<float>(f.cx);
  f.cy_f = static_cast<float>(f.cy);
  return f;
}

ProjectiveStats ProjectiveIntegrator::draw(const DepthRangeTable& depths,
                                           const Eigen::Isometry3d& world_T_camera, LocalGrid& grid,
                                           WorkSplit* split) {
  classify_blocks(depths, world_T_camera, grid.origin(), split);
  const FrameSetup f = prepare_frame(world_T_camera, grid);
  const int parts = split == nullptr ? 1 : std::min(split->parts(), kMaxParts);
  for_each_part(split, parts, [&](int part, int all) {
    draw_rows(f, depths, share_of(part, all), grid, &parts_[static_cast<std::size_t>(part)]);
  });
  // Integer sums and bounds: the same whatever the number of parts.
  ProjectiveStats stats;
  PartResult all;
  for (int p = 0; p < parts; ++p) {
    stats += parts_[p].stats;
    for (int a = 0; a < 3; ++a) {
      all.touched_lo[a] = std::min(all.touched_lo[a], parts_[p].touched_lo[a]);
      all.touched_hi[a] = std::max(all.touched_hi[a], parts_[p].touched_hi[a]);
    }
  }
  if (all.touched_hi[0] >= 0) {
    grid.extend_touched(all.touched_lo[0], all.touched_lo[1], all.touched_lo[2], all.touched_hi[0],
                        all.touched_hi[1], all.touched_hi[2]);
  }
  return stats;
}

void ProjectiveIntegrator::draw_rows(const FrameSetup& setup, const DepthRangeTable& depths,
                                     RowShare share, LocalGrid& grid, PartResult* result) const {
  // The part's own copy: the cell writes are bytes, which may alias anything
  // whose address escaped, so constants read through a reference would be
  // reloaded for every cell.
  const FrameSetup f = setup;
  const std::array<int, 3> dims = grid.dims();
  CellRays cell = f.cell;
  PartResult part;  // a local for the same reason, stored at the end
  ProjectiveStats& stats = part.stats;
  int* touched_lo = part.touched_lo.data();
  int* touched_hi = part.touched_hi.data();
  for (int z = share.first; z < dims[2]; z += share.step) {
    for (int y = 0; y < dims[1]; ++y) {
      const double wy = f.base.y() + y * f.s, wz = f.base.z() + z * f.s;
      int xa = 0, xb = -1;
      if (!f.frustum.row(wy, wz, f.base.x(), f.inv_s, dims[0], &xa, &xb)) continue;
      touched_lo[0] = std::min(touched_lo[0], xa);
      touched_hi[0] = std::max(touched_hi[0], xb);
      touched_lo[1] = std::min(touched_lo[1], y);
      touched_hi[1] = std::max(touched_hi[1], y);
      touched_lo[2] = std::min(touched_lo[2], z);
      touched_hi[2] = std::max(touched_hi[2], z);
      Eigen::Vector3d pc = f.rt * (Eigen::Vector3d(f.base.x() + xa * f.s, wy, wz) - f.t);
      const std::uint8_t* block_row =
          block_class_.get() +
          static_cast<std::size_t>(blocks_[0]) *
              (static_cast<std::size_t>(y / kBlock) +
               static_cast<std::size_t>(blocks_[1]) * static_cast<std::size_t>(z / kBlock));
      for (int x = xa; x <= xb; ++x, pc += f.step_x_camera) {
        const std::uint8_t block = block_row[static_cast<unsigned>(x) / kBlock];  // x >= 0
        if (block == kBlockUnseen) {
          // The rest of the block at once: no ray reaches any of its cells.
          const int last = std::min(xb, (x & ~(kBlock - 1)) + kBlock - 1);
          stats.cells_hidden += last - x + 1;
          pc += static_cast<double>(last - x) * f.step_x_camera;
          x = last;
          continue;
        }
        settle_cell(f, depths, block, x, y, z, pc, cell, grid, &stats);
      }
    }
  }
  *result = part;
}

// Inlined into draw's row loop: it is the per-cell body, apart only for reading.
__attribute__((always_inline)) inline void ProjectiveIntegrator::settle_cell(
    const FrameSetup& f, const DepthRangeTable& depths, std::uint8_t block, int x, int y, int z,
    const Eigen::Vector3d& pc, CellRays& cell, LocalGrid& grid, ProjectiveStats* stats) const {
  const double s = f.s;
  const int w = f.w, h = f.h;
  const double fx = f.fx, fy = f.fy, cx = f.cx, cy = f.cy;
  const double zc = pc.z();
  const double a = std::max(zc - f.half.z(), static_cast<double>(d_min_));
  const double b = zc + f.half.z();
  if (b < d_min_ || a > d_max_) return;
  // The bulk of the frustum is free space or hidden behind surfaces. When
  // every pixel ray near the cell is free across it, the cell is free if one
  // of them, a real one, crosses it: known for its whole block (then the
  // centre pixel's ray, real and crossing the cell, saves projecting it), or
  // from the depth range over the cell's footprint (best_value's bound is
  // then exactly -1). When every such ray ends before the cell, nothing
  // reaches it.
  const bool quick = zc - f.half.z() >= d_min_ && zc <= f.quick_max_depth;
  // The code of the pixel nearest to the cell centre's image when its ray
  // surely crosses the cell (quick), else kMissing; looked up once a cell
  // (the block test, the box test and U < 0 may each ask).
  int centre_looked_up = -1;
  const auto centre_code = [&]() -> std::uint16_t {
    if (centre_looked_up >= 0) return static_cast<std::uint16_t>(centre_looked_up);
    std::uint16_t code = DepthRangeTable::kMissing;
    if (quick) {
      const double inv_z = 1.0 / zc;
      const double uc = fx * pc.x() * inv_z + cx, vc = fy * pc.y() * inv_z + cy;
      if (uc > -0.5 && vc > -0.5 && uc < w - 0.5 && vc < h - 0.5)
        code = depths.codes()[static_cast<std::size_t>(vc + 0.5) * w +
                              static_cast<std::size_t>(uc + 0.5)];
    }
    centre_looked_up = code;
    return code;
  };
  if (block == kBlockFree && centre_code() != DepthRangeTable::kMissing) {
    ++stats->cells_evaluated;
    ++stats->cells_block_free;
    grid.write_max(x, y, z, static_cast<LocalCell>(-kCellScale));
    return;
  }
  // The image box of the cube's eight projected corners: the pixels whose
  // rays can cross the cell.
  const PixelRect rect = project_cube(f.projection, static_cast<float>(pc.x()),
                                      static_cast<float>(pc.y()), static_cast<float>(pc.z()));
  const int px0 = rect.x0, px1 = rect.x1, py0 = rect.y0, py1 = rect.y1;
  if (px0 > px1 || py0 > py1) return;  // no pixel sees the cell
  std::uint16_t lo_code = 0, hi_code = 0;
  depths.range(px0, py0, px1, py1, &lo_code, &hi_code);
  if (lo_code > hi_code) return;  // every pixel near it missing
  if (hi_code != DepthRangeTable::kFar && reach(hi_code) < static_cast<float>(a)) {
    ++stats->cells_hidden;  // every ray ends before the cell
    return;
  }
  cell.a = static_cast<float>(a);
  cell.b = static_cast<float>(b);
  const auto set_cell_box = [&] {
    const Eigen::Vector3f cell_lo =
        (Eigen::Vector3d(f.origin.x + x, f.origin.y + y, f.origin.z + z) * s - f.t).cast<float>();
    for (int k = 0; k < 3; ++k) {
      cell.rays.lo[k] = splat(cell_lo[k]);
      cell.rays.hi[k] = splat(cell_lo[k] + f.cell_size);
    }
  };
  // Probes, four rays at once: through the centre, through points near the
  // corners farthest from and nearest to the camera (the rays that leave the
  // cell last and enter it first), and through the centre of the footprint.
  // Their largest m̂ in the cell (cell.rays set): a value some ray reaches.
  const auto probe_value = [&] {
    const auto pxf = static_cast<float>(pc.x()), pyf = static_cast<float>(pc.y()),
               pzf = static_cast<float>(pc.z());
    const Lanes qx = splat(pxf) + f.probe_x, qy = splat(pyf) + f.probe_y,
                qz = splat(pzf) + f.probe_z;
    const Lanes footprint_u = splat(0.5f * static_cast<float>(px0 + px1));
    const Lanes footprint_v = splat(0.5f * static_cast<float>(py0 + py1));
    const auto ahead = qz > 1e-6f;
    Lanes pu = ahead ? splat(f.fx_f) * qx / qz + splat(f.cx_f) : footprint_u;
    Lanes pv = ahead ? splat(f.fy_f) * qy / qz + splat(f.cy_f) : footprint_v;
    pu[3] = footprint_u[3];
    pv[3] = footprint_v[3];
    // Rounded to the nearest pixel of the footprint (clamped first: in range).
    pu = lanes_min(lanes_max(pu, splat(static_cast<float>(px0))), splat(static_cast<float>(px1)));
    pv = lanes_min(lanes_max(pv, splat(static_cast<float>(py0))), splat(static_cast<float>(py1)));
    using Ints = std::int32_t __attribute__((vector_size(16)));
    const Ints pixel_u = __builtin_convertvector(pu + 0.5f, Ints);  // >= 0: truncation
    const Ints pixel_v = __builtin_convertvector(pv + 0.5f, Ints);  // rounds
    pu = __builtin_convertvector(pixel_u, Lanes);
    pv = __builtin_convertvector(pixel_v, Lanes);
    const Ints at = pixel_v * w + pixel_u;
    const std::uint16_t* codes = depths.codes();
    const Ints code_ints = {codes[at[0]], codes[at[1]], codes[at[2]], codes[at[3]]};
    const Lanes probe_code = __builtin_convertvector(code_ints, Lanes);
    return lanes_hmax(rays_best(pu, pv, probe_code, cell.rays));
  };
  // Whether a real ray reaches into the cell: the reference draws nothing into
  // a cell that none crosses, and the footprint box is wider than the cell's
  // silhouette. `centre_reaches` settles it for the centre pixel's ray, else
  // the probes and then the footprint's rays are clipped until one crosses.
  const auto crossed = [&](bool centre_reaches) {
    if (centre_reaches) return true;
    set_cell_box();
    if (probe_value() >= -1.0f) return true;
    return any_ray_crosses(depths, px0, py0, px1, py1, cell);
  };
  if (free_across(lo_code, hi_code, static_cast<float>(b))) {
    // What best_value gives here, without its scan. Every ray near the cell
    // is free past it: a real centre ray crosses it.
    ++stats->cells_evaluated;
    if (!crossed(centre_code() != DepthRangeTable::kMissing)) return;
    ++stats->cells_box_free;
    grid.write_max(x, y, z, static_cast<LocalCell>(-kCellScale));
    return;
  }
  // An upper bound U from the footprint's depth range (exact when it says
  // free). The cell gets U whenever the reference's value has U's sign: a
  // value never below the reference's (near a surface, a little more
  // occupied or less free: the safe side), at the sign the reference gives.
  ++stats->cells_evaluated;
  float value = best_value(depths, px0, py0, px1, py1, lo_code, hi_code, cell.a, cell.b);
  float probed = kNoRay;  // the probes' value, when U >= 0 asked for it
  const int upper_fixed = to_fixed(value);
  if (value > -1.0f && upper_fixed >= 0) {
    // U < 0 settles the sign: every ray gives at most U. U >= 0 may claim a
    // surface (or an unknown 0) where the rays that really cross the cell
    // are all free. Probe rays give a lower bound; when it rounds to U's
    // sign the sign is settled, else the rays are looked at one by one, as
    // the reference does, until one does.
    set_cell_box();
    cell.enough_fixed = upper_fixed > 0 ? 1 : 0;
    const float lower = probe_value();
    probed = lower;
    if (lower < -1.0f || to_fixed(lower) < cell.enough_fixed) {
      ++stats->cells_exact;
      const float found = exact_value(depths, px0, py0, px1, py1, cell, lower, &stats->rays_exact);
      if (to_fixed(found) < cell.enough_fixed) value = found;  // a lower sign: exact
    }
  } else if (value >= -1.0f) {
    // U < 0, if a ray reaches the cell: the centre's does when it ends past b.
    const std::uint16_t centre = centre_code();
    const bool centre_reaches =
        centre != DepthRangeTable::kMissing &&
        (centre == DepthRangeTable::kFar ? cell.b <= d_max_ : reach(centre) >= cell.b);
    if (!crossed(centre_reaches)) return;
  }
  if (value < -1.0f) return;
  if (see_through_ && to_fixed(value) > -kCellScale) {
    // A ray crossed the cell wholly free and none came near its depth in it:
    // free (MapConfig::see_through). value bounds every ray's m̂ from above; the
    // probes (asked whenever value >= 0), when they reach the near peak, keep the
    // cell without a search.
    set_cell_box();
    const bool may_reach = to_fixed(value) >= near_peak_fixed_;
    const float lower = probed;
    const bool probes_near = lower >= -1.0f && to_fixed(lower) >= near_peak_fixed_;
    // The probes reaching U: kept at its exact value, whether seen through or not.
    const bool settled = probes_near && to_fixed(lower) >= to_fixed(value);
    if (!settled && any_ray_free_across(depths, px0, py0, px1, py1, hi_code, cell)) {
      // Some ray reaches the near peak (or, behind its depth, the lower bar):
      // kept, from the best value found so far; else seen through.
      float near = probes_near ? lower : kNoRay;
      if (!probes_near && may_reach) {
        near = near_peak_value(depths, px0, py0, px1, py1, lower, cell, stats);
      }
      const bool kept = (near >= -1.0f && to_fixed(near) >= near_peak_fixed_) ||
                        (near_peak_behind_fixed_ < near_peak_fixed_ &&
                         to_fixed(value) >= near_peak_behind_fixed_ &&
                         reaches_near_peak_behind(depths, px0, py0, px1, py1, cell));
      // A search that did not reach the near peak found the exact maximum.
      const bool near_exact =
          !probes_near && may_reach && near >= -1.0f && to_fixed(near) < near_peak_fixed_;
      if (!kept) {
        value = -1.0f;
      } else if (near_exact) {
        value = std::min(value, near);
      } else if (to_fixed(value) > 0) {
        value =
            exact_at_edge(depths, px0, py0, px1, py1, value, std::max(lower, near), cell, stats);
      }
    }
  }
  grid.write_max(x, y, z, to_local_cell(value));
}

// Ray by ray from `lower` (a value some ray reaches, below the near peak): a
// value some ray reaches in the cell, at least see_through's near peak (Q6) when
// one does, else the rays' exact maximum.
float ProjectiveIntegrator::near_peak_value(const DepthRangeTable& depths, int x0, int y0, int x1,
                                            int y1, float lower, CellRays& cell,
                                            ProjectiveStats* stats) const {
  const int enough = cell.enough_fixed;
  cell.enough_fixed = near_peak_fixed_;
  const float found = exact_value(depths, x0, y0, x1, y1, cell, lower, &stats->rays_exact);
  cell.enough_fixed = enough;
  return found;
}

// A cell seen through and kept lies at an edge (a silhouette, a gap): the
// footprint's depths beside it gave U, which there may exceed every ray that
// crosses it. Summed over frames that excess fills the gaps between things, so
// here the cell takes the rays' exact maximum (from `lower`, some ray's value).
float ProjectiveIntegrator::exact_at_edge(const DepthRangeTable& depths, int x0, int y0, int x1,
                                          int y1, float upper, float lower, CellRays& cell,
                                          ProjectiveStats* stats) const {
  if (lower >= -1.0f && to_fixed(lower) >= to_fixed(upper)) return upper;
  const int enough = cell.enough_fixed;
  cell.enough_fixed = to_fixed(upper);
  const float found = exact_value(depths, x0, y0, x1, y1, cell, lower, &stats->rays_exact);
  const bool below = found >= -1.0f && to_fixed(found) < cell.enough_fixed;
  cell.enough_fixed = enough;
  ++stats->cells_exact;
  return below ? found : upper;
}

bool ProjectiveIntegrator::reaches_near_peak_behind(const DepthRangeTable& depths, int x0, int y0,
                                                    int x1, int y1, const CellRays& cell) const {
  // As any_ray_crosses, over the rows holding a depth d that ended before the
  // cell's far end b and whose ray reaches its near end a with m̂ at the bar:
  // d <= b and d + s Δd(d) >= a (s = 1 - the bar), widened by a code.
  const float s = 1.0f - (static_cast<float>(near_peak_behind_fixed_) - 0.5f) / kCellScale;
  std::uint16_t reach_lo = 0, unused_hi = 0;
  codes_reaching(cell.a, cell.b, s * (129.0f / 128.0f), 1.0f, false, &reach_lo, &unused_hi);
  const float top = static_cast<float>(DepthRangeTable::kMaxDepthCode);
  const auto reach_hi =
      static_cast<std::uint16_t>(std::clamp(std::ceil(cell.b / code_to_m_) + 1.0f, 0.0f, top));
  if (reach_lo > reach_hi) return false;
  return tiles_middle_out(
      x0, y0, x1, y1, [&](int tx, int ty, int ex, int ey) __attribute__((always_inline)) {
        std::uint16_t lo_code = 0, hi_code = 0;
        depths.range(tx, ty, ex, ey, &lo_code, &hi_code);
        if (lo_code > hi_code || hi_code < reach_lo || lo_code > reach_hi) return false;
        const int count = ex - tx + 1;
        const int width = depths.width();
        for (int v = ty; v <= ey; ++v) {
          const int halves =
              row_halves_with_code_in(depths.codes(), width, tx, count, v, reach_lo, reach_hi);
          const std::uint16_t* row = depths.codes() + static_cast<std::size_t>(v) * width;
          if ((halves & 1) && four_rays_near_peak_behind(row, width, tx, v, std::min(count, 4),
                                                         near_peak_behind_fixed_, cell.rays))
            return true;
          if ((halves & 2) && four_rays_near_peak_behind(row, width, tx + 4, v, count - 4,
                                                         near_peak_behind_fixed_, cell.rays))
            return true;
        }
        return false;
      });
}

}  // namespace zonemap
