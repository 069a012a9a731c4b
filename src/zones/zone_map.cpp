#include "zonemap/zones/zone_map.hpp"

#include <algorithm>
#include <cmath>

#include "zonemap/integrator/local_grid.hpp"

namespace zonemap {
namespace {

int z_phase_of(const MapConfig& config) {
  return config.placement == MapConfig::Placement::kBelow ? -(config.zone_cells[2] / 2) : 0;
}

}  // namespace

ZoneMap::ZoneMap(const MapConfig& config)
    : dims_(config.zone_cells),
      placement_(config.placement),
      above_cells_(
          std::clamp(static_cast<int>(std::ceil(config.above_camera_m / config.cell_size_m)), 0,
                     config.zone_cells[2] - 1)),
      z_phase_(z_phase_of(config)),
      cells_per_zone_(zone_cell_count(config)),
      limit_(static_cast<FusedCell>(std::min(to_fixed(static_cast<float>(config.saturation_units)),
                                             kMaxFusedUnits * kCellScale))),
      pool_(new FusedCell[cells_per_zone_ * kZonesHeld]()) {
  for (std::size_t s = 0; s < slots_.size(); ++s) {
    slots_[s].cells = pool_.get() + s * cells_per_zone_;
  }
}

bool ZoneMap::replace_observer(ZoneObserver* current, ZoneObserver* replacement) {
  for (int i = 0; i < observer_count_; ++i) {
    if (observers_[static_cast<std::size_t>(i)] == current) {
      observers_[static_cast<std::size_t>(i)] = replacement;
      return true;
    }
  }
  return false;
}

bool ZoneMap::live_view(const ZoneKey& key, ZoneView* view) {
  const Slot* slot = find(key);
  if (slot == nullptr) return false;
  *view = view_of(*slot);
  return true;
}

bool ZoneMap::nth_live_view(int n, ZoneView* view) {
  for (const Slot& slot : slots_) {
    if (slot.live && n-- == 0) {
      *view = view_of(slot);
      return true;
    }
  }
  return false;
}

bool ZoneMap::add_observer(ZoneObserver* observer) {
  if (observer_count_ >= kMaxObservers) return false;
  observers_[static_cast<std::size_t>(observer_count_++)] = observer;
  return true;
}

CellIndex ZoneMap::environment_origin(const CellIndex& camera_cell, bool world_z_up) const {
  std::int32_t z = camera_cell.z - dims_[2] / 2;
  if (placement_ == MapConfig::Placement::kBelow) {
    // above_cells_ cells between the camera's cell and the top face (z up), or the
    // bottom face when z points down.
    z = world_z_up ? camera_cell.z - (dims_[2] - 1 - above_cells_) : camera_cell.z - above_cells_;
  }
  return CellIndex{camera_cell.x - dims_[0] / 2, camera_cell.y - dims_[1] / 2, z};
}

ZoneKey ZoneMap::key_of(const CellIndex& cell) const {
  return ZoneKey{floor_div(cell.x, dims_[0]), floor_div(cell.y, dims_[1]),
                 floor_div(cell.z - z_phase_, dims_[2])};
}

ZoneKey ZoneMap::key_of(const MapConfig& config, const CellIndex& cell) {
  const std::array<int, 3>& d = config.zone_cells;
  return ZoneKey{floor_div(cell.x, d[0]), floor_div(cell.y, d[1]),
                 floor_div(cell.z - z_phase_of(config), d[2])};
}

CellIndex ZoneMap::origin_of(const MapConfig& config, const ZoneKey& key) {
  const std::array<int, 3>& d = config.zone_cells;
  return CellIndex{key.i * d[0], key.j * d[1], key.k * d[2] + z_phase_of(config)};
}

ZoneView ZoneMap::view_of(const Slot& slot) const {
  return ZoneView{
      slot.key,
      CellIndex{slot.key.i * dims_[0], slot.key.j * dims_[1], slot.key.k * dims_[2] + z_phase_},
      dims_, slot.cells};
}

ZoneMap::Slot* ZoneMap::find(const ZoneKey& key) {
  for (auto& slot : slots_) {
    if (slot.live && slot.key == key) return &slot;
  }
  return nullptr;
}

const ZoneMap::Slot* ZoneMap::find(const ZoneKey& key) const {
  for (const auto& slot : slots_) {
    if (slot.live && slot.key == key) return &slot;
  }
  return nullptr;
}

int ZoneMap::live_zone_count() const {
  return static_cast<int>(
      std::count_if(slots_.begin(), slots_.end(), [](const Slot& s) { return s.live; }));
}

// A new zone's cells to unknown, in as many contiguous pieces as the split has
// parts (a zone is megabytes: on the mapping workers' cores too).
void ZoneMap::clear_cells(FusedCell* cells, WorkSplit* split) const {
  const int parts = split == nullptr ? 1 : split->parts();
  for_each_part(split, parts, [&](int part, int all) {
    const std::size_t n = cells_per_zone_ / static_cast<std::size_t>(all);
    const std::size_t first = n * static_cast<std::size_t>(part);
    const std::size_t end = part == all - 1 ? cells_per_zone_ : first + n;
    std::fill(cells + first, cells + end, FusedCell{0});
  });
}

int ZoneMap::move_environment(const CellIndex& origin, WorkSplit* split) {
  const ZoneKey low = key_of(origin);
  const ZoneKey high =
      key_of(CellIndex{origin.x + dims_[0] - 1, origin.y + dims_[1] - 1, origin.z + dims_[2] - 1});
  auto wanted = [&](const ZoneKey& k) {
    return k.i >= low.i && k.i <= high.i && k.j >= low.j && k.j <= high.j && k.k >= low.k &&
           k.k <= high.k;
  };
  // Zones the environment left keep their grid until their buffer is wanted, or
  // for at most a call each after the first (oldest first): several left behind
  // in one frame (four, crossing a zone face with the environment across two
  // rows and layers) cost their extraction one a frame, not all at once; one the
  // environment comes back to is still whole.
  ++moves_;
  for (auto& slot : slots_) {
    if (!slot.live) continue;
    if (wanted(slot.key)) {
      slot.left_at = 0;
    } else if (slot.left_at == 0) {
      slot.left_at = moves_;
    }
  }
  int allocated = 0;
  for (std::int32_t k = low.k; k <= high.k; ++k) {
    for (std::int32_t j = low.j; j <= high.j; ++j) {
      for (std::int32_t i = low.i; i <= high.i; ++i) {
        const ZoneKey key{i, j, k};
        if (find(key) != nullptr) continue;
        // The environment is one zone in size, so at most 2x2x2 zones are wanted
        // and a slot is always free or held by a zone left behind.
        Slot* free_slot = nullptr;
        for (auto& slot : slots_) {
          if (!slot.live) {
            free_slot = &slot;
            break;
          }
        }
        if (free_slot == nullptr) free_slot = discard_oldest_left();
        if (free_slot == nullptr) continue;
        free_slot->key = key;
        free_slot->live = true;
        free_slot->left_at = 0;
        clear_cells(free_slot->cells, split);
        ++zones_allocated_;
        ++allocated;
        ZoneView view = view_of(*free_slot);
        for (int o = 0; o < observer_count_; ++o) observers_[o]->on_zone_allocated(view);
      }
    }
  }
  discard_oldest_left();
  return allocated;
}

ZoneMap::Slot* ZoneMap::discard_oldest_left() {
  Slot* oldest = nullptr;
  for (auto& slot : slots_) {
    if (slot.live && slot.left_at != 0 && (oldest == nullptr || slot.left_at < oldest->left_at))
      oldest = &slot;
  }
  if (oldest == nullptr) return nullptr;
  for (int o = 0; o < observer_count_; ++o) observers_[o]->on_zone_discarding(view_of(*oldest));
  oldest->live = false;
  oldest->left_at = 0;
  ++zones_discarded_;
  return oldest;
}

int ZoneMap::left_behind_count() const {
  int n = 0;
  for (const auto& slot : slots_) n += slot.live && slot.left_at != 0 ? 1 : 0;
  return n;
}

void ZoneMap::fuse(const LocalGrid& local, WorkSplit* split) {
  const int parts = split == nullptr ? 1 : split->parts();
  for_each_part(split, parts, [&](int part, int all) { fuse_rows(local, share_of(part, all)); });
}

void ZoneMap::fuse_rows(const LocalGrid& local, RowShare share) {
  // Only the local grid's active region holds values; the rest is untouched.
  const CellIndex origin = local.origin();
  const CellIndex lo{origin.x + local.active_lo()[0], origin.y + local.active_lo()[1],
                     origin.z + local.active_lo()[2]};
  const std::array<int, 3> ld = {local.active_hi()[0] - local.active_lo()[0] + 1,
                                 local.active_hi()[1] - local.active_lo()[1] + 1,
                                 local.active_hi()[2] - local.active_lo()[2] + 1};
  if (ld[0] <= 0 || ld[1] <= 0 || ld[2] <= 0) return;
  const int lim = limit_;
  for (auto& slot : slots_) {
    if (!slot.live) continue;
    const ZoneView zone = view_of(slot);
    // Intersection of the local grid and the zone, in world cells.
    const int x0 = std::max(lo.x, zone.origin.x);
    const int x1 = std::min(lo.x + ld[0], zone.origin.x + dims_[0]);
    const int y0 = std::max(lo.y, zone.origin.y);
    const int y1 = std::min(lo.y + ld[1], zone.origin.y + dims_[1]);
    const int z0 = std::max(lo.z, zone.origin.z);
    const int z1 = std::min(lo.z + ld[2], zone.origin.z + dims_[2]);
    if (x0 >= x1 || y0 >= y1 || z0 >= z1) continue;
    for (int z = z0 + share.first; z < z1; z += share.step) {
      for (int y = y0; y < y1; ++y) {
        // Only the row's span can be non-zero (0 adds nothing).
        int span_lo = 0, span_hi = -1;
        if (!local.row_span(y - origin.y, z - origin.z, &span_lo, &span_hi)) continue;
        const int from = std::max(x0, origin.x + span_lo);
        const int row = std::min(x1, origin.x + span_hi + 1) - from;
        if (row <= 0) continue;
        const LocalCell* src =
            local.data() + local.index(from - origin.x, y - origin.y, z - origin.z);
        FusedCell* dst =
            zone.cells + zone.index(from - zone.origin.x, y - zone.origin.y, z - zone.origin.z);
        // Without a branch, so that it vectorises: a 0 leaves the (already
        // clamped) cell as it is.
        for (int x = 0; x < row; ++x) {
          const int sum = static_cast<int>(dst[x]) + static_cast<int>(src[x]);
          dst[x] = static_cast<FusedCell>(std::clamp(sum, -lim, lim));
        }
      }
    }
  }
}

bool ZoneMap::value_at(const CellIndex& cell, FusedCell* value) const {
  const Slot* slot = find(key_of(cell));
  if (slot == nullptr) return false;
  const ZoneView view = view_of(*slot);
  *value = view.cells[view.index(cell.x - view.origin.x, cell.y - view.origin.y,
                                 cell.z - view.origin.z)];
  return true;
}

}  // namespace zonemap
