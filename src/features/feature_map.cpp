#include "zonemap/features/feature_map.hpp"

// The feature map (paper §IV): the store, extraction of a zone into it, and
// why a feature that is not found again goes.
#include <algorithm>
#include <array>
#include <cmath>

#include "common/simd_u16.hpp"
#include "features/feature_map_detail.hpp"

namespace zonemap {

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
      record_removal(zone, *f);
      remove(f);
      ++counters_.features_removed;
    }
  }
}

RemovalCause FeatureMap::removal_cause(const ZoneSnapshot& zone, const Feature& f,
                                       std::int32_t* occupied) {
  const CellIndex o = zone.origin();
  *occupied = 0;
  // Bounded by the feature's box, which lies inside the zone.
  for (int z = f.min.z; z <= f.max.z; ++z)
    for (int y = f.min.y; y <= f.max.y; ++y)
      for (int x = f.min.x; x <= f.max.x; ++x) {
        if (feature_contains(f, {x, y, z}) &&
            zone.occupied(zone.index(x - o.x, y - o.y, z - o.z))) {
          ++*occupied;
        }
      }
  if (*occupied * 10 <= f.cells) {
    return in_view(f.min, f.max) ? RemovalCause::kSeenFree : RemovalCause::kUnseen;
  }
  for (const Feature* g = features_.get(); g != features_.get() + capacity_; ++g) {
    if (g->in_use && !g->stale && g->kind == FeatureKind::kObstacle && g->zone == f.zone &&
        overlap_volume(g->min, g->max, f.min, f.max) > 0) {
      return RemovalCause::kJoined;
    }
  }
  return RemovalCause::kOther;
}

void FeatureMap::record_removal(const ZoneSnapshot& zone, const Feature& f) {
  FeatureRemoval r;
  r.cause = removal_cause(zone, f, &r.occupied);
  switch (r.cause) {
    case RemovalCause::kSeenFree:
      ++counters_.removed_seen_free;
      break;
    case RemovalCause::kUnseen:
      ++counters_.removed_unseen;
      break;
    case RemovalCause::kJoined:
      ++counters_.removed_joined;
      break;
    case RemovalCause::kOther:
      ++counters_.removed_other;
      break;
  }
  r.id = f.id;
  r.kind = f.kind;
  r.prior = f.prior;
  r.min = f.min;
  r.max = f.max;
  r.cells = f.cells;
  r.time_s = time_s_;
  removals_[static_cast<std::size_t>(removals_recorded_ % kRemovalsKept)] = r;
  ++removals_recorded_;
}

const char* to_string(RemovalCause cause) {
  switch (cause) {
    case RemovalCause::kSeenFree:
      return "its cells seen free in view";
    case RemovalCause::kUnseen:
      return "its cells free, not in view";
    case RemovalCause::kJoined:
      return "its cells now in another obstacle";
    case RemovalCause::kOther:
      return "its cells occupied but no obstacle's (ground, trimmed, too few)";
  }
  return "?";
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

}  // namespace zonemap
