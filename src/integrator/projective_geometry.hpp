// The projective path's camera geometry: the frustum as half-spaces (which
// cells of a row it holds) and a cube's image box (the pixels whose rays can
// cross it). Internal to src/: not a public header.
#pragma once

#include <Eigen/Geometry>

#include "integrator/projective_lanes.hpp"
#include "zonemap/common/camera.hpp"

namespace zonemap {

// The camera's frustum (image borders, d_min, d_max) as six world-frame
// half-spaces n . p >= c, widened so that a cube of side `side` whose centre is
// outside cannot reach into it.
struct Frustum {
  Eigen::Vector3d normals[6];
  double offsets[6];
  double inv_nx[6];  // 1 / n.x (0 for planes parallel to x), set by make_frustum

  // The indices i of the centres (base_x + i * step, wy, wz), 0 <= i < count,
  // inside every half-space: [*lo, *hi]; false when there are none. (Once per
  // row of cells: products with reciprocals, no divisions.)
  bool row(double wy, double wz, double base_x, double inv_step, int count, int* lo,
           int* hi) const {
    double x_lo = 0.0, x_hi = count - 1;
    for (int i = 0; i < 6 && x_lo <= x_hi; ++i) {
      const Eigen::Vector3d& n = normals[i];
      const double rest = n.y() * wy + n.z() * wz - offsets[i];  // n.x * X + rest >= 0
      if (inv_nx[i] == 0.0) {
        if (rest < 0.0) x_hi = -1.0;
        continue;
      }
      const double bound = (-rest * inv_nx[i] - base_x) * inv_step;  // in indices
      if (n.x() > 0.0) {
        x_lo = std::max(x_lo, std::ceil(bound));
      } else {
        x_hi = std::min(x_hi, std::floor(bound));
      }
    }
    if (x_lo > x_hi) return false;
    *lo = static_cast<int>(x_lo);
    *hi = static_cast<int>(x_hi);
    return true;
  }
};

Frustum make_frustum(const Eigen::Isometry3d& world_T_camera, const CameraModel& camera,
                     double d_min, double d_max, double side);

// The pixel rectangle a cube covers: the image box of its eight corners, given
// four at a time as (x, y, z) offsets from its centre (camera frame), clamped
// into the image; x0 > x1 or y0 > y1 when no pixel sees it. All four bounds in
// one vector: the horizontal minima and maxima by two transposing steps, the
// rounding by truncation and a correction (|values| < 2^31 after clamping).
struct PixelRect {
  int x0, y0, x1, y1;
};

struct Projection {
  Lanes corner_x[2], corner_y[2], corner_z[2];
  Lanes scale;   // {fx, fx, fy, fy}
  Lanes offset;  // {-cx, cx, -cy, cy}
  Lanes limit;   // {0, w - 1, 0, h - 1}
};

inline Projection projection_for(const CameraModel& camera) {
  Projection p{};
  const auto fx = static_cast<float>(camera.fx), fy = static_cast<float>(camera.fy);
  const auto cx = static_cast<float>(camera.cx), cy = static_cast<float>(camera.cy);
  p.scale = Lanes{fx, fx, fy, fy};
  p.offset = Lanes{-cx, cx, -cy, cy};
  p.limit = Lanes{0.0f, static_cast<float>(camera.width - 1), 0.0f,
                  static_cast<float>(camera.height - 1)};
  return p;
}

inline PixelRect project_cube(const Projection& p, float px, float py, float pz) {
  using Ints = std::int32_t __attribute__((vector_size(16)));
  const Lanes qz0 = splat(pz) + p.corner_z[0], qz1 = splat(pz) + p.corner_z[1];
  const auto behind = (qz0 < 1e-6f) | (qz1 < 1e-6f);
  Lanes g = p.limit;  // a corner behind the camera: the whole image
  if (!(behind[0] | behind[1] | behind[2] | behind[3])) {
    const Lanes u_a = (splat(px) + p.corner_x[0]) / qz0, u_b = (splat(px) + p.corner_x[1]) / qz1;
    const Lanes v_a = (splat(py) + p.corner_y[0]) / qz0, v_b = (splat(py) + p.corner_y[1]) / qz1;
    // Minima of u, -u, v, -v over the eight corners.
    const Lanes mu = lanes_min(u_a, u_b), nu = -lanes_max(u_a, u_b);
    const Lanes mv = lanes_min(v_a, v_b), nv = -lanes_max(v_a, v_b);
    const Lanes t1 = lanes_min(__builtin_shufflevector(mu, nu, 0, 4, 1, 5),
                               __builtin_shufflevector(mu, nu, 2, 6, 3, 7));
    const Lanes t2 = lanes_min(__builtin_shufflevector(mv, nv, 0, 4, 1, 5),
                               __builtin_shufflevector(mv, nv, 2, 6, 3, 7));
    const Lanes m = lanes_min(__builtin_shufflevector(t1, t2, 0, 1, 4, 5),
                              __builtin_shufflevector(t1, t2, 2, 3, 6, 7));
    // {-u_min - cx, u_max + cx, ...} in pixels: floor of each gives
    // {-ceil(u0), floor(u1), -ceil(v0), floor(v1)}; clamped into the image.
    g = lanes_min(splat(0.0f) - m * p.scale + p.offset, p.limit);
    g = lanes_max(g, splat(-1e6f));
  }
  const Ints truncated = __builtin_convertvector(g, Ints);
  const Ints floored = truncated + (__builtin_convertvector(truncated, Lanes) > g);  // -1 if above
  return PixelRect{-floored[0], -floored[2], floored[1], floored[3]};
}

}  // namespace zonemap
