#include "zonemap/features/feature_map.hpp"

// The feature map's terrain: the lowest occupied cell of each column, the
// measured ground band above it, and what counts as ground.
#include <algorithm>
#include <array>
#include <cmath>

#include "common/simd_u16.hpp"
#include "features/feature_map_detail.hpp"

namespace zonemap {

void FeatureMap::compute_terrain(const ZoneSnapshot& zone) {
  const std::size_t columns = static_cast<std::size_t>(dims_[0]) * dims_[1];
  if (!config_.ground_enabled) {
    std::fill_n(terrain_.get(), columns, kNoHeight);
    std::fill_n(ground_top_.get(), columns, kNoHeight);
    return;
  }
  scan_columns(zone);
  keep_surface_windows();
  borrow_terrain_where_unseen();
  compute_ground_top();
}

// Per column: the surface cell (lowest_) and the top of the occupied run rising
// from the lowest occupied cell (run_top_); summed-area tables of the columns
// holding an occupied cell and of those known at all give a window's coverage
// in O(1).
void FeatureMap::scan_columns(const ZoneSnapshot& zone) {
  const int nx = dims_[0];
  const int ny = dims_[1];
  const std::size_t stride = static_cast<std::size_t>(nx + 1);
  std::fill_n(coverage_.get(), stride, 0);
  std::fill_n(observed_.get(), stride, 0);
  for (int y = 0; y < ny; ++y) {
    std::int32_t covered_row = 0;
    std::int32_t observed_row = 0;
    coverage_[static_cast<std::size_t>(y + 1) * stride] = 0;
    observed_[static_cast<std::size_t>(y + 1) * stride] = 0;
    for (int x = 0; x < nx; ++x) {
      const bool known = zone.column_known(x, y);  // any evidence, free or occupied
      std::int16_t surface = kNoHeight, top = kNoHeight;
      if (known) column_surface(zone, x, y, &surface, &top);
      lowest_[static_cast<std::size_t>(y) * nx + x] = surface;
      run_top_[static_cast<std::size_t>(y) * nx + x] = top;
      covered_row += surface != kNoHeight ? 1 : 0;
      observed_row += known ? 1 : 0;
      const std::size_t at = static_cast<std::size_t>(y + 1) * stride + x + 1;
      coverage_[at] = coverage_[at - stride] + covered_row;
      observed_[at] = observed_[at - stride] + observed_row;
    }
  }
}

// One column's lowest occupied cell, the run rising from it (followed no
// farther than the band can reach) and the surface in it: where the run's
// fused value peaks (far views smear a band about it both ways, so its lowest
// cell lies under the ground with the band measured; else the run is that one
// cell). kNoHeight for both when no cell is occupied.
void FeatureMap::column_surface(const ZoneSnapshot& zone, int x, int y, std::int16_t* surface,
                                std::int16_t* run_top) const {
  const int nz = dims_[2];
  const auto cell = [&](int h) { return zone.index(x, y, z_up_ ? h : nz - 1 - h); };
  int lowest = kNoHeight;
  for (int h = 0; h < nz; ++h) {
    if (zone.occupied(cell(h))) {
      lowest = h;
      break;
    }
  }
  if (lowest == kNoHeight) return;
  int top = lowest;
  const int run_end = std::min(nz - 1, lowest + ground_band_cells_);
  while (top < run_end && zone.occupied(cell(top + 1))) ++top;
  *surface = static_cast<std::int16_t>(lowest);
  int peak_level = -1;
  for (int h = lowest; h <= top; ++h) {
    const int level = zone.level(cell(h));
    if (level > peak_level) {
      peak_level = level;
      *surface = static_cast<std::int16_t>(h);
    }
  }
  *run_top = static_cast<std::int16_t>(top);
}

// Terrain candidates: the surface cell, minimum over the window; kept where the
// window is a surface (enough of its observed columns hold an occupied cell),
// not a thing standing in free air.
void FeatureMap::keep_surface_windows() {
  const int nx = dims_[0];
  const int ny = dims_[1];
  const std::size_t stride = static_cast<std::size_t>(nx + 1);
  const int r = ground_window_cells_;
  window_min(lowest_.get(), terrain_.get(), column_tmp_.get(), r);
  for (int y = 0; y < ny; ++y) {
    const int y0 = std::max(0, y - r);
    const int y1 = std::min(ny - 1, y + r);
    for (int x = 0; x < nx; ++x) {
      const int x0 = std::max(0, x - r);
      const int x1 = std::min(nx - 1, x + r);
      const std::int32_t covered = window_sum(coverage_.get(), stride, x0, y0, x1, y1);
      const std::int32_t observed = window_sum(observed_.get(), stride, x0, y0, x1, y1);
      std::int16_t& t = terrain_[static_cast<std::size_t>(y) * nx + x];
      if (covered < config_.ground_min_coverage * observed) t = kNoHeight;
    }
  }
}

// Columns at the rim of the seen ground (few observed columns hold the ground
// there) and in the shadows behind obstacles take the lowest terrain of the
// surface columns within one window radius, else within three (lowest_ is free
// to reuse now): on a slope the lowest within three radii lies under the
// ground there, and the band above it would stand out as objects.
void FeatureMap::borrow_terrain_where_unseen() {
  const std::size_t columns = static_cast<std::size_t>(dims_[0]) * dims_[1];
  const int r = ground_window_cells_;
  window_min(terrain_.get(), lowest_.get(), column_tmp_.get(), 3 * r);
  window_min(terrain_.get(), near_terrain_.get(), column_tmp_.get(), r);
  for (std::size_t c = 0; c < columns; ++c) {
    if (terrain_[c] != kNoHeight) continue;
    terrain_[c] = near_terrain_[c] != kNoHeight ? near_terrain_[c] : lowest_[c];
    // Borrowed terrain: this column's own run (a thing standing there, or one
    // cut by the zone's bottom face) measures no band.
    run_top_[c] = kNoHeight;
  }
}

void FeatureMap::compute_ground_top() {
  const int nx = dims_[0];
  const int ny = dims_[1];
  const std::size_t columns = static_cast<std::size_t>(nx) * ny;
  const int band = ground_band_cells_;
  const std::size_t stride = static_cast<std::size_t>(nx + 1);
  // The summed-area tables of every band height k at once (band_tables_): a
  // column adds one to lane k when its run reaches k cells above its terrain
  // (clipped to the band; k = 0: every column with a run).
  const int lanes = band_lanes();
  if (band > 0) {
    std::uint16_t* sat = band_tables_.get();
    std::fill_n(sat, stride * static_cast<std::size_t>(lanes), std::uint16_t{0});
    for (int y = 0; y < ny; ++y) {
      std::uint16_t* const row_sat = sat + static_cast<std::size_t>(y + 1) * stride * lanes;
      std::fill_n(row_sat, lanes, std::uint16_t{0});
      for (int group = 0; group < lanes; group += 8) {
        const simd::I16x8 k =
            simd::I16x8{0, 1, 2, 3, 4, 5, 6, 7} + static_cast<std::int16_t>(group);
        simd::U16x8 row{};
        for (int x = 0; x < nx; ++x) {
          const std::size_t c = static_cast<std::size_t>(y) * nx + x;
          const bool has_run = terrain_[c] != kNoHeight && run_top_[c] != kNoHeight;
          const auto height =
              static_cast<std::int16_t>(has_run ? std::min(run_top_[c] - terrain_[c], band) : -1);
          row -= reinterpret_cast<simd::U16x8>(simd::I16x8{} + height >= k);
          std::uint16_t* at = row_sat + static_cast<std::size_t>(x + 1) * lanes + group;
          const simd::U16x8 above = simd::load_u16(at - stride * lanes);
          simd::store_u16(at, above + row);
        }
      }
    }
  }
  for (std::size_t c = 0; c < columns; ++c) {
    if (terrain_[c] == kNoHeight) {
      ground_top_[c] = kNoHeight;
      continue;
    }
    const int x = static_cast<int>(c % static_cast<std::size_t>(nx));
    const int y = static_cast<int>(c / static_cast<std::size_t>(nx));
    const int measured = band > 0 ? measured_band(x, y) : 0;
    ground_top_[c] =
        static_cast<std::int16_t>(terrain_[c] + std::max(ground_thickness_cells_, measured));
  }
}

int FeatureMap::measured_band(int x, int y) const {
  // A surface's band has runs of one height give or take a cell; where they
  // spread wider, objects (or their smear) stand in the window and its runs say
  // nothing of the ground: the thickness alone holds there.
  const double p = config_.ground_band_percentile;
  const int low = band_quantile(x, y, p);
  const int high = band_quantile(x, y, 1.0 - p);
  return high - low <= kBandScatterCells ? high + kBandScatterCells : 0;
}

int FeatureMap::band_quantile(int x, int y, double fraction) const {
  const int r = ground_window_cells_;
  const std::size_t stride = static_cast<std::size_t>(dims_[0] + 1);
  const int x0 = std::max(0, x - r);
  const int x1 = std::min(dims_[0] - 1, x + r);
  const int y0 = std::max(0, y - r);
  const int y1 = std::min(dims_[1] - 1, y + r);
  const int lanes = band_lanes();
  const std::uint16_t* sat = band_tables_.get();
  const auto entry = [&](int ex, int ey, int k) {
    return sat[(static_cast<std::size_t>(ey) * stride + static_cast<std::size_t>(ex)) * lanes + k];
  };
  auto window_count = [&](int k) {  // below 2^16: exact from the wrapped corners
    return static_cast<std::uint16_t>(entry(x1 + 1, y1 + 1, k) - entry(x1 + 1, y0, k) -
                                      entry(x0, y1 + 1, k) + entry(x0, y0, k));
  };
  // The largest k that (1 - fraction) of the window's runs reach.
  const double needed = (1.0 - fraction) * window_count(0);
  int k = 0;
  while (needed > 0.0 && k < ground_band_cells_ && window_count(k + 1) >= needed) ++k;
  return k;
}

void FeatureMap::window_min(const std::int16_t* values, std::int16_t* out, std::int16_t* tmp,
                            int r) const {
  // kNoHeight entries are left out (as the largest value); a window with none
  // else gives kNoHeight.
  const std::int16_t none = INT16_MAX;
  const std::size_t columns = static_cast<std::size_t>(dims_[0]) * dims_[1];
  for (std::size_t c = 0; c < columns; ++c) tmp[c] = values[c] == kNoHeight ? none : values[c];
  window_min_plane(tmp, out, dims_[0], dims_[1], r, none, window_buffer_.get());
  for (std::size_t c = 0; c < columns; ++c) {
    if (out[c] == none) out[c] = kNoHeight;
  }
}

bool FeatureMap::is_ground_cell(int x, int y, int z) const {
  const std::int16_t top = ground_top_[static_cast<std::size_t>(y) * dims_[0] + x];
  return top != kNoHeight && height_of(z) <= top;
}

// Far grazing views smear the ground into a band whose runs vary from column
// to column by more than the measured band's scatter; a patch of it standing a
// cell or two above the band's measure is no object when the ground around it
// rises as high: at least half of the measured columns within a window radius
// of its box (outside it) have runs reaching its top, give or take a cell.
bool FeatureMap::within_ground_around(const CellIndex& lo, const CellIndex& hi, int top) const {
  const int r = ground_window_cells_;
  const int nx = dims_[0], ny = dims_[1];
  int measured = 0, as_high = 0;
  for (int y = std::max(0, lo.y - r); y <= std::min(ny - 1, hi.y + r); ++y) {
    for (int x = std::max(0, lo.x - r); x <= std::min(nx - 1, hi.x + r); ++x) {
      if (x >= lo.x && x <= hi.x && y >= lo.y && y <= hi.y) continue;
      const std::size_t c = static_cast<std::size_t>(y) * nx + x;
      if (terrain_[c] == kNoHeight || run_top_[c] == kNoHeight) continue;
      ++measured;
      as_high += run_top_[c] + kBandScatterCells >= top ? 1 : 0;
    }
  }
  return measured > 0 && 2 * as_high >= measured;
}

}  // namespace zonemap
