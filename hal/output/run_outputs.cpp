#include "hal/output/run_outputs.hpp"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>

namespace zonemap::hal {
namespace {}  // namespace

double percentile(std::vector<double> values, double fraction) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const double rank = std::ceil(fraction * static_cast<double>(values.size()));
  const std::size_t index =
      static_cast<std::size_t>(std::clamp(rank, 1.0, static_cast<double>(values.size()))) - 1;
  return values[index];
}

bool write_stats_json(const std::string& path, const RunStats& s, std::string* error) {
  std::ofstream out(path);
  if (!out) {
    *error = path + ": cannot create";
    return false;
  }
  char ms[160];
  std::snprintf(ms, sizeof(ms), "{\"p50\": %.3f, \"p99\": %.3f, \"max\": %.3f}", s.frame_ms_p50,
                s.frame_ms_p99, s.frame_ms_max);
  out << "{\n"
      << "  \"frames_in\": " << s.frames_in << ",\n"
      << "  \"frames_mapped\": " << s.frames_mapped << ",\n"
      << "  \"frames_skipped_no_pose\": " << s.frames_skipped_no_pose << ",\n"
      << "  \"frames_rejected\": " << s.frames_rejected << ",\n"
      << "  \"frame_ms\": " << ms << ",\n"
      << "  \"heap_allocations_after_init\": " << s.heap_allocations_after_init << ",\n"
      << "  \"static_memory_bytes\": " << s.static_memory_bytes << ",\n"
      << "  \"zones_allocated\": " << s.zones_allocated << ",\n"
      << "  \"features\": " << s.features << ",\n"
      << "  \"cell_size_m\": " << s.cell_size_m << ",\n"
      << "  \"heap_frees_after_init\": " << s.heap_frees_after_init << ",\n"
      << "  \"zones_discarded\": " << s.zones_discarded << ",\n"
      << "  \"frames_rejected_bad_pose\": " << s.frames_rejected_bad_pose << ",\n"
      << "  \"frames_rejected_bad_image\": " << s.frames_rejected_bad_image << ",\n"
      << "  \"frames_rejected_time_order\": " << s.frames_rejected_time_order << ",\n"
      << "  \"poses_rejected\": " << s.poses_rejected << ",\n"
      << "  \"left_images_rejected\": " << s.left_images_rejected << ",\n"
      << "  \"cells_visited\": " << s.cells_visited << ",\n"
      << "  \"rays_hit\": " << s.rays_hit << ",\n"
      << "  \"rays_free\": " << s.rays_free << ",\n"
      << "  \"pixels_sky\": " << s.pixels_sky << ",\n"
      << "  \"pixels_sky_refused\": " << s.pixels_sky_refused << ",\n"
      << "  \"sky_refused_max_frame\": " << s.sky_refused_max_frame << ",\n"
      << "  \"pixels_missing\": " << s.pixels_missing << ",\n"
      << "  \"pixels_too_near\": " << s.pixels_too_near << ",\n"
      << "  \"frames_ground_below_environment\": " << s.frames_ground_below_environment << ",\n"
      << "  \"occupied_cells_final\": " << s.occupied_cells_final << ",\n"
      << "  \"height_profile_columns_outside\": " << s.height_profile_columns_outside << ",\n"
      << "  \"obstacle_boxes\": " << s.obstacle_boxes << ",\n"
      << "  \"ground_boxes\": " << s.ground_boxes << ",\n"
      << "  \"feature_counters\": {\"extractions\": " << s.feature_counters.extractions
      << ", \"added\": " << s.feature_counters.features_added
      << ", \"updated\": " << s.feature_counters.features_updated
      << ", \"removed\": " << s.feature_counters.features_removed
      << ", \"removed_seen_free\": " << s.feature_counters.removed_seen_free
      << ", \"removed_unseen\": " << s.feature_counters.removed_unseen
      << ", \"removed_joined\": " << s.feature_counters.removed_joined
      << ", \"removed_other\": " << s.feature_counters.removed_other
      << ", \"evicted\": " << s.feature_counters.features_evicted
      << ", \"dropped\": " << s.feature_counters.features_dropped
      << ", \"objects_too_small\": " << s.feature_counters.objects_too_small
      << ", \"objects_in_ground_band\": " << s.feature_counters.objects_in_ground_band
      << ", \"objects_split\": " << s.feature_counters.objects_split
      << ", \"shapes_truncated\": " << s.feature_counters.shapes_truncated
      << ", \"cells_reintegrated\": " << s.feature_counters.cells_reintegrated
      << ", \"priors_added\": " << s.feature_counters.priors_added
      << ", \"priors_confirmed\": " << s.feature_counters.priors_confirmed
      << ", \"priors_removed\": " << s.feature_counters.priors_removed
      << ", \"priors_dropped\": " << s.feature_counters.priors_dropped
      << ", \"shared_updates\": " << s.feature_counters.shared_updates
      << ", \"shared_added\": " << s.feature_counters.shared_added
      << ", \"shared_kept\": " << s.feature_counters.shared_kept
      << ", \"shared_removed\": " << s.feature_counters.shared_removed
      << ", \"shared_dropped\": " << s.feature_counters.shared_dropped << "},\n"
      << "  \"extract_ms\": {\"p50\": " << s.extract_ms_p50 << ", \"max\": " << s.extract_ms_max
      << "},\n"
      << "  \"pipeline\": " << (s.pipeline ? "true" : "false") << ",\n"
      << "  \"drops\": {\"mapper_behind\": " << s.dropped_mapper_behind
      << ", \"pool_full\": " << s.dropped_pool_full
      << ", \"outputs_skipped\": " << s.outputs_skipped << "},\n"
      << "  \"pose_waits\": " << s.pose_waits << ",\n"
      << "  \"outputs_published\": " << s.outputs_published << ",\n"
      << "  \"deadline_misses\": " << s.deadline_misses << ",\n"
      << "  \"end_to_end_ms\": {\"p50\": " << s.end_to_end_ms_p50
      << ", \"p99\": " << s.end_to_end_ms_p99 << ", \"p99.9\": " << s.end_to_end_ms_p999
      << ", \"max\": " << s.end_to_end_ms_max << "},\n"
      << "  \"queue_ms_p99\": " << s.queue_ms_p99 << ",\n"
      << "  \"rss_bytes\": {\"after_start\": " << s.rss_after_start
      << ", \"at_end\": " << s.rss_at_end << "},\n"
      << "  \"memory_bytes\": {\"zone_pool\": " << s.zone_pool_bytes
      << ", \"local_grid\": " << s.local_grid_bytes << ", \"feature_map\": " << s.feature_map_bytes
      << ", \"depth_table\": " << s.depth_table_bytes << ", \"pipeline\": " << s.pipeline_bytes
      << "}";
  // Counters by name, as one object each (only when there are any).
  auto named = [&out](const char* key, const std::vector<std::pair<std::string, std::int64_t>>& v) {
    if (v.empty()) return;
    out << ",\n  \"" << key << "\": {";
    for (std::size_t i = 0; i < v.size(); ++i) {
      out << (i == 0 ? "" : ", ") << "\"" << v[i].first << "\": " << v[i].second;
    }
    out << "}";
  };
  named("rejections", s.rejections);
  named("links", s.links);  // the daemon's vehicle-link counters
  named("recording", s.recording);
  named("stereo", s.stereo);
  out << "\n}\n";
  out.close();
  if (!out) {
    *error = path + ": write failed";
    return false;
  }
  return true;
}

