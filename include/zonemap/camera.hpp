// Pinhole stereo camera model (paper §II): intrinsics plus the stereo
// parameters of eq. (1).
#pragma once

#include <Eigen/Geometry>

namespace zonemap {

struct CameraModel {
  int width = 0;
  int height = 0;
  double fx = 0.0;
  double fy = 0.0;
  double cx = 0.0;
  double cy = 0.0;
  double baseline_m = 0.0;      // b in eq. (1)
  double match_sigma_px = 0.0;  // sigma in eq. (1)
  double depth_scale = 1000.0;  // PNG value per metre
  bool world_z_up = true;       // false: world is NED (z down)
  Eigen::Isometry3d body_T_camera = Eigen::Isometry3d::Identity();
};

// Eq. (1): range resolution Δd = d² σ / (b f). Uses fx as the focal length.
inline double range_resolution(const CameraModel& camera, double depth_m) {
  return depth_m * depth_m * camera.match_sigma_px / (camera.baseline_m * camera.fx);
}

}  // namespace zonemap
