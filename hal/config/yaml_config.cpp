#include "hal/config/yaml_config.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <sstream>

#include "hal/config/yaml_support.hpp"

namespace zonemap::hal {

static bool parse_map_config(const YAML::Node& root, const std::string& path, MapConfig* config,
                             std::string* error) {
  MapConfig c;
  const bool read = read_explained(path, error, [&] {
    auto zone_cells = [&](const YAML::Node& node) {
      if (!node.IsSequence() || node.size() != 3) {
        throw ParseError{where(path, node) + ": map.zone_cells must be [nx, ny, nz]"};
      }
      for (int i = 0; i < 3; ++i) c.zone_cells[static_cast<std::size_t>(i)] = node[i].as<int>();
    };
    using MC = MapConfig;
    const Reader placement = one_of<MC::Placement>(
        path, "map.environment", &c.placement,
        {{"below", MC::Placement::kBelow}, {"centred", MC::Placement::kCentred}});
    const Reader integration = one_of<MC::Integration>(
        path, "sensor.integration", &c.integration,
        {{"reference", MC::Integration::kReference}, {"projective", MC::Integration::kProjective}});
    const Reader weighting =
        one_of<MC::Fusion>(path, "fusion.weighting", &c.fusion,
                           {{"range", MC::Fusion::kRangeWeighted}, {"equal", MC::Fusion::kEqual}});
    auto section = [&](const std::string& name, std::map<std::string, Reader> readers) {
      return [&path, name, readers](const YAML::Node& node) {
        read_section(path, node, name, readers);
      };
    };
    read_section(
        path, root, "",
        {{"map", section("map", {{"cell_size_m", into(&c.cell_size_m)},
                                 {"zone_cells", zone_cells},
                                 {"environment", placement},
                                 {"above_camera_m", into(&c.above_camera_m)}})},
         {"sensor", section("sensor", {{"d_min_m", into(&c.d_min_m)},
                                       {"d_max_m", into(&c.d_max_m)},
                                       {"pixel_step", into(&c.pixel_step)},
                                       {"depth_filter_radius", into(&c.depth_filter_radius_px)},
                                       {"see_through", into(&c.see_through)},
                                       {"see_through_behind", into(&c.see_through_behind)},
                                       {"integration", integration}})},
         {"blur", section("blur", {{"radius", into(&c.blur_radius)},
                                   {"keep_near_m", into(&c.blur_keep_near_m)}})},
         {"fusion", section("fusion", {{"saturation", into(&c.saturation_units)},
                                       {"occupied_threshold", into(&c.occupied_threshold_units)},
                                       {"free_threshold", into(&c.free_threshold_units)},
                                       {"weighting", weighting},
                                       {"full_weight_resolution_cells",
                                        into(&c.full_weight_resolution_cells)},
                                       {"min_weight", into(&c.min_weight)}})},
         {"sky_filter",
          section("sky_filter", {{"enabled", into(&c.sky.enabled)},
                                 {"min_intensity", into(&c.sky.min_intensity)},
                                 {"max_gradient", into(&c.sky.max_gradient)},
                                 {"horizon_margin_deg", into(&c.sky.horizon_margin_deg)},
                                 {"max_gap_px", into(&c.sky.max_gap_px)},
                                 {"min_region_share", into(&c.sky.min_region_share)}})},
         {"pose", section("pose", {{"max_gap_s", into(&c.pose_max_gap_s)},
                                   {"tolerance_s", into(&c.pose_tolerance_s)}})},
         {"timestamps",
          section("timestamps", {{"max_step_s", into(&c.timestamps.max_step_s)},
                                 {"confirm_values", into(&c.timestamps.confirm_values)}})},
         {"camera", section("camera", {{"depth_scale", into(&c.depth_scale_override)}})},
         {"features",
          section("features", {{"occupied_threshold", into(&c.features.occupied_threshold_units)},
                               {"min_cells", into(&c.features.min_cells)},
                               {"capacity", into(&c.features.capacity)},
                               {"quadtree_groups", into(&c.features.quadtree_groups)},
                               {"extract_every_frames", into(&c.features.extract_every_frames)},
                               {"reintegration", into(&c.features.reintegration_units)},
                               {"merge_gap_cells", into(&c.features.merge_gap_cells)},
                               {"split_touching", into(&c.features.split_touching)},
                               {"core_min_cells", into(&c.features.core_min_cells)},
                               {"peak_fraction", into(&c.features.peak_fraction)},
                               {"peak_window_m", into(&c.features.peak_window_m)}})},
         {"pipeline", [](const YAML::Node&) {}},  // the runtime's: runtime/runtime_config
         {"ground",
          section("ground", {{"enabled", into(&c.features.ground_enabled)},
                             {"thickness_m", into(&c.features.ground_thickness_m)},
                             {"window_m", into(&c.features.ground_window_m)},
                             {"min_coverage", into(&c.features.ground_min_coverage)},
                             {"band_percentile", into(&c.features.ground_band_percentile)},
                             {"max_thickness_m", into(&c.features.ground_max_thickness_m)}})}});
  });
  if (!read) return false;
  const std::string invalid = validate(c);
  if (!invalid.empty()) {
    *error = path + ": " + invalid;
    return false;
  }
  *config = c;
  return true;
}

std::string validate_camera(const CameraModel& k) {
  std::ostringstream why;
  if (k.width < 1 || k.height < 1 || k.width > kMaxImageWidth || k.height > kMaxImageHeight) {
    why << "width and height must be in [1, " << kMaxImageWidth << "] x [1, " << kMaxImageHeight
        << "]";
  } else if (!(k.fx > 0.0) || !(k.fy > 0.0) || !std::isfinite(k.fx) || !std::isfinite(k.fy)) {
    why << "fx and fy must be > 0";
  } else if (!std::isfinite(k.cx) || !std::isfinite(k.cy)) {
    why << "cx and cy must be finite";
  } else if (!(k.baseline_m > 0.0) || !(k.match_sigma_px > 0.0)) {
    why << "baseline_m and match_sigma_px must be > 0";
  } else if (!(k.depth_scale > 0.0) || !std::isfinite(k.depth_scale)) {
    why << "depth_scale must be > 0";
  } else if (!k.body_T_camera.matrix().allFinite()) {
    why << "body_T_camera must be finite";
  }
  return why.str();
}

static bool parse_camera_yaml(const YAML::Node& root, const std::string& path, CameraModel* camera,
                              std::string* error) {
  CameraModel k;
  bool seen_width = false, seen_height = false, seen_fx = false, seen_fy = false;
  const bool read = read_explained(path, error, [&] {
    auto body_pose = [&](const YAML::Node& node) {
      std::vector<double> t{0, 0, 0};
      std::vector<double> q{0, 0, 0, 1};
      read_section(path, node, "body_T_camera", {{"t", into(&t)}, {"q", into(&q)}});
      if (t.size() != 3 || q.size() != 4) {
        throw ParseError{where(path, node) + ": body_T_camera needs t: [x, y, z], q: [x, y, z, w]"};
      }
      const Eigen::Quaterniond quat(q[3], q[0], q[1], q[2]);
      if (!std::isfinite(quat.norm()) || std::fabs(quat.norm() - 1.0) > 1e-3) {
        throw ParseError{where(path, node) + ": body_T_camera.q is not a unit quaternion"};
      }
      k.body_T_camera = Eigen::Isometry3d::Identity();
      k.body_T_camera.linear() = quat.normalized().toRotationMatrix();
      k.body_T_camera.translation() = Eigen::Vector3d(t[0], t[1], t[2]);
      k.mount_configured = true;
    };
    auto flag = [](bool* seen, Reader r) {
      return [seen, r](const YAML::Node& n) {
        r(n);
        *seen = true;
      };
    };
    read_section(path, root, "",
                 {{"width", flag(&seen_width, into(&k.width))},
                  {"height", flag(&seen_height, into(&k.height))},
                  {"fx", flag(&seen_fx, into(&k.fx))},
                  {"fy", flag(&seen_fy, into(&k.fy))},
                  {"cx", into(&k.cx)},
                  {"cy", into(&k.cy)},
                  {"baseline_m", into(&k.baseline_m)},
                  {"match_sigma_px", into(&k.match_sigma_px)},
                  {"depth_scale", into(&k.depth_scale)},
                  {"world_z_up", into(&k.world_z_up)},
                  {"body_T_camera", body_pose}});
  });
  if (!read) return false;
  if (!seen_width || !seen_height || !seen_fx || !seen_fy) {
    *error = path + ": width, height, fx and fy are required";
    return false;
  }
  const std::string invalid = validate_camera(k);
  if (!invalid.empty()) {
    *error = path + ": " + invalid;
    return false;
  }
  *camera = k;
  return true;
}

bool load_map_config(const std::string& path, MapConfig* config, std::string* error) {
  YAML::Node root;
  return load_file(path, &root, error) && parse_map_config(root, path, config, error);
}

bool load_map_config_text(const std::string& text, const std::string& name, MapConfig* config,
                          std::string* error) {
  YAML::Node root;
  return load_text(text, name, &root, error) && parse_map_config(root, name, config, error);
}

bool load_camera_yaml(const std::string& path, CameraModel* camera, std::string* error) {
  YAML::Node root;
  return load_file(path, &root, error) && parse_camera_yaml(root, path, camera, error);
}

bool load_camera_yaml_text(const std::string& text, const std::string& name, CameraModel* camera,
                           std::string* error) {
  YAML::Node root;
  return load_text(text, name, &root, error) && parse_camera_yaml(root, name, camera, error);
}

}  // namespace zonemap::hal
