#include "zonemap/common/camera.hpp"

#include <cstdio>

namespace zonemap {

std::string describe_mount(const CameraModel& camera) {
  const Eigen::Quaterniond q(camera.body_T_camera.linear());
  const Eigen::Vector3d t = camera.body_T_camera.translation();
  char text[256];
  std::snprintf(
      text, sizeof text,
      "camera mount body_T_camera t [%.3f, %.3f, %.3f] q [%.4f, %.4f, %.4f, %.4f] (%s)", t.x(),
      t.y(), t.z(), q.x(), q.y(), q.z(), q.w(),
      camera.mount_configured ? "configured" : "not configured: camera looking along the nose");
  return text;
}

}  // namespace zonemap
