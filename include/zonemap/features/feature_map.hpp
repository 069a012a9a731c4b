// The global feature map (paper §IV): per zone, occupied cells are split into
// ground and obstacles, 6-connected obstacles become bounding boxes with a
// quadtree footprint (eq. 8), kept when the grid moves on and written back into
// the grid when their zone is allocated again (§IV-B). Fixed capacity, reserved
// at construction; extraction and re-integration do not allocate.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "zonemap/common/camera.hpp"
#include "zonemap/common/cell.hpp"
#include "zonemap/common/config.hpp"
#include "zonemap/containers/quadtree.hpp"
#include "zonemap/containers/window_min.hpp"
#include "zonemap/zones/zone_map.hpp"
#include "zonemap/zones/zone_snapshot.hpp"

namespace zonemap {

enum class FeatureKind : std::uint8_t { kObstacle, kGround };

struct Feature {
  std::uint32_t id = 0;  // stable across re-extractions of the same object
  FeatureKind kind = FeatureKind::kObstacle;
  // 0: this vehicle's map; else the map shared by sender `shared_source` (1..):
  // never written into the grid, replaced by that sender's next map (replace_shared).
  std::uint8_t shared_source = 0;
  ZoneKey zone;
  CellIndex min;  // world cells, inclusive; always inside `zone`
  CellIndex max;
  std::int32_t cells = 0;  // occupied cells it was made of
  double first_seen_s = 0.0;
  // The last extraction that found it while some of it stood in the camera's view
  // (within d_max); a feature whose cells are later seen free is removed instead.
  double last_seen_s = 0.0;
  QuadNode shape;  // footprint over [min.x, min.x + shape_side) x [min.y, min.y + shape_side)
  int shape_side = 0;
  bool has_shape = false;  // false: the pool was full, the whole box counts as occupied
  bool in_use = false;
  bool stale = false;  // during an update of its zone: not matched yet
  // Known before the flight (add_prior) or from another vehicle (replace_shared),
  // and not yet confirmed by a view of this vehicle's camera.
  bool prior = false;
};
static_assert(sizeof(Feature) <= 80, "the store's size is in the memory budget");

// One object of the output: per-zone features of the same object merged.
struct ObstacleBox {
  std::uint32_t id = 0;  // the smallest id of its features
  FeatureKind kind = FeatureKind::kObstacle;
  bool prior = false;  // every feature of it is prior, none confirmed by a view (in padding)
  Eigen::Vector3d min = Eigen::Vector3d::Zero();  // world metres
  Eigen::Vector3d max = Eigen::Vector3d::Zero();
  std::int32_t cells = 0;
  std::int32_t parts = 0;     // per-zone features merged into it
  double first_seen_s = 0.0;  // earliest of its features
  double last_seen_s = 0.0;   // latest of its features (Feature::last_seen_s)
};

// Footprint of a merged box for the outputs: the full squares of its features'
// quadtrees as world rectangles (a feature without a shape gives its box).
struct FootprintRect {
  float x0, y0, x1, y1;
};
struct FootprintOutput {
  FootprintRect* rects = nullptr;
  std::size_t capacity = 0;          // rectangles in all
  std::uint32_t* offsets = nullptr;  // per box: first rectangle
  std::uint32_t* counts = nullptr;   // per box: rectangles (0 when they did not fit)
  std::size_t used = 0;
  std::int64_t boxes_without_footprint = 0;  // did not fit: the box is the shape
};

struct FeatureCounters {
  std::int64_t extractions = 0;
  std::int64_t features_added = 0;
  std::int64_t features_updated = 0;
  std::int64_t features_removed = 0;   // gone from the grid on re-extraction, by cause:
  std::int64_t removed_seen_free = 0;  //   its cells free, part of it in view
  std::int64_t removed_unseen = 0;     //   its cells free, none of it in view
  std::int64_t removed_joined = 0;     //   its cells now in another obstacle of the zone
  std::int64_t removed_other =
      0;  //   its cells occupied but no obstacle's (ground, trimmed, too small)
  std::int64_t features_evicted = 0;        // store full: a less relevant feature made room
  std::int64_t features_dropped = 0;        // store full: the new feature was the least relevant
  std::int64_t objects_too_small = 0;       // fewer than min_cells: noise
  std::int64_t objects_in_ground_band = 0;  // no higher than the ground around them: ground
  std::int64_t objects_split = 0;           // components split at value dips into several objects
  std::int64_t shapes_truncated = 0;        // quadtree pool full: box kept without its shape
  std::int64_t cells_reintegrated = 0;
  // A-priori features (add_prior): pieces stored, confirmed occupied by a view,
  // removed when views saw their cells free, not stored (the store was full).
  std::int64_t priors_added = 0, priors_confirmed = 0, priors_removed = 0, priors_dropped = 0;
  // Maps shared by other vehicles (replace_shared): updates taken, pieces added,
  // kept (the same object again), removed (no longer in the sender's map), not
  // stored (the store was full).
  std::int64_t shared_updates = 0, shared_added = 0, shared_kept = 0, shared_removed = 0,
               shared_dropped = 0;
};

// One feature the extraction did not find again and removed, with the evidence:
// what the grid held in its footprint when it went.
enum class RemovalCause : std::uint8_t { kSeenFree, kUnseen, kJoined, kOther };
struct FeatureRemoval {
  std::uint32_t id = 0;
  FeatureKind kind = FeatureKind::kObstacle;
  RemovalCause cause = RemovalCause::kSeenFree;
  bool prior = false;
  CellIndex min, max;         // world cells, inclusive
  std::int32_t cells = 0;     // it was made of
  std::int32_t occupied = 0;  // of its footprint's cells still occupied when it went
  double time_s = 0.0;        // the extraction's
};
const char* to_string(RemovalCause cause);

class FeatureMap : public ZoneObserver {
 public:
  // world_z_up: false when the world frame is NED (height = -z).
  FeatureMap(const MapConfig& config, bool world_z_up);

