// The global grid M of paper §III-D: the world is cut into fixed cuboid zones
// the size of the sensor environment; only the (at most 8) zones that the
// environment cube around the camera overlaps hold a grid. Zone buffers come
// from a pool reserved at construction and are reused, never allocated later.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>

#include "zonemap/common/cell.hpp"
#include "zonemap/common/config.hpp"
#include "zonemap/common/work_split.hpp"

namespace zonemap {

class LocalGrid;

struct ZoneKey {
  std::int32_t i = 0;
  std::int32_t j = 0;
  std::int32_t k = 0;
  friend constexpr bool operator==(const ZoneKey&, const ZoneKey&) = default;
};

// Read/write view of one zone that holds a grid.
struct ZoneView {
  ZoneKey key;
  CellIndex origin;         // world cell of the zone's minimum corner
  std::array<int, 3> dims;  // cells per axis
  FusedCell* cells;         // x fastest, then y, then z

  std::size_t index(int x, int y, int z) const {
    return static_cast<std::size_t>(x) +
           static_cast<std::size_t>(dims[0]) *
               (static_cast<std::size_t>(y) +
                static_cast<std::size_t>(dims[1]) * static_cast<std::size_t>(z));
  }
};

// Told when a zone gets a grid (to re-integrate features, §IV-B) and just before
// its grid is discarded (to extract features, §IV-A). Called on the mapping path:
// implementations must not allocate or block.
class ZoneObserver {
 public:
  virtual ~ZoneObserver() = default;
  virtual void on_zone_allocated(ZoneView& zone) = 0;
  virtual void on_zone_discarding(const ZoneView& zone) = 0;
};

class ZoneMap {
 public:
  // Reserves kZonesHeld zone buffers of the configured size. The configuration
  // must have passed validate().
  explicit ZoneMap(const MapConfig& config);

  // Observers are told in the order added (e.g. the feature map, then outputs).
  // Returns false when kMaxObservers are already registered.
  bool add_observer(ZoneObserver* observer);
  // Puts `replacement` where `current` was (false when it was not there): the
  // pipeline feeds its extraction thread instead of the feature map.
  bool replace_observer(ZoneObserver* current, ZoneObserver* replacement);
  static constexpr int kMaxObservers = 4;

  // The environment cube (zone-sized) about `camera_cell` (MapConfig::placement):
  // its minimum corner. world_z_up tells which way "below" is.
  CellIndex environment_origin(const CellIndex& camera_cell, bool world_z_up = true) const;

  // Makes the zones overlapping the environment with minimum corner `origin` hold
  // a grid: new ones are taken from the pool and cleared. Zones left behind are
  // discarded one a call, oldest first, or sooner when a new zone needs their
  // buffer; until then they keep their grid (live, outside the environment: no
  // frame is fused into them, and one the environment comes back to is whole).
  // Returns how many zones were newly allocated. With a split, its parts clear
  // the new zones' cells (each a piece of its own).
  int move_environment(const CellIndex& origin, WorkSplit* split = nullptr);
  // Live zones outside the environment, waiting to be discarded.
  int left_behind_count() const;

  // Eq. (7): m_t = m_{t-1} + m̂_t for every cell of the local grid, saturating at
  // ±limit. The local grid's origin must be the current environment origin.
  // With a split, each part adds its own share of the rows (the sum is the same).
  void fuse(const LocalGrid& local, WorkSplit* split = nullptr);

  // The fused value of a world cell, or false when no zone holds a grid there.
  bool value_at(const CellIndex& cell, FusedCell* value) const;

  ZoneKey key_of(const CellIndex& cell) const;
  // The same for any map of this configuration (zone faces in z at k * dims_z + phase).
  static ZoneKey key_of(const MapConfig& config, const CellIndex& cell);
  static CellIndex origin_of(const MapConfig& config, const ZoneKey& key);

  int live_zone_count() const;
  // The zone `key` when it holds a grid.
  bool live_view(const ZoneKey& key, ZoneView* view);
  // The n-th zone holding a grid (for_each_live_zone order), when there is one.
  bool nth_live_view(int n, ZoneView* view);
  // Visits the zones that hold a grid; `fn(ZoneView&)`.
  template <typename Fn>
  void for_each_live_zone(Fn&& fn) {
    for (auto& slot : slots_) {
      if (slot.live) {
        ZoneView view = view_of(slot);
        fn(view);
      }
    }
  }

  std::int64_t zones_allocated() const { return zones_allocated_; }
  std::int64_t zones_discarded() const { return zones_discarded_; }
  std::size_t reserved_bytes() const { return cells_per_zone_ * kZonesHeld * sizeof(FusedCell); }
  FusedCell limit() const { return limit_; }
  const std::array<int, 3>& zone_dims() const { return dims_; }

 private:
  void clear_cells(FusedCell* cells, WorkSplit* split) const;
  void fuse_rows(const LocalGrid& local, RowShare share);
  struct Slot {
    ZoneKey key;
    bool live = false;
    FusedCell* cells = nullptr;
    std::int64_t left_at = 0;  // the move_environment call it was left behind in; 0: wanted
  };
  Slot* discard_oldest_left();  // its observers told; null when no zone was left behind
  ZoneView view_of(const Slot& slot) const;
  Slot* find(const ZoneKey& key);
  const Slot* find(const ZoneKey& key) const;

  std::array<int, 3> dims_;
  MapConfig::Placement placement_;
  int above_cells_;  // kBelow: cells between the camera's cell and the environment's top
  // Zone faces in z lie at k * dims_z + z_phase_. kBelow reaches down to the ground,
  // which usually lies at z = 0 (the take-off level): half a zone of phase keeps it
  // inside a zone instead of on a face, where the ground layer would be cut in two
  // and its lower half read as an obstacle standing in the upper zone's floor.
  int z_phase_;
  std::size_t cells_per_zone_;
  FusedCell limit_;
  std::unique_ptr<FusedCell[]> pool_;
  std::array<Slot, kZonesHeld> slots_{};
  std::array<ZoneObserver*, kMaxObservers> observers_{};
  int observer_count_ = 0;
  std::int64_t zones_allocated_ = 0;
  std::int64_t zones_discarded_ = 0;
  std::int64_t moves_ = 0;  // move_environment calls
};

}  // namespace zonemap
