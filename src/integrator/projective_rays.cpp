// The ray-by-ray passes over a cell's footprint (the tiers' last resort): the
// reference's value or its sign, whether a ray crosses the cell, crosses it
// wholly free, or reaches its near peak (MapConfig::see_through).
#include <algorithm>
#include <array>
#include <cmath>

#include "integrator/projective_detail.hpp"

namespace zonemap {

// exact_value's state across its two passes (inlined: a local of exact_value).
struct ProjectiveIntegrator::ExactSearch {
  const ProjectiveIntegrator& integrator;
  const DepthRangeTable& depths;
  const CellRays& cell;
  int x0, y0, x1, y1;
  float best;                              // a value some ray reaches
  std::uint16_t sign_lo = 0, sign_hi = 0;  // the depths that can reach the sign sought
  std::int64_t clipped = 0;                // rays clipped so far
  bool passed_over = false;                // some ray was not clipped in pass 1
  // The tiles' depth ranges, kept for the second pass when the footprint has few
  // enough tiles (the first pass visits them all when it does not stop early).
  int tile_cols = 0;
  bool keep_ranges = false;
  std::array<std::uint32_t, kKeptTileRanges> kept_ranges;  // written before read

  ExactSearch(const ProjectiveIntegrator& of, const DepthRangeTable& codes, const CellRays& rays,
              int left, int top, int right, int bottom, float reached)
      : integrator(of),
        depths(codes),
        cell(rays),
        x0(left),
        y0(top),
        x1(right),
        y1(bottom),
        best(reached) {}

  __attribute__((always_inline)) void scan_row(int tx, int v, int count) {
    clipped += count;
    const std::uint16_t* row = depths.codes() + static_cast<std::size_t>(v) * depths.width();
    best = std::max(best, four_rays_best(row, depths.width(), tx, v, count, cell.rays));
  }
  __attribute__((always_inline)) std::size_t tile_at(int tx, int ty) const {
    return static_cast<std::size_t>((ty - y0) / kSearchTileH * tile_cols + (tx - x0) / kTileW);
  }
  __attribute__((always_inline)) bool sign_pass();
  __attribute__((always_inline)) void maximum_pass();
};

float ProjectiveIntegrator::exact_value(const DepthRangeTable& depths, int x0, int y0, int x1,
                                        int y1, const CellRays& cell, float best,
                                        std::int64_t* rays) const {
  // The first pass clips only the rays whose depth can reach the sign sought
  // (cell.enough_fixed), found by tile and then by row, and stops at the first
  // that does; when none does, the sign is lower and the second pass takes the
  // exact maximum, each tile bounded by its depth range (the cell's δ-support
  // bounds every ray's part in it).
  ExactSearch search(*this, depths, cell, x0, y0, x1, y1, best);
  // The depths whose rays can reach the value sought, cell.enough_fixed in Q6
  // (0 or 1: the sign; see_through's near peak): m̂ >= (enough - 1/2) / 64, the
  // rounding's edge.
  const float margin =
      1.0f - (static_cast<float>(cell.enough_fixed) - 0.5f) / static_cast<float>(kCellScale);
  codes_reaching(cell.a, cell.b, margin, margin, false, &search.sign_lo, &search.sign_hi);
  search.tile_cols = (x1 - x0) / kTileW + 1;
  search.keep_ranges = search.tile_cols * ((y1 - y0) / kSearchTileH + 1) <= kKeptTileRanges;
  if (!search.sign_pass() && search.passed_over) search.maximum_pass();
  *rays += search.clipped;
  return search.best;
}

// Pass 1: only rows of tiles with a depth in [sign_lo, sign_hi], and of those
// only the rows holding such a depth (one vector compare per row), until a ray
// reaches the sign; tiles from the middle out. True when one does.
inline bool ProjectiveIntegrator::ExactSearch::sign_pass() {
  return tiles_middle_out(
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
}

// Pass 2 (the sign is lower than U's): the exact maximum over every tile that
// can beat the best so far; once a ray is known to cross the cell, a tile that
// can only add a free value gives its bound instead (it keeps the sign and
// stays above the reference's value).
inline void ProjectiveIntegrator::ExactSearch::maximum_pass() {
  const ProjectiveIntegrator& pi = integrator;
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
      pi.codes_reaching(cell.a, cell.b, widen, (1.0f - best) * widen, true, &beat_lo, &beat_hi);
    } else {
      std::uint16_t unused = 0;
      pi.codes_reaching(cell.a, cell.b, widen, widen, false, &beat_lo, &unused);
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
      float bound = std::max(pi.value_for_code(lo_code, cell.a, cell.b),
                             pi.far_end(lo_code, hi_code, cell.a, cell.b));
      if (static_cast<float>(hi_code) * pi.code_to_m_ >= cell.a &&
          static_cast<float>(lo_code) * pi.code_to_m_ <= cell.b)
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
        int halves =
            row_halves_with_code_in(depths.codes(), depths.width(), tx, count, v, beat_lo, beat_hi);
        if (seen && halves != 0) {
          halves &= ~row_halves_with_code_in(depths.codes(), depths.width(), tx, count, v, sign_lo,
                                             sign_hi);
        }
        if (halves & 1) scan_row(tx, v, std::min(count, 4));
        if (halves & 2) scan_row(tx + 4, v, count - 4);
        if (best > beat_for) narrow();
      }
    }
  }
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
        // The rows from the middle out too: the rays through a cell's middle
        // cross it, the rays at its bounding box's top and bottom rows seldom.
        for (int row_i = 0; row_i <= ey - ty; ++row_i) {
          const int v = ty + middle_out(row_i, ey - ty + 1);
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
        for (int row_i = 0; row_i <= ey - ty; ++row_i) {
          const int v = ty + middle_out(row_i, ey - ty + 1);
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