  // The camera whose view decides last-seen stamps. Without it (or without a
  // camera pose in the context) every extraction that finds a feature sees it.
  void set_camera(const CameraModel& camera);
  // Time and vehicle position for first/last-seen stamps and relevance.
  void set_context(double time_s, const Eigen::Vector3d& vehicle_m) {
    time_s_ = time_s;
    vehicle_m_ = vehicle_m;
    view_known_ = false;
  }
  // The same with the camera's pose (its position is the vehicle's).
  void set_context(double time_s, const Eigen::Isometry3d& world_T_camera) {
    time_s_ = time_s;
    vehicle_m_ = world_T_camera.translation();
    camera_T_world_ = world_T_camera.inverse();
    view_known_ = true;
  }

  // Extracts the features of a zone that holds a grid: its previous features are
  // updated (same object = overlapping box), new ones added, vanished ones removed.
  void extract(const ZoneView& zone);
  // The same from a snapshot (taken with occupied_threshold(), maybe on another thread).
  void extract(const ZoneSnapshot& zone);
  FusedCell occupied_threshold() const { return threshold_; }

  // A-priori knowledge (the paper's abstract, §IV): an obstacle known before the
  // flight, world metres. Cut into the zones it spans, each piece a feature
  // marked prior (a full box: no footprint) that is written into its zone's grid
  // when the zone is allocated, like any stored feature. An extraction that finds
  // it occupied while it stands in view makes it an ordinary feature; one that
  // finds its cells seen free removes it (both counted). When the store is full
  // the usual relevance rule decides (obstacles by size and nearness to the
  // vehicle); a piece left out is counted and the call returns false.
  bool add_prior(const Eigen::Vector3d& min_m, const Eigen::Vector3d& max_m);

  // Another vehicle's map (its obstacles in this map's world metres, min/max
  // pairs): replaces what `source` (1..255) sent before. Its boxes are cut at
  // zone faces like priors and marked prior (no view of ours confirmed them),
  // but never written into the grid: the sender's map stays the sender's, and
  // leaves with its next map that lacks a box. A piece overlapping one that
  // source sent before keeps its id. Store full: the relevance rule, counted.
  // Returns the pieces stored.
  std::size_t replace_shared(std::uint8_t source, const Eigen::Vector3d* min_m,
                             const Eigen::Vector3d* max_m, std::size_t count);

  // ZoneObserver: re-integration on allocation, extraction before discard.
  void on_zone_allocated(ZoneView& zone) override;

