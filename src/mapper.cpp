#include "zonemap/mapper.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>

namespace zonemap {

bool is_valid_pose(const Eigen::Isometry3d& pose) {
  if (!pose.matrix().allFinite()) return false;
  const Eigen::Matrix3d r = pose.linear();
  const double orthonormal_error = (r.transpose() * r - Eigen::Matrix3d::Identity()).norm();
  return orthonormal_error < 1e-3 && r.determinant() > 0.0;
}

Mapper::Mapper(const MapConfig& config, const CameraModel& camera)
    : config_(config),
      camera_(camera),
      local_(config.zone_cells),
      zones_(config),
      depths_(config.integration == MapConfig::Integration::kProjective ? camera.width : 1,
              config.integration == MapConfig::Integration::kProjective ? camera.height : 1),
      projective_(config, camera),
      occupied_threshold_(
          static_cast<FusedCell>(to_fixed(static_cast<float>(config.occupied_threshold_units)))),
      free_threshold_(
          static_cast<FusedCell>(to_fixed(static_cast<float>(config.free_threshold_units)))) {}

CellIndex Mapper::cell_of(const Eigen::Vector3d& point) const {
  const Eigen::Vector3d c = point / config_.cell_size_m;
  return CellIndex{static_cast<std::int32_t>(std::floor(c.x())),
                   static_cast<std::int32_t>(std::floor(c.y())),
                   static_cast<std::int32_t>(std::floor(c.z()))};
}

Eigen::Vector3d Mapper::cell_center(const CellIndex& cell) const {
  return Eigen::Vector3d(cell.x + 0.5, cell.y + 0.5, cell.z + 0.5) * config_.cell_size_m;
}

bool Mapper::is_sky(const std::uint8_t* left, int u, int v) const {
  const int w = camera_.width;
  const int h = camera_.height;
  const int center = left[static_cast<std::size_t>(v) * w + u];
  if (center < config_.sky.min_intensity) return false;
  // Low texture: every 8-neighbour within max_gradient of the centre.
  for (int dv = -1; dv <= 1; ++dv) {
    const int y = std::clamp(v + dv, 0, h - 1);
    for (int du = -1; du <= 1; ++du) {
      const int x = std::clamp(u + du, 0, w - 1);
      if (std::abs(left[static_cast<std::size_t>(y) * w + x] - center) > config_.sky.max_gradient) {
        return false;
      }
    }
  }
  return true;
}

FrameReport Mapper::integrate(const DepthFrameView& frame,
                              const Eigen::Isometry3d& world_T_camera) {
  FrameReport report;
  if (frame.depth == nullptr || frame.width != camera_.width || frame.height != camera_.height) {
    report.status = FrameStatus::kBadFrame;
    return report;
  }
  if (!is_valid_pose(world_T_camera)) {
    report.status = FrameStatus::kBadPose;
    return report;
  }

  // The environment cube follows the camera, centred on the camera's cell.
  const CellIndex camera_cell = cell_of(world_T_camera.translation());
  const CellIndex origin = zones_.environment_origin(camera_cell);
  report.zones_allocated = zones_.move_environment(origin);
  local_.reset(origin);

  // Ray geometry in grid units relative to the local grid's minimum corner.
  // Subtract in double first so that large world coordinates keep their precision.
  const double inv_cell = 1.0 / config_.cell_size_m;
  const Eigen::Vector3d origin_m =
      Eigen::Vector3d(origin.x, origin.y, origin.z) * config_.cell_size_m;
  const Eigen::Vector3f start =
      ((world_T_camera.translation() - origin_m) * inv_cell).cast<float>();
  const Eigen::Matrix3f rotation_cells = (world_T_camera.linear() * inv_cell).cast<float>();

  const float d_min = static_cast<float>(config_.d_min_m);
  const float d_max = static_cast<float>(config_.d_max_m);
  const float depth_to_m = static_cast<float>(1.0 / camera_.depth_scale);
  const float resolution_factor =
      static_cast<float>(camera_.match_sigma_px / (camera_.baseline_m * camera_.fx));
  const float inv_fx = static_cast<float>(1.0 / camera_.fx);
  const float inv_fy = static_cast<float>(1.0 / camera_.fy);
  const float cx = static_cast<float>(camera_.cx);
  const float cy = static_cast<float>(camera_.cy);
  const bool sky_filter = config_.sky.enabled && frame.left != nullptr;
  const int step = config_.pixel_step;

  if (config_.integration == MapConfig::Integration::kProjective) {
    // Level 0 of the range table: each pixel's depth code, kFar for free-only
    // rays, or missing. pixel_step is a reference-path option: every pixel is used.
    std::uint16_t* base = depths_.base();
    for (int v = 0; v < frame.height; ++v) {
      const std::uint16_t* depth_row = frame.depth + static_cast<std::size_t>(v) * frame.width;
      std::uint16_t* out = base + static_cast<std::size_t>(v) * frame.width;
      for (int u = 0; u < frame.width; ++u) {
        const std::uint16_t raw = depth_row[u];
        std::uint16_t value = DepthRangeTable::kMissing;
        if (raw == 0) {
          if (sky_filter && is_sky(frame.left, u, v)) {
            ++report.pixels_sky;
            ++report.rays_free;
            value = DepthRangeTable::kFar;
          } else {
            ++report.pixels_missing;
          }
        } else {
          const float d = static_cast<float>(raw) * depth_to_m;
          if (d < d_min) {
            ++report.pixels_too_near;
          } else if (d > d_max) {
            ++report.rays_free;
            value = DepthRangeTable::kFar;
          } else {
            ++report.rays_hit;
            value = std::min(raw, DepthRangeTable::kMaxDepthCode);
          }
        }
        out[u] = value;
      }
    }
    depths_.build();
    const ProjectiveStats drawn = projective_.draw(depths_, world_T_camera, local_);
    report.cells_visited = drawn.cells_evaluated;
    report.cells_block_free = drawn.cells_block_free;
    report.cells_box_free = drawn.cells_box_free;
    report.cells_hidden = drawn.cells_hidden;
    report.cells_exact = drawn.cells_exact;
    report.rays_exact = drawn.rays_exact;
    local_.finish(config_.blur_radius);
    zones_.fuse(local_);
    return report;
  }

  for (int v = 0; v < frame.height; v += step) {
    const std::uint16_t* depth_row = frame.depth + static_cast<std::size_t>(v) * frame.width;
    for (int u = 0; u < frame.width; u += step) {
      RayProfile ray;
      ray.delta_begin = d_min;
      const std::uint16_t raw = depth_row[u];
      if (raw == 0) {
        if (sky_filter && is_sky(frame.left, u, v)) {
          ++report.pixels_sky;
          ray.free_only = true;
        } else {
          ++report.pixels_missing;
          continue;
        }
      } else {
        const float d = static_cast<float>(raw) * depth_to_m;
        if (d < d_min) {
          ++report.pixels_too_near;
          continue;
        }
        ray.free_only = d > d_max;
        ray.depth = d;
        ray.range_resolution = std::max(d * d * resolution_factor, 1e-6f);  // eq. (1)
      }
      if (ray.free_only) {
        ray.delta_end = d_max;
        ++report.rays_free;
      } else {
        ray.delta_end = std::min(ray.depth + ray.range_resolution, d_max);
        ++report.rays_hit;
      }
      // Pinhole ray: the point at depth-plane distance δ is δ * (x, y, 1).
      const Eigen::Vector3f pixel_ray((static_cast<float>(u) - cx) * inv_fx,
                                      (static_cast<float>(v) - cy) * inv_fy, 1.0f);
      report.cells_visited += local_.draw_ray(start, rotation_cells * pixel_ray, ray);
    }
  }

  local_.finish(config_.blur_radius);
  zones_.fuse(local_);
  return report;
}

}  // namespace zonemap