// Written whole or not at all: into PATH.tmp, flushed to the disk (fsync), then
// renamed over PATH, so a power cut mid-write leaves the last good map (a saved
// map is the next flight's prior).
bool write_boxes_csv(const std::string& path, const ObstacleBox* boxes, std::size_t count,
                     std::string* error) {
  const std::string temporary = path + ".tmp";
  std::FILE* f = std::fopen(temporary.c_str(), "w");
  if (f == nullptr) {
    *error = path + ": cannot create";
    return false;
  }
  std::fprintf(f, "id,kind,xmin,ymin,zmin,xmax,ymax,zmax,cells,last_seen_s,prior\n");
  for (std::size_t i = 0; i < count; ++i) {
    const ObstacleBox& b = boxes[i];
    std::fprintf(f, "%u,%s,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%d,%.3f,%d\n", b.id,
                 b.kind == FeatureKind::kObstacle ? "obstacle" : "ground", b.min.x(), b.min.y(),
                 b.min.z(), b.max.x(), b.max.y(), b.max.z(), b.cells, b.last_seen_s,
                 b.prior ? 1 : 0);
  }
  const bool written = std::fflush(f) == 0 && ::fsync(::fileno(f)) == 0;
  if (std::fclose(f) != 0 || !written || std::rename(temporary.c_str(), path.c_str()) != 0) {
    std::remove(temporary.c_str());
    *error = path + ": write failed";
    return false;
  }
  return true;
}

std::int64_t write_occupied_ply(const std::string& path, Mapper& mapper, std::string* error) {
  struct Point {
    float x, y, z;
    int value;
  };
  std::vector<Point> points;
  mapper.for_each_occupied_cell([&](const Eigen::Vector3d& c, FusedCell v) {
    points.push_back(
        {static_cast<float>(c.x()), static_cast<float>(c.y()), static_cast<float>(c.z()), v});
  });
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) {
    *error = path + ": cannot create";
    return -1;
  }
  std::fprintf(f,
               "ply\nformat ascii 1.0\ncomment zonemap occupied cells (world frame, metres); "
               "value = fused cell, %d per sensor-model unit\nelement vertex %zu\n"
               "property float x\nproperty float y\nproperty float z\nproperty int value\n"
               "end_header\n",
               kCellScale, points.size());
  for (const Point& p : points) std::fprintf(f, "%.4f %.4f %.4f %d\n", p.x, p.y, p.z, p.value);
  if (std::fclose(f) != 0) {
    *error = path + ": write failed";
    return -1;
  }
  return static_cast<std::int64_t>(points.size());
}

}  // namespace zonemap::hal