  // §IV-B as boxes of world cells (inclusive), so that another thread can do the
  // writing: the stored obstacles of zone `key`, their shapes' full quadtree
  // squares (clipped to their boxes) over their height. emit(min, max).
  template <typename Emit>
  void for_each_reintegration_box(const ZoneKey& key, Emit&& emit) const {
    for (const Feature* f = features_.get(); f != features_.get() + capacity_; ++f) {
      if (!f->in_use || f->kind != FeatureKind::kObstacle || !(f->zone == key) ||
          f->shared_source != 0) {
        continue;
      }
      if (!f->has_shape) {
        emit(f->min, f->max);
        continue;
      }
      shapes_.for_each_full_square(f->shape, f->shape_side, [&](int sx, int sy, int size) {
        const CellIndex lo{f->min.x + sx, f->min.y + sy, f->min.z};
        const CellIndex hi{std::min(f->min.x + sx + size - 1, f->max.x),
                           std::min(f->min.y + sy + size - 1, f->max.y), f->max.z};
        if (lo.x <= hi.x && lo.y <= hi.y) emit(lo, hi);
        return true;
      });
    }
  }
  // Max-writes `value` into the cells of [min, max] that lie in the zone; returns
  // how many cells that was.
  static std::int64_t reintegrate_box(ZoneView& zone, const CellIndex& min, const CellIndex& max,
                                      FusedCell value);
  FusedCell reintegration_value() const { return reintegration_value_; }
  // Cells another thread re-integrated for this map (the pipeline's mapping thread).
  void add_cells_reintegrated(std::int64_t cells) { counters_.cells_reintegrated += cells; }
  void on_zone_discarding(const ZoneView& zone) override { extract(zone); }

  // Merges features of one object cut by zone boundaries. Writes at most
  // `capacity` boxes (obstacles before ground) and returns how many.
  // With `footprints`, each box's footprint rectangles too (bounded by its capacity).
  std::size_t merged(ObstacleBox* out, std::size_t capacity, bool include_ground,
                     FootprintOutput* footprints = nullptr);

  // Footprint test in world cells for a feature (box and shape).
  bool feature_contains(const Feature& f, const CellIndex& cell) const;

  const Feature* begin() const { return features_.get(); }
  const Feature* end() const { return features_.get() + capacity_; }
  std::size_t capacity() const { return capacity_; }
  std::size_t count() const { return in_use_; }
  std::size_t count(FeatureKind kind) const;
  const FeatureCounters& counters() const { return counters_; }
  // The last kRemovalsKept removals, for an edge to log: removal n (0-based, of
  // removals_recorded()) is removal(n) while n + kRemovalsKept > removals_recorded().
  static constexpr std::size_t kRemovalsKept = 32;
  std::int64_t removals_recorded() const { return removals_recorded_; }
  const FeatureRemoval& removal(std::int64_t n) const {
    return removals_[static_cast<std::size_t>(n) % kRemovalsKept];
  }
  std::size_t reserved_bytes() const;
  const QuadtreePool& shapes() const { return shapes_; }
  double cell_size_m() const { return cell_size_m_; }

