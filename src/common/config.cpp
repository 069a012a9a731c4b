#include "zonemap/common/config.hpp"

#include "zonemap/common/cell.hpp"

#include <cmath>
#include <sstream>

namespace zonemap {

namespace {

// Each checks its keys in order and writes the first wrong one (a table of
// keys: one condition and one message a key).
bool map_and_sensor_wrong(const MapConfig& c, std::ostringstream& why) {
  if (!(c.cell_size_m > 0.0) || !std::isfinite(c.cell_size_m)) {
    why << "map.cell_size_m must be > 0 (got " << c.cell_size_m << ")";
  } else if (c.zone_cells[0] < 2 || c.zone_cells[1] < 2 || c.zone_cells[2] < 2 ||
             c.zone_cells[0] > kMaxZoneEdgeCells || c.zone_cells[1] > kMaxZoneEdgeCells ||
             c.zone_cells[2] > kMaxZoneEdgeCells) {
    why << "map.zone_cells must each be in [2, " << kMaxZoneEdgeCells << "]";
  } else if (zone_cell_count(c) > kMaxZoneCells) {
    why << "map.zone_cells holds " << zone_cell_count(c) << " cells, more than the build maximum "
        << kMaxZoneCells;
  } else if (!(c.d_min_m > 0.0) || !(c.d_max_m > c.d_min_m) || !std::isfinite(c.d_max_m)) {
    why << "sensor.d_min_m must be > 0 and sensor.d_max_m > d_min_m (got " << c.d_min_m << ", "
        << c.d_max_m << ")";
  } else if (c.pixel_step < 1 || c.pixel_step > 64) {
    why << "sensor.pixel_step must be in [1, 64]";
  } else if (c.depth_filter_radius_px < 0 || c.depth_filter_radius_px > kMaxDepthFilterRadius) {
    why << "sensor.depth_filter_radius must be in [0, " << kMaxDepthFilterRadius << "] pixels";
  } else if (!(c.see_through >= 0.0) || c.see_through > 1.0) {
    why << "sensor.see_through must be in [0, 1] (0: off)";
  } else if (c.see_through_behind > c.see_through ||
             !(c.see_through_behind >= 0.0 || c.see_through_behind == -1.0)) {
    why << "sensor.see_through_behind must be in [0, see_through] (or -1: see_through)";
  } else if (c.blur_radius < 0 || c.blur_radius > 2) {
    why << "blur.radius must be 0, 1 or 2";
  } else if (!(c.blur_keep_near_m >= 0.0) ||
             c.blur_keep_near_m > MapConfig::kMaxKeepNearCells * c.cell_size_m) {
    why << "blur.keep_near_m must be in [0, " << MapConfig::kMaxKeepNearCells << " cells] (0: off)";
  } else {
    return false;
  }
  return true;
}

// Fusion, the sky filter, time and poses.
bool fusion_and_inputs_wrong(const MapConfig& c, std::ostringstream& why) {
  if (!(c.full_weight_resolution_cells >= 0.1) || c.full_weight_resolution_cells > 100.0) {
    why << "fusion.full_weight_resolution_cells must be in [0.1, 100]";
  } else if (!(c.min_weight >= 0.05) || c.min_weight > 1.0) {
    why << "fusion.min_weight must be in [0.05, 1]";
  } else if (!(c.saturation_units >= 1.0) || c.saturation_units > kMaxFusedUnits) {
    why << "fusion.saturation must be in [1, " << kMaxFusedUnits << "]";
  } else if (!(c.occupied_threshold_units > 0.0) ||
             c.occupied_threshold_units >= c.saturation_units) {
    why << "fusion.occupied_threshold must be in (0, saturation)";
  } else if (!(c.free_threshold_units < 0.0) || -c.free_threshold_units >= c.saturation_units) {
    why << "fusion.free_threshold must be in (-saturation, 0)";
  } else if (c.sky.min_intensity < 0 || c.sky.min_intensity > 255 || c.sky.max_gradient < 0 ||
             c.sky.max_gradient > 255) {
    why << "sky_filter.min_intensity and max_gradient must be in [0, 255]";
  } else if (!(c.sky.horizon_margin_deg >= 0.0 && c.sky.horizon_margin_deg <= 30.0) ||
             c.sky.max_gap_px < 0 || c.sky.max_gap_px > 64 ||
             !(c.sky.min_region_share >= 0.0 && c.sky.min_region_share <= 1.0)) {
    why << "sky_filter.horizon_margin_deg must be in [0, 30], max_gap_px in [0, 64] and "
           "min_region_share in [0, 1]";
  } else if (!(c.above_camera_m >= 0.0) || !std::isfinite(c.above_camera_m)) {
    why << "map.above_camera_m must be >= 0";
  } else if (!(c.timestamps.max_step_s > 0.0) || c.timestamps.confirm_values < 2 ||
             c.timestamps.confirm_values > 100) {
    why << "timestamps.max_step_s must be > 0 and timestamps.confirm_values in [2, 100]";
  } else if (!(c.pose_max_gap_s > 0.0) || !(c.pose_tolerance_s >= 0.0)) {
    why << "pose.max_gap_s must be > 0 and pose.tolerance_s >= 0";
  } else if (c.depth_scale_override < 0.0 || !std::isfinite(c.depth_scale_override)) {
    why << "camera.depth_scale must be > 0";
  } else {
    return false;
  }
  return true;
}

// The feature map and the ground.
bool features_wrong(const MapConfig& c, std::ostringstream& why) {
  if (!(c.features.occupied_threshold_units > 0.0) ||
      c.features.occupied_threshold_units >= c.saturation_units) {
    why << "features.occupied_threshold must be in (0, saturation)";
  } else if (c.features.min_cells < 1 || c.features.capacity < 1 ||
             c.features.capacity > 1'000'000 || c.features.quadtree_groups < 1 ||
             c.features.quadtree_groups > 16'000'000) {
    why << "features.min_cells >= 1, features.capacity in [1, 1000000], "
           "features.quadtree_groups in [1, 16000000]";
  } else if (c.features.extract_every_frames < 1) {
    why << "features.extract_every_frames must be >= 1";
  } else if (!(c.features.reintegration_units > c.features.occupied_threshold_units) ||
             c.features.reintegration_units > c.saturation_units) {
    why << "features.reintegration must be in (features.occupied_threshold, saturation]";
  } else if (!(c.features.peak_fraction >= 0.0) || !(c.features.peak_fraction < 1.0) ||
             (c.features.peak_fraction > 0.0 &&
              (!(c.features.peak_window_m >= 0.0) ||
               c.features.peak_window_m > kMaxPeakWindowCells * c.cell_size_m))) {
    why << "features.peak_fraction must be in [0, 1), features.peak_window_m in [0, "
        << kMaxPeakWindowCells << " cells]";
  } else if (c.features.merge_gap_cells < 0 || c.features.merge_gap_cells > 8) {
    why << "features.merge_gap_cells must be in [0, 8]";
  } else if (!(c.features.ground_thickness_m >= 0.0) || !(c.features.ground_window_m >= 0.0) ||
             !(c.features.ground_min_coverage >= 0.0) || c.features.ground_min_coverage > 1.0) {
    why << "ground.thickness_m and ground.window_m must be >= 0, ground.min_coverage in [0, 1]";
  } else if (!(c.features.ground_band_percentile >= 0.0) ||
             !(c.features.ground_band_percentile < 1.0) ||
             (c.features.ground_band_percentile > 0.0 &&
              (!(c.features.ground_max_thickness_m >= c.features.ground_thickness_m) ||
               c.features.ground_max_thickness_m > kMaxGroundBandCells * c.cell_size_m))) {
    why << "ground.band_percentile must be in [0, 1), ground.max_thickness_m in [thickness_m, "
        << kMaxGroundBandCells << " cells]";
  } else {
    return false;
  }
  return true;
}

}  // namespace

std::string validate(const MapConfig& c) {
  std::ostringstream why;
  // The first wrong key, section by section.
  if (!map_and_sensor_wrong(c, why) && !fusion_and_inputs_wrong(c, why)) features_wrong(c, why);
  return why.str();
}

}  // namespace zonemap
