// Files a replay run writes (FORMATS.md §3, §4) and the height-profile picture
// (paper fig. 11). Host side: these run after the mapping loop or, for the height
// profile, fold zones into storage reserved before the loop.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "hal/output/frame_counters.hpp"
#include "zonemap/features/feature_map.hpp"
#include "zonemap/mapping/mapper.hpp"
#include "zonemap/zones/zone_map.hpp"

namespace zonemap::hal {

// stats.json: the shared counters (FrameCounters) plus the run's own figures.
struct RunStats : FrameCounters {
  double frame_ms_p50 = 0.0;
  double frame_ms_p99 = 0.0;
  double frame_ms_max = 0.0;
  std::uint64_t static_memory_bytes = 0;
  std::int64_t zones_allocated = 0;
  std::int64_t zones_discarded = 0;
  std::int64_t features = 0;
  // Extensions (FORMATS.md allows new keys).
  double cell_size_m = 0.0;
  std::int64_t frames_rejected_bad_pose = 0;
  std::int64_t frames_rejected_bad_image = 0;
  std::int64_t frames_rejected_time_order = 0;
  std::int64_t poses_rejected = 0;
  std::int64_t left_images_rejected = 0;
  std::int64_t cells_visited = 0;  // cells the integration evaluated, summed over frames
  std::int64_t rays_hit = 0;
  std::int64_t rays_free = 0;
  std::int64_t pixels_sky = 0;
  std::int64_t pixels_sky_refused = 0;     // bright, flat, no depth, but not where sky can be
  std::int64_t sky_refused_max_frame = 0;  // the most refused in one frame
  std::int64_t pixels_missing = 0;
  std::int64_t pixels_too_near = 0;
  std::int64_t occupied_cells_final = 0;
  std::int64_t height_profile_columns_outside = 0;
  std::uint64_t local_grid_bytes = 0;
  std::uint64_t zone_pool_bytes = 0;
  std::uint64_t feature_map_bytes = 0;
  std::uint64_t depth_table_bytes = 0;  // projective path
  std::uint64_t pipeline_bytes = 0;     // frame pool and output buffers (--pipeline)
  std::int64_t obstacle_boxes = 0;      // merged, as in boxes.csv
  std::int64_t ground_boxes = 0;
  FeatureCounters feature_counters;
  double extract_ms_p50 = 0.0;
  double extract_ms_max = 0.0;
  // The threaded pipeline (zonemap-replay --pipeline).
  bool pipeline = false;
  double end_to_end_ms_p50 = 0.0, end_to_end_ms_p99 = 0.0, end_to_end_ms_p999 = 0.0;
  double end_to_end_ms_max = 0.0;
  double queue_ms_p99 = 0.0;
  long rss_after_start = 0, rss_at_end = 0;
  std::vector<std::pair<std::string, std::int64_t>> links;  // vehicle-link counters (daemon)
  // Every refused input item by kind, and the clock steps adopted (replay).
  std::vector<std::pair<std::string, std::int64_t>> rejections;
  // The MCAP recording (OUT/run.mcap): messages, bytes, drops, reserved memory.
  std::vector<std::pair<std::string, std::int64_t>> recording;
  // The host stereo step of an ASL recording (zonemap-replay on mav0/): pairs,
  // valid share (per mille), time per pair (µs).
  std::vector<std::pair<std::string, std::int64_t>> stereo;
};

// boxes.csv (FORMATS.md §2): id,kind,xmin,ymin,zmin,xmax,ymax,zmax,cells,last_seen_s
bool write_boxes_csv(const std::string& path, const ObstacleBox* boxes, std::size_t count,
                     std::string* error);

// Percentile by nearest rank over an unsorted sample (copied and sorted).
double percentile(std::vector<double> values, double fraction);

bool write_stats_json(const std::string& path, const RunStats& stats, std::string* error);

// Occupied cells (value above the occupied threshold) of the zones holding a grid.
// Returns the number of points written, or -1 on error.
std::int64_t write_occupied_ply(const std::string& path, Mapper& mapper, std::string* error);

}  // namespace zonemap::hal