 private:
  bool is_ground_cell(int x, int y, int z) const;
  void compute_terrain(const ZoneSnapshot& zone);
  // compute_terrain's stages (src/feature_terrain.cpp).
  void scan_columns(const ZoneSnapshot& zone);
  void column_surface(const ZoneSnapshot& zone, int x, int y, std::int16_t* surface,
                      std::int16_t* run_top) const;
  void keep_surface_windows();
  void borrow_terrain_where_unseen();
  // ground_top_ from terrain_ and run_top_: the thickness, or the band as measured.
  void compute_ground_top();
  // The band's height about column (x, y) as measured (0: not a surface band), and
  // the `fraction` quantile of the window's clipped run heights above the terrain.
  int measured_band(int x, int y) const;
  int band_quantile(int x, int y, double fraction) const;
  // out = minimum of the values within radius r (kNoHeight entries left out).
  void window_min(const std::int16_t* values, std::int16_t* out, std::int16_t* tmp, int r) const;
  // measured: views added to its cells (a prior one it matches is then confirmed).
  void upsert(const ZoneKey& zone, FeatureKind kind, const CellIndex& min, const CellIndex& max,
              std::int32_t cells, bool measured);
  bool measured(const ZoneSnapshot& zone, const std::uint32_t* cells, std::size_t count) const;
  bool within_ground_around(const CellIndex& lo, const CellIndex& hi, int top) const;
  // Why a feature the extraction does not find again goes, by what the snapshot
  // holds in its footprint: counted, and recorded for the edges.
  RemovalCause removal_cause(const ZoneSnapshot& zone, const Feature& f, std::int32_t* occupied);
  void record_removal(const ZoneSnapshot& zone, const Feature& f);
  double relevance(const Feature& f) const;
  // Whether part of the box of world cells [min, max] is in the camera's view:
  // one of its corners, edge middles, face centres or centre projects into the
  // image within d_max.
  bool in_view(const CellIndex& min, const CellIndex& max) const;
  bool append_footprint(const Feature& f, FootprintOutput* out) const;
  // merged()'s parts: the groups (parent_, union-find) and one group's box.
  void group_touching_features();
  ObstacleBox box_of_group(std::size_t root_index, FootprintOutput* footprints, std::size_t n);
  Feature* free_slot(double new_relevance);
  bool add_prior_piece(const ZoneKey& zone, const CellIndex& min, const CellIndex& max);
  // The box of world metres [min, max) as world cells cut at the zone faces:
  // fn(zone, min cell, max cell) per piece (bounded by the box's extent in zones).
  template <typename Fn>
  void for_each_zone_piece(const Eigen::Vector3d& min_m, const Eigen::Vector3d& max_m,
                           Fn&& fn) const;
  // The stale feature of `zone` that `pick` accepts and that overlaps [min, max]
  // most (the same object as before), or null.
  template <typename Pick>
  Feature* most_overlapping_stale(const ZoneKey& zone, const CellIndex& min, const CellIndex& max,
                                  Pick&& pick);
  void add_or_keep_shared(std::uint8_t source, const ZoneKey& zone, const CellIndex& min,
                          const CellIndex& max);
  void remove(Feature* f);
  int height_of(int z) const { return z_up_ ? z : dims_[2] - 1 - z; }
  // Extraction steps: the 6-connected component of one class from `start` into
  // component_ (returns its size); its split into regions around value cores
  // (returns how many; 1: not split, component_ unchanged; else component_ holds
  // the regions one after another, bounded by region_start_); one object's box,
  // footprint and store entry.
  std::size_t fill_component(const ZoneSnapshot& zone, std::size_t start, bool ground);
  std::size_t split_at_valleys(const ZoneSnapshot& zone, std::size_t count);
  // The watershed's two steps at one level (queue entries: packed cell and
  // label; both return the new queue length).
  std::size_t grow_regions(const ZoneSnapshot& zone, std::uint32_t* queue, std::size_t tail,
                           int level);
  std::size_t add_cores(const ZoneSnapshot& zone, std::size_t count, std::uint32_t* queue,
                        std::size_t tail, int level, std::uint32_t* cores);
  // Every column of the component's x-y box gets the label of a core (column_tmp_),
  // flooded from the cores down the columns' peak levels; the component's cells
  // are then sorted by it into regions.
  void label_columns_by_flooding(const ZoneSnapshot& zone, std::size_t count,
                                 const std::uint32_t* queue, std::uint32_t cores);
  void sort_by_column_label(std::size_t count, std::uint32_t cores);
  // Regions (sorted) whose x-y boxes overlap by more than half of the smaller are
  // one object: their columns get one label; true when any were joined.
  bool merge_overlapping_regions(std::uint32_t cores);
  void add_object(const ZoneSnapshot& zone, const std::uint32_t* cells, std::size_t count,
                  bool ground);
  int cell_x(std::size_t i) const {
    return static_cast<int>(i % static_cast<std::size_t>(dims_[0]));
  }
  int cell_y(std::size_t i) const {
    return static_cast<int>((i / static_cast<std::size_t>(dims_[0])) %
                            static_cast<std::size_t>(dims_[1]));
  }
  int cell_z(std::size_t i) const {
    return static_cast<int>(
        i / (static_cast<std::size_t>(dims_[0]) * static_cast<std::size_t>(dims_[1])));
  }
  bool visited(std::size_t i) const { return (visited_[i >> 6] >> (i & 63)) & 1u; }
  void mark(std::size_t i) { visited_[i >> 6] |= std::uint64_t{1} << (i & 63); }
  void unmark(std::size_t i) { visited_[i >> 6] &= ~(std::uint64_t{1} << (i & 63)); }
  // The 6 neighbours inside the zone: fn(index, x, y, z).
  template <typename Fn>
  void for_each_neighbour(std::size_t i, Fn&& fn) const {
    const int x = cell_x(i), y = cell_y(i), z = cell_z(i);
    const std::size_t sx = 1, sy = static_cast<std::size_t>(dims_[0]),
                      sz = sy * static_cast<std::size_t>(dims_[1]);
    if (x > 0) fn(i - sx, x - 1, y, z);
    if (x + 1 < dims_[0]) fn(i + sx, x + 1, y, z);
    if (y > 0) fn(i - sy, x, y - 1, z);
    if (y + 1 < dims_[1]) fn(i + sy, x, y + 1, z);
    if (z > 0) fn(i - sz, x, y, z - 1);
    if (z + 1 < dims_[2]) fn(i + sz, x, y, z + 1);
  }
  // Growth queue entries: a cell index below kMaxZoneCells (22 bits), its core above.
  static constexpr std::uint32_t kCellBits = 22;
  static constexpr std::uint32_t kMaxCores = 1023;
  static_assert(kMaxZoneCells <= (std::size_t{1} << kCellBits));
  static std::uint32_t pack(std::size_t cell, std::uint32_t label) {
    return static_cast<std::uint32_t>(cell) | (label << kCellBits);
  }
  static std::size_t unpack_cell(std::uint32_t e) { return e & ((1u << kCellBits) - 1u); }
  static std::uint32_t unpack_label(std::uint32_t e) { return e >> kCellBits; }

