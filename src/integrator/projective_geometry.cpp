#include "integrator/projective_geometry.hpp"

#include <cmath>

namespace zonemap {

Frustum make_frustum(const Eigen::Isometry3d& world_T_camera, const CameraModel& camera,
                     double d_min, double d_max, double side) {
  const Eigen::Matrix3d r = world_T_camera.linear();
  const Eigen::Vector3d t = world_T_camera.translation();
  // Half extent of the cube along the optical axis, and its half diagonal.
  const double half_z = 0.5 * side * r.col(2).cwiseAbs().sum();
  const double margin = 0.5 * side * std::sqrt(3.0);
  const double kl = (0.0 - camera.cx) / camera.fx, kr = (camera.width - 1 - camera.cx) / camera.fx;
  const double kt = (0.0 - camera.cy) / camera.fy, kb = (camera.height - 1 - camera.cy) / camera.fy;
  Frustum f{{{1, 0, -kl}, {-1, 0, kr}, {0, 1, -kt}, {0, -1, kb}, {0, 0, 1}, {0, 0, -1}},
            {0, 0, 0, 0, d_min - half_z, -(d_max + half_z)},
            {}};
  for (int i = 0; i < 6; ++i) {
    const double len = f.normals[i].norm();
    f.normals[i] /= len;
    f.offsets[i] /= len;
    f.offsets[i] -= margin;
    // To the world frame: n_c . R^T (p - t) >= c  <=>  (R n_c) . p >= c + (R n_c) . t
    f.normals[i] = r * f.normals[i];
    f.offsets[i] += f.normals[i].dot(t);
    f.inv_nx[i] = std::fabs(f.normals[i].x()) < 1e-12 ? 0.0 : 1.0 / f.normals[i].x();
  }
  return f;
}

}  // namespace zonemap
