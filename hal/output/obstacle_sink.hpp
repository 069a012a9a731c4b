// Outputs to the vehicle behind one small interface, called on the pipeline's
// output thread with buffers the mapping thread filled (no allocation, no
// blocking: a sink that cannot send counts it and returns).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "hal/output/frame_counters.hpp"
#include "zonemap/features/feature_map.hpp"
#include "zonemap/outputs/obstacle_distance.hpp"

namespace zonemap::hal {

struct ObstacleUpdate {
  double time_s = 0.0;  // the newest mapped depth frame's time
  Eigen::Isometry3d world_T_body = Eigen::Isometry3d::Identity();  // the vehicle
  bool world_z_up = true;
  const ObstacleBox* boxes = nullptr;  // obstacles first, then ground
  std::size_t count = 0;
  const FootprintRect* rects = nullptr;  // per box: rect_offsets / rect_counts
  const std::uint32_t* rect_offsets = nullptr;
  const std::uint32_t* rect_counts = nullptr;
  // Sectors around the vehicle the live grid has seen (observed_sectors), filled by
  // the mapping thread; a sector never seen is sent as unknown, not as free.
  SectorMask sectors_observed{};
  FootprintView footprints() const { return {rects, rect_offsets, rect_counts}; }
};

// Storage for an update built from the feature map (its merged boxes with their
// footprints), reserved once; fill() does not allocate.
struct MergedUpdate {
  std::vector<ObstacleBox> boxes;
  std::vector<FootprintRect> rects;
  std::vector<std::uint32_t> offsets, counts;
  void reserve(std::size_t max_boxes, std::size_t max_rects) {
    boxes.resize(max_boxes);
    rects.resize(max_rects);
    offsets.resize(max_boxes);
    counts.resize(max_boxes);
  }
  ObstacleUpdate fill(FeatureMap& features, bool include_ground, double time_s,
                      const Eigen::Isometry3d& world_T_body, bool world_z_up) {
    FootprintOutput shapes{rects.data(), rects.size(), offsets.data(), counts.data()};
    ObstacleUpdate update;
    update.time_s = time_s;
    update.world_T_body = world_T_body;
    update.world_z_up = world_z_up;
    update.count = features.merged(boxes.data(), boxes.size(), include_ground, &shapes);
    update.boxes = boxes.data();
    update.rects = rects.data();
    update.rect_offsets = offsets.data();
    update.rect_counts = counts.data();
    return update;
  }
};

// Every counter of the run, for the periodic health message and stats.json.
// The health message: the shared counters (FrameCounters) so far, plus the
// vehicle's own figures.
struct HealthSnapshot : FrameCounters {
  double time_s = 0.0, uptime_s = 0.0;
  std::int64_t poses_in = 0, poses_rejected = 0;
  double mapping_ms_p50 = 0, mapping_ms_p99 = 0;
  double end_to_end_ms_p50 = 0, end_to_end_ms_p99 = 0, end_to_end_ms_p999 = 0;
  std::int64_t static_memory_bytes = 0, rss_bytes = 0;
  std::int32_t zones_allocated = 0, features = 0;
  // Everything else by name (fixed names, set once).
  static constexpr int kMaxNamed = 96;
  const char* names[kMaxNamed] = {};
  std::int64_t values[kMaxNamed] = {};
  int named = 0;
  void add(const char* name, std::int64_t value) {
    if (named < kMaxNamed) {
      names[named] = name;
      values[named++] = value;
    }
  }
};

class ObstacleSink {
 public:
  virtual ~ObstacleSink() = default;
  virtual const char* name() const = 0;
  virtual void publish(const ObstacleUpdate& update, double now_s) = 0;
  virtual void publish_health(const HealthSnapshot& /*health*/, double /*now_s*/) {}
  // Called by the output thread at least every kTickPeriodS whether or not an
  // update came: for messages with a rate of their own (MAVLink's heartbeat and
  // its re-sent sectors).
  virtual void tick(double /*now_s*/) {}
  static constexpr double kTickPeriodS = 0.02;
  // Adds this sink's counters to a snapshot (for health and stats.json).
  virtual void report(HealthSnapshot* /*health*/) const {}
};

}  // namespace zonemap::hal
