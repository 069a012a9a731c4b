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

#include "zonemap/cell.hpp"
#include "zonemap/config.hpp"
#include "zonemap/quadtree.hpp"
#include "zonemap/zone_map.hpp"
#include "zonemap/zone_snapshot.hpp"

namespace zonemap {

enum class FeatureKind : std::uint8_t { kObstacle, kGround };

struct Feature {
  std::uint32_t id = 0;  // stable across re-extractions of the same object
  FeatureKind kind = FeatureKind::kObstacle;
  ZoneKey zone;
  CellIndex min;  // world cells, inclusive; always inside `zone`
  CellIndex max;
  std::int32_t cells = 0;  // occupied cells it was made of
  double first_seen_s = 0.0;
  double last_seen_s = 0.0;
  QuadNode shape;  // footprint over [min.x, min.x + shape_side) x [min.y, min.y + shape_side)
  int shape_side = 0;
  bool has_shape = false;  // false: the pool was full, the whole box counts as occupied
  bool in_use = false;
  bool stale = false;  // during an update of its zone: not matched yet
};

// One object of the output: per-zone features of the same object merged.
struct ObstacleBox {
  std::uint32_t id = 0;  // the smallest id of its features
  FeatureKind kind = FeatureKind::kObstacle;
  Eigen::Vector3d min = Eigen::Vector3d::Zero();  // world metres
  Eigen::Vector3d max = Eigen::Vector3d::Zero();
  std::int32_t cells = 0;
  std::int32_t parts = 0;  // per-zone features merged into it
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
  std::int64_t features_removed = 0;   // gone from the grid on re-extraction
  std::int64_t features_evicted = 0;   // store full: a less relevant feature made room
  std::int64_t features_dropped = 0;   // store full: the new feature was the least relevant
  std::int64_t objects_too_small = 0;  // fewer than min_cells: noise
  std::int64_t shapes_truncated = 0;   // quadtree pool full: box kept without its shape
  std::int64_t cells_reintegrated = 0;
};

class FeatureMap : public ZoneObserver {
 public:
  // world_z_up: false when the world frame is NED (height = -z).
  FeatureMap(const MapConfig& config, bool world_z_up);

  // Time and vehicle position for first/last-seen stamps and relevance.
  void set_context(double time_s, const Eigen::Vector3d& vehicle_m) {
    time_s_ = time_s;
    vehicle_m_ = vehicle_m;
  }

  // Extracts the features of a zone that holds a grid: its previous features are
  // updated (same object = overlapping box), new ones added, vanished ones removed.
  void extract(const ZoneView& zone);
  // The same from a snapshot (taken with occupied_threshold(), maybe on another thread).
  void extract(const ZoneSnapshot& zone);
  FusedCell occupied_threshold() const { return threshold_; }

  // ZoneObserver: re-integration on allocation, extraction before discard.
  void on_zone_allocated(ZoneView& zone) override;

  // §IV-B as boxes of world cells (inclusive), so that another thread can do the
  // writing: the stored obstacles of zone `key`, their shapes' full quadtree
  // squares (clipped to their boxes) over their height. emit(min, max).
  template <typename Emit>
  void for_each_reintegration_box(const ZoneKey& key, Emit&& emit) const {
    for (const Feature* f = features_.get(); f != features_.get() + capacity_; ++f) {
      if (!f->in_use || f->kind != FeatureKind::kObstacle || !(f->zone == key)) continue;
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
  std::size_t reserved_bytes() const;
  const QuadtreePool& shapes() const { return shapes_; }
  double cell_size_m() const { return cell_size_m_; }

 private:
  bool is_ground_cell(int x, int y, int z) const;
  void compute_terrain(const ZoneSnapshot& zone);
  // out = minimum of the values within radius r (kNoHeight entries left out).
  void window_min(const std::int16_t* values, std::int16_t* out, std::int16_t* tmp, int r) const;
  void upsert(const ZoneKey& zone, FeatureKind kind, const CellIndex& min, const CellIndex& max,
              std::int32_t cells);
  double relevance(const Feature& f) const;
  bool append_footprint(const Feature& f, FootprintOutput* out) const;
  Feature* free_slot(double new_relevance);
  void remove(Feature* f);
  int height_of(int z) const { return z_up_ ? z : dims_[2] - 1 - z; }

  FeatureConfig config_;
  double cell_size_m_;
  bool z_up_;
  std::array<int, 3> dims_;
  FusedCell threshold_;
  FusedCell reintegration_value_;
  int ground_thickness_cells_;
  int ground_window_cells_;

  std::size_t capacity_;
  std::unique_ptr<Feature[]> features_;
  std::size_t in_use_ = 0;
  std::uint32_t next_id_ = 1;
  QuadtreePool shapes_;

  // Scratch for one zone, reserved once.
  std::unique_ptr<std::uint64_t[]> visited_;    // one bit per zone cell
  std::unique_ptr<std::uint32_t[]> component_;  // cells of the object being filled
  std::unique_ptr<std::uint8_t[]> footprint_;   // nx * ny
  std::unique_ptr<std::int16_t[]> lowest_;      // per column: lowest occupied height, or -1
  std::unique_ptr<std::int16_t[]> terrain_;     // per column: terrain height, or -1
  std::unique_ptr<std::int16_t[]> column_tmp_;
  std::unique_ptr<std::int32_t[]> coverage_;  // (nx + 1) * (ny + 1) summed-area table
  std::unique_ptr<std::int32_t[]> observed_;  // the same for columns with any known cell
  std::unique_ptr<std::uint32_t[]> parent_;   // union-find for merging, per feature
  ZoneSnapshot scratch_;                      // extract(ZoneView) goes through it

  double time_s_ = 0.0;
  Eigen::Vector3d vehicle_m_ = Eigen::Vector3d::Zero();
  FeatureCounters counters_;
};

}  // namespace zonemap