  FeatureConfig config_;
  double cell_size_m_;
  bool z_up_;
  std::array<int, 3> dims_;
  MapConfig map_config_;          // the zones' layout, for cutting priors at zone faces
  std::int64_t priors_live_ = 0;  // prior features in the store, not confirmed yet
  std::array<FeatureRemoval, kRemovalsKept> removals_{};
  std::int64_t removals_recorded_ = 0;
  FusedCell threshold_;
  FusedCell reintegration_value_;
  int ground_thickness_cells_;
  int ground_window_cells_;
  int ground_band_cells_;  // the band's largest measured height (0: the thickness alone)

  std::size_t capacity_;
  std::unique_ptr<Feature[]> features_;
  std::size_t in_use_ = 0;
  std::uint32_t next_id_ = 1;
  QuadtreePool shapes_;

  // Scratch for one zone, reserved once.
  std::unique_ptr<std::uint64_t[]> visited_;      // one bit per zone cell
  std::unique_ptr<std::uint32_t[]> component_;    // cells of the object being filled
  std::unique_ptr<std::uint8_t[]> footprint_;     // nx * ny
  std::unique_ptr<std::int16_t[]> lowest_;        // per column: lowest occupied height, or -1
  std::unique_ptr<std::int16_t[]> near_terrain_;  // per column: terrain within one window radius
  std::unique_ptr<std::int16_t[]> terrain_;       // per column: terrain height, or -1
  std::unique_ptr<std::int16_t[]> run_top_;       // per column: top of the run from lowest_, or -1
  std::unique_ptr<std::int16_t[]> ground_top_;    // per column: highest ground height, or -1
  // Summed-area tables of the columns whose clipped run height above the terrain
  // is at least k, for k = 0 .. ground_band_cells_, interleaved: entry (x, y)
  // holds band_lanes() counts, k in lane k. Counts are kept modulo 2^16: a
  // window's count (its four corners' difference) is below 2^16, so it comes out
  // exact whatever the zone's size, and the k of one entry add as 16-bit lanes.
  int band_lanes() const { return ground_band_cells_ > 0 ? (ground_band_cells_ + 8) / 8 * 8 : 0; }
  std::unique_ptr<std::uint16_t[]> band_tables_;
  std::unique_ptr<std::int16_t[]> column_tmp_;
  // window_min's buffer, for the widest radius (3 windows).
  std::size_t window_buffer_size() const {
    return window_min_buffer_size(dims_[0], dims_[1], 3 * ground_window_cells_);
  }
  std::unique_ptr<std::int16_t[]> window_buffer_;
  std::unique_ptr<std::int32_t[]> coverage_;     // (nx + 1) * (ny + 1) summed-area table
  std::unique_ptr<std::int32_t[]> observed_;     // the same for columns with any known cell
  std::unique_ptr<std::uint32_t[]> parent_;      // union-find for merging, per feature
  int core_min_cells_;                           // 0: objects are never split
  std::unique_ptr<std::size_t[]> region_start_;  // kMaxCores + 1 region bounds
  std::unique_ptr<std::size_t[]> core_first_, core_end_;  // each core's seed cells in the queue
  std::unique_ptr<std::uint32_t[]> column_queue_;         // nx * ny
  struct RegionBox {
    int x0, y0, x1, y1;
  };
  std::unique_ptr<RegionBox[]> region_box_;       // per region, x-y cells
  std::unique_ptr<std::uint16_t[]> region_root_;  // union-find over regions
  ZoneSnapshot scratch_;                          // extract(ZoneView) goes through it
  PeakTrim trim_;                                 // ... keeping the cells it keeps

  double time_s_ = 0.0;
  Eigen::Vector3d vehicle_m_ = Eigen::Vector3d::Zero();
  double d_max_m_;
  CameraModel camera_;  // width 0: not set
  Eigen::Isometry3d camera_T_world_ = Eigen::Isometry3d::Identity();
  bool view_known_ = false;
  FeatureCounters counters_;
};

}  // namespace zonemap
