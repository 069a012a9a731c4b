#include "zonemap/feature_map.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "simd_u16.hpp"

namespace zonemap {
namespace {

constexpr std::int16_t kNoHeight = -1;
// A measured band's run tops scatter about its quantile by about a cell.
constexpr int kBandScatterCells = 1;
// PeakTrim compares a cell with the planes one above and below it: beside a
// stronger part it takes a cell of a thin thing; two leave a cell of margin.
constexpr int kTrimReachZ = 2;

std::int64_t overlap_volume(const CellIndex& a0, const CellIndex& a1, const CellIndex& b0,
                            const CellIndex& b1) {
  const std::int64_t dx = std::min(a1.x, b1.x) - std::max(a0.x, b0.x) + 1;
  const std::int64_t dy = std::min(a1.y, b1.y) - std::max(a0.y, b0.y) + 1;
  const std::int64_t dz = std::min(a1.z, b1.z) - std::max(a0.z, b0.z) + 1;
  return dx > 0 && dy > 0 && dz > 0 ? dx * dy * dz : 0;
}

// Sum over the window [x0, x1] x [y0, y1] of a summed-area table with `stride`
// entries per row (row and column 0 are zero).
std::int32_t window_sum(const std::int32_t* table, std::size_t stride, int x0, int y0, int x1,
                        int y1) {
  return table[static_cast<std::size_t>(y1 + 1) * stride + x1 + 1] -
         table[static_cast<std::size_t>(y0) * stride + x1 + 1] -
         table[static_cast<std::size_t>(y1 + 1) * stride + x0] +
         table[static_cast<std::size_t>(y0) * stride + x0];
}

// Whether the x-y boxes of a and b overlap by more than half the smaller one.
bool mostly_overlap_xy(const Feature& a, const Feature& b) {
  const std::int64_t dx = std::min(a.max.x, b.max.x) - std::max(a.min.x, b.min.x) + 1;
  const std::int64_t dy = std::min(a.max.y, b.max.y) - std::max(a.min.y, b.min.y) + 1;
  if (dx <= 0 || dy <= 0) return false;
  const auto area = [](const Feature& f) {
    return static_cast<std::int64_t>(f.max.x - f.min.x + 1) * (f.max.y - f.min.y + 1);
  };
  return 2 * dx * dy > std::min(area(a), area(b));
}

std::size_t band_table_size(const MapConfig& config) {
  return static_cast<std::size_t>(config.zone_cells[0] + 1) * (config.zone_cells[1] + 1);
}

std::uint32_t find_root(std::uint32_t* parent, std::uint32_t i) {
  while (parent[i] != i) {  // path halving: bounded by the tree height
    parent[i] = parent[parent[i]];
    i = parent[i];
  }
  return i;
}

}  // namespace

FeatureMap::FeatureMap(const MapConfig& config, bool world_z_up)
    : config_(config.features),
      cell_size_m_(config.cell_size_m),
      z_up_(world_z_up),
      dims_(config.zone_cells),
      map_config_(config),
      threshold_(static_cast<FusedCell>(
          to_fixed(static_cast<float>(config.features.occupied_threshold_units)))),
      reintegration_value_(static_cast<FusedCell>(
          to_fixed(static_cast<float>(config.features.reintegration_units)))),
      ground_thickness_cells_(
          static_cast<int>(std::lround(config.features.ground_thickness_m / config.cell_size_m))),
      ground_window_cells_(static_cast<int>(
          std::lround(config.features.ground_window_m / config.cell_size_m / 2.0))),
      ground_band_cells_(config.features.ground_band_percentile > 0.0
                             ? static_cast<int>(std::lround(config.features.ground_max_thickness_m /
                                                            config.cell_size_m))
                             : 0),
      capacity_(static_cast<std::size_t>(config.features.capacity)),
      features_(new Feature[capacity_]()),
      shapes_(static_cast<std::size_t>(config.features.quadtree_groups),
              std::max(config.zone_cells[0], config.zone_cells[1])),
      visited_(new std::uint64_t[(zone_cell_count(config) + 63) / 64]()),
      component_(new std::uint32_t[zone_cell_count(config)]()),
      footprint_(new std::uint8_t[static_cast<std::size_t>(dims_[0]) * dims_[1]]()),
      lowest_(new std::int16_t[static_cast<std::size_t>(dims_[0]) * dims_[1]]()),
      near_terrain_(new std::int16_t[static_cast<std::size_t>(dims_[0]) * dims_[1]]()),
      terrain_(new std::int16_t[static_cast<std::size_t>(dims_[0]) * dims_[1]]()),
      run_top_(new std::int16_t[static_cast<std::size_t>(dims_[0]) * dims_[1]]()),
      ground_top_(new std::int16_t[static_cast<std::size_t>(dims_[0]) * dims_[1]]()),
      band_tables_(
          new std::uint16_t[band_table_size(config) * static_cast<std::size_t>(band_lanes())]()),
      column_tmp_(new std::int16_t[static_cast<std::size_t>(dims_[0]) * dims_[1]]()),
      window_buffer_(new std::int16_t[window_buffer_size()]()),
      coverage_(new std::int32_t[static_cast<std::size_t>(dims_[0] + 1) * (dims_[1] + 1)]()),
      observed_(new std::int32_t[static_cast<std::size_t>(dims_[0] + 1) * (dims_[1] + 1)]()),
      parent_(new std::uint32_t[capacity_]()),
      core_min_cells_(config.features.split_touching ? config.features.core_min_cells : 0),
      region_start_(new std::size_t[kMaxCores + 1]()),
      core_first_(new std::size_t[kMaxCores]()),
      core_end_(new std::size_t[kMaxCores]()),
      column_queue_(new std::uint32_t[static_cast<std::size_t>(dims_[0]) * dims_[1]]()),
      region_box_(new RegionBox[kMaxCores]()),
      region_root_(new std::uint16_t[kMaxCores]()),
      scratch_(config.zone_cells, coarse_level_step(config)),
      trim_(make_peak_trim(config)),
      d_max_m_(config.d_max_m) {}

void FeatureMap::set_camera(const CameraModel& camera) {
  camera_ = camera;
}

bool FeatureMap::in_view(const CellIndex& min, const CellIndex& max) const {
  if (!view_known_ || camera_.width <= 0) return true;
  const Eigen::Vector3d lo = Eigen::Vector3d(min.x, min.y, min.z) * cell_size_m_;
  const Eigen::Vector3d size =
      Eigen::Vector3d(max.x - min.x + 1, max.y - min.y + 1, max.z - min.z + 1) * cell_size_m_;
  for (int i = 0; i < 27; ++i) {
    const Eigen::Vector3d at(i % 3, (i / 3) % 3, i / 9);
    const Eigen::Vector3d c = camera_T_world_ * (lo + size.cwiseProduct(at) * 0.5);
    if (c.z() <= 0.0 || c.norm() > d_max_m_) continue;
    const double u = camera_.fx * c.x() / c.z() + camera_.cx;
    const double v = camera_.fy * c.y() / c.z() + camera_.cy;
    if (u >= 0.0 && v >= 0.0 && u < camera_.width && v < camera_.height) return true;
  }
  return false;
}

std::size_t FeatureMap::reserved_bytes() const {
  const std::size_t columns = static_cast<std::size_t>(dims_[0]) * dims_[1];
  const std::size_t cells = columns * static_cast<std::size_t>(dims_[2]);
  return capacity_ * (sizeof(Feature) + sizeof(std::uint32_t)) + shapes_.reserved_bytes() +
         (cells + 63) / 64 * 8 + cells * sizeof(std::uint32_t) + columns * (1 + 3 * 2) +
         2 * static_cast<std::size_t>(dims_[0] + 1) * (dims_[1] + 1) * sizeof(std::int32_t) +
         (3 * kMaxCores + 1) * sizeof(std::size_t) + columns * sizeof(std::uint32_t) +
         kMaxCores * (sizeof(RegionBox) + sizeof(std::uint16_t)) + scratch_.reserved_bytes() +
         trim_.reserved_bytes() + columns * 3 * sizeof(std::int16_t) +
         window_buffer_size() * sizeof(std::int16_t) +
         static_cast<std::size_t>(dims_[0] + 1) * (dims_[1] + 1) * band_lanes() *
             sizeof(std::uint16_t);
}

std::size_t FeatureMap::count(FeatureKind kind) const {
  return static_cast<std::size_t>(std::count_if(
      begin(), end(), [kind](const Feature& f) { return f.in_use && f.kind == kind; }));
}

void FeatureMap::compute_terrain(const ZoneSnapshot& zone) {
  const int nx = dims_[0];
  const int ny = dims_[1];
  const int nz = dims_[2];
  const std::size_t columns = static_cast<std::size_t>(nx) * ny;
  if (!config_.ground_enabled) {
    std::fill_n(terrain_.get(), columns, kNoHeight);
    std::fill_n(ground_top_.get(), columns, kNoHeight);
    return;
  }
  // Per column: the lowest occupied cell, and whether any cell is known at all.
  // Summed-area tables of both give the window coverage in O(1).
  const std::size_t stride = static_cast<std::size_t>(nx + 1);
  std::fill_n(coverage_.get(), stride, 0);
  std::fill_n(observed_.get(), stride, 0);
  for (int y = 0; y < ny; ++y) {
    std::int32_t covered_row = 0;
    std::int32_t observed_row = 0;
    coverage_[static_cast<std::size_t>(y + 1) * stride] = 0;
    observed_[static_cast<std::size_t>(y + 1) * stride] = 0;
    for (int x = 0; x < nx; ++x) {
      std::int16_t lowest = kNoHeight;
      const bool known = zone.column_known(x, y);  // any evidence, free or occupied
      for (int h = 0; known && h < nz; ++h) {
        if (zone.occupied(zone.index(x, y, z_up_ ? h : nz - 1 - h))) {
          lowest = static_cast<std::int16_t>(h);
          break;
        }
      }
      // The run rising from it, followed no farther than the band can reach.
      int top = lowest;
      const int run_end = std::min(nz - 1, lowest + ground_band_cells_);
      while (lowest != kNoHeight && top < run_end &&
             zone.occupied(zone.index(x, y, z_up_ ? top + 1 : nz - 2 - top))) {
        ++top;
      }
      // The surface lies where the run's fused value peaks: far views smear a band
      // about it both ways, so its lowest cell lies under the ground (with the
      // band measured; else the run is that one cell).
      std::int16_t surface = lowest;
      int peak_level = -1;
      for (int h = lowest; lowest != kNoHeight && h <= top; ++h) {
        const int level = zone.level(zone.index(x, y, z_up_ ? h : nz - 1 - h));
        if (level > peak_level) {
          peak_level = level;
          surface = static_cast<std::int16_t>(h);
        }
      }
      lowest_[static_cast<std::size_t>(y) * nx + x] = surface;
      run_top_[static_cast<std::size_t>(y) * nx + x] = static_cast<std::int16_t>(top);
      covered_row += lowest != kNoHeight ? 1 : 0;
      observed_row += known ? 1 : 0;
      const std::size_t at = static_cast<std::size_t>(y + 1) * stride + x + 1;
      coverage_[at] = coverage_[at - stride] + covered_row;
      observed_[at] = observed_[at - stride] + observed_row;
    }
  }
  // Terrain candidates: the surface cell, minimum over the window.
  const int r = ground_window_cells_;
  window_min(lowest_.get(), terrain_.get(), column_tmp_.get(), r);
  // Kept where the window is a surface (enough of its observed columns hold an
  // occupied cell), not a thing standing in free air.
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
  // Columns at the rim of the seen ground (few observed columns hold the ground
  // there) and in the shadows behind obstacles take the lowest terrain of the
  // surface columns within one window radius, else within three (lowest_ is free
  // to reuse now): on a slope the lowest within three radii lies under the
  // ground there, and the band above it would stand out as objects.
  window_min(terrain_.get(), lowest_.get(), column_tmp_.get(), 3 * r);
  window_min(terrain_.get(), near_terrain_.get(), column_tmp_.get(), r);
  for (std::size_t c = 0; c < columns; ++c) {
    if (terrain_[c] != kNoHeight) continue;
    terrain_[c] = near_terrain_[c] != kNoHeight ? near_terrain_[c] : lowest_[c];
    // Borrowed terrain: this column's own run (a thing standing there, or one
    // cut by the zone's bottom face) measures no band.
    run_top_[c] = kNoHeight;
  }
  compute_ground_top();
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

void FeatureMap::extract(const ZoneView& zone) {
  scratch_.capture(zone, threshold_, &trim_);
  extract(scratch_);
}

void FeatureMap::extract(const ZoneSnapshot& zone) {
  ++counters_.extractions;
  const int nx = dims_[0];
  const int ny = dims_[1];
  const int nz = dims_[2];
  const std::size_t total = static_cast<std::size_t>(nx) * ny * nz;
  compute_terrain(zone);
  std::fill_n(visited_.get(), (total + 63) / 64, std::uint64_t{0});
  for (Feature* f = features_.get(); f != features_.get() + capacity_; ++f) {
    // Another vehicle's boxes are not in the grid: not this extraction's to match.
    if (f->in_use && f->zone == zone.key() && f->shared_source == 0) f->stale = true;
  }
  for (std::size_t start = 0; start < total; ++start) {
    if ((start & 63) == 0 && zone.occupied_word(start >> 6) == 0) {  // 64 empty cells
      start += 63;
      continue;
    }
    if (visited(start) || !zone.occupied(start)) continue;
    const bool ground = is_ground_cell(cell_x(start), cell_y(start), cell_z(start));
    const std::size_t count = fill_component(zone, start, ground);
    const std::size_t regions = ground ? 0 : split_at_valleys(zone, count);
    if (regions <= 1) {
      add_object(zone, component_.get(), count, ground);
      continue;
    }
    ++counters_.objects_split;
    for (std::size_t r = 0; r < regions; ++r) {
      const std::size_t size = region_start_[r + 1] - region_start_[r];
      if (size > 0) add_object(zone, component_.get() + region_start_[r], size, false);
    }
  }
  // Objects of this zone that the grid no longer holds.
  for (Feature* f = features_.get(); f != features_.get() + capacity_; ++f) {
    if (f->in_use && f->stale) {
      if (f->prior) ++counters_.priors_removed;
      ++removal_cause(zone, *f);
      remove(f);
      ++counters_.features_removed;
    }
  }
}

template <typename Pick>
Feature* FeatureMap::most_overlapping_stale(const ZoneKey& zone, const CellIndex& min,
                                            const CellIndex& max, Pick&& pick) {
  Feature* most = nullptr;
  std::int64_t best = 0;
  for (Feature* f = features_.get(); f != features_.get() + capacity_; ++f) {
    if (!f->in_use || !f->stale || !(f->zone == zone) || !pick(*f)) continue;
    const std::int64_t v = overlap_volume(f->min, f->max, min, max);
    if (v > best) {
      best = v;
      most = f;
    }
  }
  return most;
}

template <typename Fn>
void FeatureMap::for_each_zone_piece(const Eigen::Vector3d& min_m, const Eigen::Vector3d& max_m,
                                     Fn&& fn) const {
  const auto cell = [this](double m, bool upper) {
    const double c = m / cell_size_m_;
    // [min, max) in metres: the cells it covers, at least one.
    return static_cast<std::int32_t>(upper ? std::ceil(c) - 1.0 : std::floor(c));
  };
  const CellIndex lo{cell(min_m.x(), false), cell(min_m.y(), false), cell(min_m.z(), false)};
  CellIndex hi{cell(max_m.x(), true), cell(max_m.y(), true), cell(max_m.z(), true)};
  hi = {std::max(hi.x, lo.x), std::max(hi.y, lo.y), std::max(hi.z, lo.z)};
  const ZoneKey first = ZoneMap::key_of(map_config_, lo);
  const ZoneKey last = ZoneMap::key_of(map_config_, hi);
  // Bounded by the box's extent in zones (the loaders refuse boxes over 1 km).
  for (std::int32_t k = first.k; k <= last.k; ++k)
    for (std::int32_t j = first.j; j <= last.j; ++j)
      for (std::int32_t i = first.i; i <= last.i; ++i) {
        const ZoneKey key{i, j, k};
        const CellIndex o = ZoneMap::origin_of(map_config_, key);
        const CellIndex a{std::max(lo.x, o.x), std::max(lo.y, o.y), std::max(lo.z, o.z)};
        const CellIndex b{std::min(hi.x, o.x + dims_[0] - 1), std::min(hi.y, o.y + dims_[1] - 1),
                          std::min(hi.z, o.z + dims_[2] - 1)};
        fn(key, a, b);
      }
}

std::int64_t& FeatureMap::removal_cause(const ZoneSnapshot& zone, const Feature& f) {
  const CellIndex o = zone.origin();
  std::int64_t occupied = 0;
  // Bounded by the feature's box, which lies inside the zone.
  for (int z = f.min.z; z <= f.max.z; ++z)
    for (int y = f.min.y; y <= f.max.y; ++y)
      for (int x = f.min.x; x <= f.max.x; ++x) {
        if (feature_contains(f, {x, y, z}) && zone.occupied(zone.index(x - o.x, y - o.y, z - o.z))) {
          ++occupied;
        }
      }
  if (occupied * 10 <= f.cells) {
    return in_view(f.min, f.max) ? counters_.removed_seen_free : counters_.removed_unseen;
  }
  for (const Feature* g = features_.get(); g != features_.get() + capacity_; ++g) {
    if (g->in_use && !g->stale && g->kind == FeatureKind::kObstacle && g->zone == f.zone &&
        overlap_volume(g->min, g->max, f.min, f.max) > 0) {
      return counters_.removed_joined;
    }
  }
  return counters_.removed_other;
}

bool FeatureMap::add_prior(const Eigen::Vector3d& min_m, const Eigen::Vector3d& max_m) {
  bool all_stored = true;
  for_each_zone_piece(min_m, max_m,
                      [&](const ZoneKey& key, const CellIndex& a, const CellIndex& b) {
                        all_stored &= add_prior_piece(key, a, b);
                      });
  return all_stored;
}

std::size_t FeatureMap::replace_shared(std::uint8_t source, const Eigen::Vector3d* min_m,
                                       const Eigen::Vector3d* max_m, std::size_t count) {
  ++counters_.shared_updates;
  // What this sender sent before stays out of eviction while it is matched.
  for (Feature* f = features_.get(); f != features_.get() + capacity_; ++f) {
    if (f->in_use && f->shared_source == source) f->stale = true;
  }
  for (std::size_t b = 0; b < count; ++b) {
    for_each_zone_piece(min_m[b], max_m[b],
                        [&](const ZoneKey& key, const CellIndex& lo, const CellIndex& hi) {
                          add_or_keep_shared(source, key, lo, hi);
                        });
  }
  std::size_t stored = 0;
  for (Feature* f = features_.get(); f != features_.get() + capacity_; ++f) {
    if (!f->in_use || f->shared_source != source) continue;
    if (f->stale) {
      remove(f);
      ++counters_.shared_removed;
    } else {
      ++stored;
    }
  }
  return stored;
}

void FeatureMap::add_or_keep_shared(std::uint8_t source, const ZoneKey& zone, const CellIndex& min,
                                    const CellIndex& max) {
  Feature* same = most_overlapping_stale(zone, min, max, [source](const Feature& f) {
    return f.shared_source == source;
  });
  Feature piece;
  piece.min = min;
  piece.max = max;
  piece.cells = (max.x - min.x + 1) * (max.y - min.y + 1) * (max.z - min.z + 1);
  if (same != nullptr) {
    same->min = min;
    same->max = max;
    same->cells = piece.cells;
    same->last_seen_s = time_s_;
    same->stale = false;
    ++counters_.shared_kept;
    return;
  }
  Feature* slot = free_slot(relevance(piece));
  if (slot == nullptr) {
    ++counters_.shared_dropped;
    return;
  }
  piece.id = next_id_++;
  piece.zone = zone;
  piece.shared_source = source;
  piece.first_seen_s = time_s_;
  piece.last_seen_s = time_s_;
  piece.in_use = true;
  piece.prior = true;  // no view of ours has confirmed it (never matched by upsert)
  *slot = piece;
  ++in_use_;
  ++priors_live_;
  ++counters_.shared_added;
}

bool FeatureMap::add_prior_piece(const ZoneKey& zone, const CellIndex& min, const CellIndex& max) {
  Feature piece;
  piece.kind = FeatureKind::kObstacle;
  piece.min = min;
  piece.max = max;
  piece.cells = (max.x - min.x + 1) * (max.y - min.y + 1) * (max.z - min.z + 1);
  Feature* slot = free_slot(relevance(piece));
  if (slot == nullptr) {
    ++counters_.priors_dropped;
    return false;
  }
  piece.id = next_id_++;
  piece.zone = zone;
  piece.first_seen_s = time_s_;
  piece.last_seen_s = time_s_;
  piece.in_use = true;
  piece.prior = true;  // has_shape false: the whole box is the object until a view says more
  *slot = piece;
  ++in_use_;
  ++priors_live_;
  ++counters_.priors_added;
  return true;
}

std::size_t FeatureMap::fill_component(const ZoneSnapshot& zone, std::size_t start, bool ground) {
  // Breadth-first fill of the 6-connected cells of the same class. Each cell is
  // queued once (marked when queued), so the queue never exceeds the zone.
  std::size_t head = 0;
  std::size_t tail = 0;
  component_[tail++] = static_cast<std::uint32_t>(start);
  mark(start);
  while (head < tail) {
    const std::size_t i = component_[head++];
    for_each_neighbour(i, [&](std::size_t j, int x, int y, int z) {
      if (visited(j) || !zone.occupied(j) || is_ground_cell(x, y, z) != ground) return;
      mark(j);
      component_[tail++] = static_cast<std::uint32_t>(j);
    });
  }
  return tail;
}

std::size_t FeatureMap::grow_regions(const ZoneSnapshot& zone, std::uint32_t* queue,
                                     std::size_t tail, int level) {
  // Breadth-first from every labelled cell at once: each cell at or above `level`
  // goes to the region that reaches it first.
  for (std::size_t head = 0; head < tail; ++head) {
    const std::uint32_t label = unpack_label(queue[head]);
    for_each_neighbour(unpack_cell(queue[head]), [&](std::size_t j, int x, int y, int z) {
      if (visited(j) || !zone.occupied(j) || zone.level(j) < level || is_ground_cell(x, y, z)) {
        return;
      }
      mark(j);
      queue[tail++] = pack(j, label);
    });
  }
  return tail;
}

std::size_t FeatureMap::add_cores(const ZoneSnapshot& zone, std::size_t count, std::uint32_t* queue,
                                  std::size_t tail, int level, std::uint32_t* cores) {
  // Parts at or above `level` that no region reached are new cores, unless they
  // are specks (fewer than core_min_cells: left for the growth).
  for (std::size_t k = 0; k < count && *cores < kMaxCores; ++k) {
    const std::size_t seed = component_[k];
    if (visited(seed) || zone.level(seed) < level) continue;
    const std::size_t first = tail;
    queue[tail++] = pack(seed, *cores);
    mark(seed);
    for (std::size_t head = first; head < tail; ++head) {
      for_each_neighbour(unpack_cell(queue[head]), [&](std::size_t j, int x, int y, int z) {
        if (visited(j) || !zone.occupied(j) || zone.level(j) < level || is_ground_cell(x, y, z)) {
          return;
        }
        mark(j);
        queue[tail++] = pack(j, *cores);
      });
    }
    if (tail - first < static_cast<std::size_t>(core_min_cells_)) {
      for (std::size_t q = first; q < tail; ++q) unmark(unpack_cell(queue[q]));
      tail = first;
      continue;
    }
    core_first_[*cores] = first;
    core_end_[*cores] = tail;
    ++*cores;
  }
  return tail;
}

std::size_t FeatureMap::split_at_valleys(const ZoneSnapshot& zone, std::size_t count) {
  // Objects that stand close (trees in a line, bushes of a hedge) touch through
  // cells that fewer or farther views saw occupied: the fused value dips between
  // them. A watershed by flooding, in levels from the object's peak down:
  // at each level the regions found so far grow into the cells now above it, and
  // parts that none of them reaches are new regions (cores). What is left below
  // the last level goes to the nearest region. A part whose value never rises
  // apart from its neighbour's (no dip) stays one region.
  const std::size_t total = zone.cell_count();
  if (!(core_min_cells_ > 0) || count < 2 * static_cast<std::size_t>(core_min_cells_) ||
      2 * count > total || !zone.levels_complete()) {
    return 1;  // nothing to split, no room for the growth queue, or no levels
  }
  int peak = 0;
  for (std::size_t k = 0; k < count; ++k) peak = std::max<int>(peak, zone.level(component_[k]));
  for (std::size_t k = 0; k < count; ++k) unmark(component_[k]);
  // The queue lives behind the component's cells: entries are a cell index (22
  // bits: kMaxZoneCells) and its region's label above it.
  std::uint32_t* queue = component_.get() + count;
  std::size_t tail = 0;
  std::uint32_t cores = 0;
  // Levels 0.9^k of the peak down to the occupied threshold: a dip of a tenth
  // shows, and a weak object next to a strong one still rises apart from it.
  const int floor_level = threshold_ / zone.level_step() + 1;
  for (int level = peak * 9 / 10; level >= floor_level; level = level * 9 / 10) {
    tail = grow_regions(zone, queue, tail, level);
    tail = add_cores(zone, count, queue, tail, level, &cores);
    if (level < 10) break;  // 9 * 9 / 10 rounds to itself
  }
  for (std::size_t k = 0; k < count; ++k) mark(component_[k]);
  if (cores <= 1) return 1;
  // Each cell then goes with its column: columns, not cells, so that a region's
  // growth along the low band that joins neighbours cannot reach far under them;
  // flooded down the columns' peaks, so that neighbours part where they dip.
  label_columns_by_flooding(zone, count, queue, cores);
  sort_by_column_label(count, cores);
  // Two faces of one solid thing (a hut seen from both sides, its inside never
  // seen) are cores too; their regions' x-y boxes overlap mostly, those of
  // neighbours standing apart hardly: such regions are one object again.
  if (merge_overlapping_regions(cores)) sort_by_column_label(count, cores);
  return cores;
}

bool FeatureMap::merge_overlapping_regions(std::uint32_t cores) {
  RegionBox* box = region_box_.get();
  for (std::uint32_t r = 0; r < cores; ++r) {
    box[r] = {INT32_MAX, INT32_MAX, INT32_MIN, INT32_MIN};
    for (std::size_t k = region_start_[r]; k < region_start_[r + 1]; ++k) {
      const int x = cell_x(component_[k]), y = cell_y(component_[k]);
      box[r] = {std::min(box[r].x0, x), std::min(box[r].y0, y), std::max(box[r].x1, x),
                std::max(box[r].y1, y)};
    }
    region_root_[r] = static_cast<std::uint16_t>(r);
  }
  const auto root = [&](std::uint32_t r) {
    while (region_root_[r] != r) r = region_root_[r];
    return r;
  };
  const auto area = [](const RegionBox& b) {
    return static_cast<std::int64_t>(b.x1 - b.x0 + 1) * (b.y1 - b.y0 + 1);
  };
  bool merged_any = false;
  for (std::uint32_t a = 0; a < cores; ++a) {
    if (region_start_[a] == region_start_[a + 1]) continue;
    for (std::uint32_t b = a + 1; b < cores; ++b) {
      if (region_start_[b] == region_start_[b + 1]) continue;
      const std::int64_t w = std::min(box[a].x1, box[b].x1) - std::max(box[a].x0, box[b].x0) + 1;
      const std::int64_t h = std::min(box[a].y1, box[b].y1) - std::max(box[a].y0, box[b].y0) + 1;
      if (w <= 0 || h <= 0 || 2 * w * h <= std::min(area(box[a]), area(box[b]))) continue;
      const std::uint32_t ra = root(a), rb = root(b);
      if (ra != rb) region_root_[std::max(ra, rb)] = static_cast<std::uint16_t>(std::min(ra, rb));
      merged_any = true;
    }
  }
  if (!merged_any) return false;
  // The columns take their region's root as label (sort_by_column_label reads them).
  std::int16_t* label = column_tmp_.get();
  const std::size_t nx = static_cast<std::size_t>(dims_[0]);
  for (std::uint32_t r = 0; r < cores; ++r) {
    for (std::size_t k = region_start_[r]; k < region_start_[r + 1]; ++k) {
      const std::uint32_t c = component_[k];
      label[static_cast<std::size_t>(cell_y(c)) * nx + cell_x(c)] =
          static_cast<std::int16_t>(root(r));
    }
  }
  return true;
}

void FeatureMap::label_columns_by_flooding(const ZoneSnapshot& zone, std::size_t count,
                                           const std::uint32_t* queue, std::uint32_t cores) {
  const int nx = dims_[0];
  CellIndex lo{cell_x(component_[0]), cell_y(component_[0]), 0};
  CellIndex hi = lo;
  for (std::size_t k = 0; k < count; ++k) {
    lo = {std::min(lo.x, cell_x(component_[k])), std::min(lo.y, cell_y(component_[k])), 0};
    hi = {std::max(hi.x, cell_x(component_[k])), std::max(hi.y, cell_y(component_[k])), 0};
  }
  std::int16_t* label = column_tmp_.get();
  // Each column's peak: the largest level of the component's cells in it (lowest_
  // is free once the terrain is known); -1 for the box's other columns.
  std::int16_t* peak = lowest_.get();
  for (int y = lo.y; y <= hi.y; ++y) {
    const std::size_t row = static_cast<std::size_t>(y) * nx + lo.x;
    std::fill_n(label + row, hi.x - lo.x + 1, std::int16_t{-1});
    std::fill_n(peak + row, hi.x - lo.x + 1, std::int16_t{-1});
  }
  for (std::size_t k = 0; k < count; ++k) {
    const std::uint32_t c = component_[k];
    std::int16_t& p = peak[static_cast<std::size_t>(cell_y(c)) * nx + cell_x(c)];
    p = std::max<std::int16_t>(p, zone.level(c));
  }
  // A bucket queue of columns by level (FIFO within a level; links through
  // column_queue_): from the cores' seed columns, the highest columns are
  // taken first and give their label to their unlabelled 4-neighbours, queued
  // at their own peak (never above the level being flooded). Neighbours thus
  // meet where the column peaks dip between them, not halfway between cores.
  constexpr std::uint32_t kEnd = UINT32_MAX;
  constexpr int kLevels = 256;
  std::array<std::uint32_t, kLevels> head;
  std::array<std::uint32_t, kLevels> tail;
  head.fill(kEnd);
  tail.fill(kEnd);
  std::uint32_t* next = column_queue_.get();
  const auto push = [&](std::uint32_t column, int level) {
    const int b = std::clamp(level, 0, kLevels - 1);
    next[column] = kEnd;
    if (tail[b] == kEnd) {
      head[b] = column;
    } else {
      next[tail[b]] = column;
    }
    tail[b] = column;
  };
  for (std::uint32_t c = 0; c < cores; ++c) {
    for (std::size_t q = core_first_[c]; q < core_end_[c]; ++q) {
      const std::size_t cell = unpack_cell(queue[q]);
      const std::size_t column = static_cast<std::size_t>(cell_y(cell)) * nx + cell_x(cell);
      if (label[column] >= 0) continue;
      label[column] = static_cast<std::int16_t>(c);
      push(static_cast<std::uint32_t>(column), peak[column]);
    }
  }
  for (int level = kLevels - 1; level >= 0; --level) {
    while (head[level] != kEnd) {
      const std::uint32_t column = head[level];
      head[level] = next[column];
      if (head[level] == kEnd) tail[level] = kEnd;
      const int x = static_cast<int>(column % static_cast<std::uint32_t>(nx));
      const int y = static_cast<int>(column / static_cast<std::uint32_t>(nx));
      const auto visit = [&](int vx, int vy) {
        if (vx < lo.x || vx > hi.x || vy < lo.y || vy > hi.y) return;
        const std::size_t v = static_cast<std::size_t>(vy) * nx + vx;
        if (label[v] >= 0) return;
        label[v] = label[column];
        push(static_cast<std::uint32_t>(v), std::min<int>(peak[v], level));
      };
      visit(x - 1, y);
      visit(x + 1, y);
      visit(x, y - 1);
      visit(x, y + 1);
    }
  }
}

void FeatureMap::sort_by_column_label(std::size_t count, std::uint32_t cores) {
  // Counting sort by the column's label into component_[0, count) (through the
  // queue area behind it): region r is [region_start_[r], region_start_[r + 1]).
  const int nx = dims_[0];
  const std::int16_t* label = column_tmp_.get();
  const auto label_of = [&](std::uint32_t cell) {
    return static_cast<std::size_t>(
        label[static_cast<std::size_t>(cell_y(cell)) * nx + cell_x(cell)]);
  };
  std::fill_n(region_start_.get(), cores + 1, std::size_t{0});
  for (std::size_t k = 0; k < count; ++k) ++region_start_[label_of(component_[k]) + 1];
  for (std::uint32_t r = 0; r < cores; ++r) region_start_[r + 1] += region_start_[r];
  std::uint32_t* sorted = component_.get() + count;
  for (std::size_t k = 0; k < count; ++k)
    sorted[region_start_[label_of(component_[k])]++] = component_[k];
  std::copy_n(sorted, count, component_.get());
  // region_start_[r] now ends region r: shifted back to where each begins.
  for (std::uint32_t r = cores; r > 0; --r) region_start_[r] = region_start_[r - 1];
  region_start_[0] = 0;
}

void FeatureMap::add_object(const ZoneSnapshot& zone, const std::uint32_t* cells, std::size_t count,
                            bool ground) {
  if (count < static_cast<std::size_t>(config_.min_cells)) {
    ++counters_.objects_too_small;
    return;
  }
  const int nx = dims_[0];
  const int nz = dims_[2];
  CellIndex lo{cell_x(cells[0]), cell_y(cells[0]), cell_z(cells[0])};
  CellIndex hi = lo;
  // An obstacle resting on the ground layer reaches down to the terrain surface,
  // which lies in the terrain cell (the column's lowest occupied one): its lowest
  // part lies within the ground thickness and was labelled ground.
  int standing_height = INT32_MAX;
  for (std::size_t k = 0; k < count; ++k) {
    const int x = cell_x(cells[k]);
    const int y = cell_y(cells[k]);
    const int z = cell_z(cells[k]);
    lo = {std::min(lo.x, x), std::min(lo.y, y), std::min(lo.z, z)};
    hi = {std::max(hi.x, x), std::max(hi.y, y), std::max(hi.z, z)};
    if (ground) continue;
    // The cell under it, or within the trim's reach under it: the trim takes a
    // thin thing's foot beside a saturated ground for the ground's halo.
    for (int step = 1; step <= 1 + kTrimReachZ; ++step) {
      const int below = z_up_ ? z - step : z + step;
      if (below < 0 || below >= nz) break;
      if (!zone.occupied(zone.index(x, y, below))) continue;
      if (is_ground_cell(x, y, below)) {
        standing_height = std::min(
            standing_height, static_cast<int>(terrain_[static_cast<std::size_t>(y) * nx + x]));
      }
      break;
    }
  }
  if (standing_height != INT32_MAX && ground_band_cells_ > 0 && !ground &&
      within_ground_around(lo, hi, std::max(height_of(lo.z), height_of(hi.z)))) {
    ++counters_.objects_in_ground_band;
    ground = true;
    standing_height = INT32_MAX;
  }
  if (standing_height != INT32_MAX) {
    const int z_ground = z_up_ ? standing_height : nz - 1 - standing_height;
    lo.z = std::min(lo.z, z_ground);
    hi.z = std::max(hi.z, z_ground);
  }
  // Footprint s'(x, y) of eq. (8): any occupied cell in the column.
  const int w = hi.x - lo.x + 1;
  const int h = hi.y - lo.y + 1;
  std::fill_n(footprint_.get(), static_cast<std::size_t>(w) * h, std::uint8_t{0});
  for (std::size_t k = 0; k < count; ++k) {
    footprint_[static_cast<std::size_t>(cell_y(cells[k]) - lo.y) * w + cell_x(cells[k]) - lo.x] = 1;
  }
  const CellIndex& origin = zone.origin();
  upsert(zone.key(), ground ? FeatureKind::kGround : FeatureKind::kObstacle,
         CellIndex{origin.x + lo.x, origin.y + lo.y, origin.z + lo.z},
         CellIndex{origin.x + hi.x, origin.y + hi.y, origin.z + hi.z},
         static_cast<std::int32_t>(count), priors_live_ > 0 && measured(zone, cells, count));
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

// Whether views found the object occupied: a tenth of its cells above the value
// re-integration writes (a re-inserted object no view has looked at holds
// exactly that; one seen free falls below it). Its lowest cells are left out: the
// measured ground's band reaches into them whether the object stands or not.
bool FeatureMap::measured(const ZoneSnapshot& zone, const std::uint32_t* cells,
                          std::size_t count) const {
  int lowest = INT32_MAX;
  for (std::size_t k = 0; k < count; ++k) lowest = std::min(lowest, height_of(cell_z(cells[k])));
  const int above_ground_band = lowest + 2 * std::max(ground_thickness_cells_, 1);
  const int written = reintegration_value_ / zone.level_step();
  std::size_t upper = 0, above = 0;
  for (std::size_t k = 0; k < count; ++k) {
    if (height_of(cell_z(cells[k])) < above_ground_band) continue;
    ++upper;
    above += zone.level(cells[k]) > written ? 1 : 0;
  }
  return above > 0 && 10 * above >= upper;
}

double FeatureMap::relevance(const Feature& f) const {
  const Eigen::Vector3d centre =
      Eigen::Vector3d(f.min.x + f.max.x + 1, f.min.y + f.max.y + 1, f.min.z + f.max.z + 1) *
      (0.5 * cell_size_m_);
  const double distance = (centre - vehicle_m_).norm();
  const double score = f.cells / (1.0 + (distance / 10.0) * (distance / 10.0));
  // Any obstacle outranks any ground feature (a zone holds < 1e9 cells).
  return f.kind == FeatureKind::kObstacle ? 1e9 + score : score;
}

void FeatureMap::remove(Feature* f) {
  if (f->prior) --priors_live_;
  if (f->has_shape) shapes_.release(&f->shape);
  *f = Feature{};
  --in_use_;
}

Feature* FeatureMap::free_slot(double new_relevance) {
  Feature* least = nullptr;
  for (Feature* f = features_.get(); f != features_.get() + capacity_; ++f) {
    if (!f->in_use) return f;
    // Stale features are being matched in this extraction: keep them out of the choice.
    if (!f->stale && (least == nullptr || relevance(*f) < relevance(*least))) least = f;
  }
  if (least == nullptr || relevance(*least) >= new_relevance) {
    ++counters_.features_dropped;
    return nullptr;
  }
  remove(least);
  ++counters_.features_evicted;
  return least;
}

void FeatureMap::upsert(const ZoneKey& zone, FeatureKind kind, const CellIndex& min,
                        const CellIndex& max, std::int32_t cells, bool measured) {
  // The same object as before: the stale feature of this zone and kind that
  // overlaps the new box most.
  Feature* match =
      most_overlapping_stale(zone, min, max, [kind](const Feature& f) { return f.kind == kind; });
  if (match == nullptr) {
    Feature candidate;
    candidate.kind = kind;
    candidate.min = min;
    candidate.max = max;
    candidate.cells = cells;
    match = free_slot(relevance(candidate));
    if (match == nullptr) return;
    match->id = next_id_++;
    match->first_seen_s = time_s_;
    match->last_seen_s = time_s_;
    match->in_use = true;
    ++in_use_;
    ++counters_.features_added;
  } else {
    if (match->has_shape) shapes_.release(&match->shape);
    ++counters_.features_updated;
  }
  match->kind = kind;
  match->zone = zone;
  match->min = min;
  match->max = max;
  match->cells = cells;
  if (in_view(min, max)) {
    match->last_seen_s = time_s_;
    if (match->prior && measured) {  // seen occupied where it was said to stand
      match->prior = false;
      --priors_live_;
      ++counters_.priors_confirmed;
    }
  }
  match->stale = false;
  match->has_shape = shapes_.build(footprint_.get(), max.x - min.x + 1, max.y - min.y + 1,
                                   &match->shape, &match->shape_side);
  if (!match->has_shape) ++counters_.shapes_truncated;
}

bool FeatureMap::feature_contains(const Feature& f, const CellIndex& c) const {
  if (c.x < f.min.x || c.y < f.min.y || c.z < f.min.z || c.x > f.max.x || c.y > f.max.y ||
      c.z > f.max.z) {
    return false;
  }
  return !f.has_shape || shapes_.contains(f.shape, f.shape_side, c.x - f.min.x, c.y - f.min.y);
}

void FeatureMap::on_zone_allocated(ZoneView& zone) {
  // §IV-B: cells inside a stored object's shape (footprint x z extent) become
  // occupied with a high value; everything else stays unknown.
  for_each_reintegration_box(zone.key, [&](const CellIndex& min, const CellIndex& max) {
    counters_.cells_reintegrated += reintegrate_box(zone, min, max, reintegration_value_);
  });
}

std::int64_t FeatureMap::reintegrate_box(ZoneView& zone, const CellIndex& min, const CellIndex& max,
                                         FusedCell value) {
  const int x0 = std::max(min.x - zone.origin.x, 0);
  const int y0 = std::max(min.y - zone.origin.y, 0);
  const int z0 = std::max(min.z - zone.origin.z, 0);
  const int x1 = std::min(max.x - zone.origin.x, zone.dims[0] - 1);
  const int y1 = std::min(max.y - zone.origin.y, zone.dims[1] - 1);
  const int z1 = std::min(max.z - zone.origin.z, zone.dims[2] - 1);
  std::int64_t cells = 0;
  for (int z = z0; z <= z1; ++z)
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        FusedCell& cell = zone.cells[zone.index(x, y, z)];
        cell = std::max(cell, value);
        ++cells;
      }
  return cells;
}

std::size_t FeatureMap::merged(ObstacleBox* out, std::size_t capacity, bool include_ground,
                               FootprintOutput* footprints) {
  if (footprints != nullptr) {
    footprints->used = 0;
    footprints->boxes_without_footprint = 0;
  }
  const int gap = config_.merge_gap_cells;
  for (std::size_t i = 0; i < capacity_; ++i) parent_[i] = static_cast<std::uint32_t>(i);
  // Features of one object cut by zone faces touch across the face. In one
  // zone, obstacles whose x-y boxes mostly overlap are the faces of one object
  // seen from opposite sides (a hut flown out and back), apart once the halo
  // between them is trimmed.
  for (std::size_t i = 0; i < capacity_; ++i) {
    const Feature& a = features_[i];
    if (!a.in_use) continue;
    for (std::size_t j = i + 1; j < capacity_; ++j) {
      const Feature& b = features_[j];
      if (!b.in_use || b.kind != a.kind) continue;
      const bool one_object = a.kind == FeatureKind::kObstacle && mostly_overlap_xy(a, b);
      if (b.zone == a.zone && !one_object) continue;
      // Parts of one object one above the other (the halo trim can take a weaker
      // middle for the halo of a stronger end: a post in two boxes) join across
      // the trim's reach in z as well.
      const int gap_z = b.zone == a.zone ? gap + kTrimReachZ : gap;
      if (a.min.x > b.max.x + gap || b.min.x > a.max.x + gap || a.min.y > b.max.y + gap ||
          b.min.y > a.max.y + gap || a.min.z > b.max.z + gap_z || b.min.z > a.max.z + gap_z) {
        continue;
      }
      const std::uint32_t ra = find_root(parent_.get(), static_cast<std::uint32_t>(i));
      const std::uint32_t rb = find_root(parent_.get(), static_cast<std::uint32_t>(j));
      if (ra != rb) parent_[std::max(ra, rb)] = std::min(ra, rb);
    }
  }
  std::size_t n = 0;
  // Roots first write their group; obstacles before ground.
  for (const FeatureKind kind : {FeatureKind::kObstacle, FeatureKind::kGround}) {
    if (kind == FeatureKind::kGround && !include_ground) break;
    for (std::size_t i = 0; i < capacity_ && n < capacity; ++i) {
      const Feature& root = features_[i];
      if (!root.in_use || root.kind != kind ||
          find_root(parent_.get(), static_cast<std::uint32_t>(i)) != i) {
        continue;
      }
      ObstacleBox box;
      box.kind = kind;
      box.id = root.id;
      box.first_seen_s = root.first_seen_s;
      box.last_seen_s = root.last_seen_s;
      box.prior = true;
      CellIndex lo = root.min;
      CellIndex hi = root.max;
      const std::size_t first_rect = footprints != nullptr ? footprints->used : 0;
      bool footprint_fits = true;
      for (std::size_t j = i; j < capacity_; ++j) {
        const Feature& f = features_[j];
        if (!f.in_use || find_root(parent_.get(), static_cast<std::uint32_t>(j)) != i) continue;
        if (footprints != nullptr && footprint_fits) {
          footprint_fits = append_footprint(f, footprints);
        }
        lo = {std::min(lo.x, f.min.x), std::min(lo.y, f.min.y), std::min(lo.z, f.min.z)};
        hi = {std::max(hi.x, f.max.x), std::max(hi.y, f.max.y), std::max(hi.z, f.max.z)};
        box.id = std::min(box.id, f.id);
        box.first_seen_s = std::min(box.first_seen_s, f.first_seen_s);
        box.last_seen_s = std::max(box.last_seen_s, f.last_seen_s);
        box.cells += f.cells;
        box.prior &= f.prior;
        ++box.parts;
      }
      box.min = Eigen::Vector3d(lo.x, lo.y, lo.z) * cell_size_m_;
      box.max = Eigen::Vector3d(hi.x + 1, hi.y + 1, hi.z + 1) * cell_size_m_;
      if (footprints != nullptr) {
        footprints->offsets[n] = static_cast<std::uint32_t>(first_rect);
        footprints->counts[n] =
            footprint_fits ? static_cast<std::uint32_t>(footprints->used - first_rect) : 0;
        if (!footprint_fits) {
          footprints->used = first_rect;  // the space goes to the next box
          ++footprints->boxes_without_footprint;
        }
      }
      out[n++] = box;
    }
  }
  return n;
}

bool FeatureMap::append_footprint(const Feature& f, FootprintOutput* out) const {
  const auto rect = [&](int x0, int y0, int x1, int y1) {  // cells [x0, x1) x [y0, y1)
    out->rects[out->used++] = {
        static_cast<float>(x0 * cell_size_m_), static_cast<float>(y0 * cell_size_m_),
        static_cast<float>(x1 * cell_size_m_), static_cast<float>(y1 * cell_size_m_)};
  };
  if (!f.has_shape) {
    if (out->used >= out->capacity) return false;
    rect(f.min.x, f.min.y, f.max.x + 1, f.max.y + 1);
    return true;
  }
  bool fits = true;
  shapes_.for_each_full_square(f.shape, f.shape_side, [&](int sx, int sy, int size) {
    if (out->used >= out->capacity) return fits = false;
    // The tree covers a power-of-two square: clip to the feature's box.
    const int x0 = f.min.x + sx, y0 = f.min.y + sy;
    rect(x0, y0, std::min(x0 + size, f.max.x + 1), std::min(y0 + size, f.max.y + 1));
    return true;
  });
  if (!fits) return false;
  return true;
}

}  // namespace zonemap
