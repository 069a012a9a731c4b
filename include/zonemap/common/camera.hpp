// Pinhole stereo camera model (paper §II): intrinsics plus the stereo
// parameters of eq. (1).
#pragma once

#include <string>

#include <Eigen/Geometry>

namespace zonemap {

// The mount assumed when none is configured: the camera looks along the vehicle's
// nose, image right = body right, image down = body down (body FRD: x forward,
// y right, z down; optical: x right, y down, z forward). Never the identity, which
// would make the image's x axis (right) the nose and turn every body-frame output
// by 90 degrees.
inline Eigen::Isometry3d camera_looking_forward() {
  Eigen::Matrix3d body_R_camera;
  body_R_camera << 0, 0, 1,  // body x (forward) = optical z
      1, 0, 0,               // body y (right)   = optical x
      0, 1, 0;               // body z (down)    = optical y
  Eigen::Isometry3d mount = Eigen::Isometry3d::Identity();
  mount.linear() = body_R_camera;
  return mount;
}

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
  // Pose of the camera in the vehicle body frame (FRD): for INS (body) pose sources
  // and for every body-frame output (sectors, 3-D obstacles).
  Eigen::Isometry3d body_T_camera = camera_looking_forward();
  bool mount_configured = false;  // false: camera_looking_forward(), said at start-up
};

// One line for start-up logs: the mount and where it came from.
std::string describe_mount(const CameraModel& camera);

// Eq. (1): range resolution Δd = d² σ / (b f). Uses fx as the focal length.
inline double range_resolution(const CameraModel& camera, double depth_m) {
  return depth_m * depth_m * camera.match_sigma_px / (camera.baseline_m * camera.fx);
}

}  // namespace zonemap
