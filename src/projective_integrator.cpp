#include "zonemap/projective_integrator.hpp"

#include <algorithm>
#include <cmath>

#include "zonemap/sensor_model.hpp"

namespace zonemap {
namespace {

constexpr float kNoRay = -2.0f;  // below every m̂: no ray reaches the cell

LocalCell quantize(float units) {
  return static_cast<LocalCell>(std::clamp(to_fixed(units), -kCellScale, kCellScale));
}

}  // namespace

ProjectiveIntegrator::ProjectiveIntegrator(const MapConfig& config, const CameraModel& camera)
    : cell_size_m_(config.cell_size_m),
      d_min_(static_cast<float>(config.d_min_m)),
      d_max_(static_cast<float>(config.d_max_m)),
      resolution_factor_(
          static_cast<float>(camera.match_sigma_px / (camera.baseline_m * camera.fx))),
      code_to_m_(static_cast<float>(1.0 / camera.depth_scale)),
      camera_(camera) {}

// m̂ maximised over the part of [a, b] the ray covers: the ray of depth d runs
// from d_min to min(d + Δd, d_max) (free-only rays to d_max).
float ProjectiveIntegrator::value_for_code(std::uint16_t code, float a, float b) const {
  if (code == DepthRangeTable::kFar) return a <= d_max_ ? -1.0f : kNoRay;
  const float d = static_cast<float>(code) * code_to_m_;
  const float resolution = std::max(d * d * resolution_factor_, 1e-6f);
  const float end = std::min(d + resolution, d_max_);
  if (a > end) return kNoRay;
  return sensor_model_value(std::clamp(d, a, std::min(b, end)), d, resolution);
}

float ProjectiveIntegrator::best_value(const DepthRangeTable& depths, int x0, int y0, int x1,
                                       int y1, float a, float b) const {
  // m̂ is unimodal in d with its plateau for d in [a, b]: over a set of depths
  // entirely below a the largest one decides, entirely above b the smallest. Only
  // a rectangle whose depths straddle [a, b] across a gap (an edge in front of
  // a background) is split, down to single pixels if need be.
  struct Rect {
    int x0, y0, x1, y1;
  };
  Rect stack[64];
  int top = 0;
  stack[top++] = {x0, y0, x1, y1};
  float best = kNoRay;
  const float a_code = a / code_to_m_;
  const float b_code = b / code_to_m_;
  while (top > 0) {
    const Rect r = stack[--top];
    std::uint16_t lo = 0, hi = 0;
    depths.range(r.x0, r.y0, r.x1, r.y1, &lo, &hi);
    if (lo > hi) continue;  // no usable pixel
    if (static_cast<float>(hi) < a_code) {
      best = std::max(best, value_for_code(hi, a, b));
      continue;
    }
    if (static_cast<float>(lo) > b_code) {
      best = std::max(best, value_for_code(lo, a, b));
      continue;
    }
    // lo <= b and hi >= a. A pixel with its depth inside [a, b] is the peak.
    if (static_cast<float>(lo) >= a_code || static_cast<float>(hi) <= b_code) return 1.0f;
    // lo < a <= b < hi. On a continuous surface (depths spread over less than
    // half Δd) the depths next to a and b are within Δd/2 of them, so the
    // largest m̂ is in [0.5, 1]: take the peak.
    const float lo_m = static_cast<float>(lo) * code_to_m_;
    const float hi_m = hi == DepthRangeTable::kFar ? 1e30f : static_cast<float>(hi) * code_to_m_;
    if (hi_m - lo_m <= 0.5f * lo_m * lo_m * resolution_factor_) return 1.0f;
    // Split along the longer side (a single pixel never gets here: lo == hi).
    if (top + 2 > 64) return 1.0f;  // cannot happen for images up to 2^32 pixels
    if (r.x1 - r.x0 >= r.y1 - r.y0) {
      const int mid = (r.x0 + r.x1) / 2;
      stack[top++] = {r.x0, r.y0, mid, r.y1};
      stack[top++] = {mid + 1, r.y0, r.x1, r.y1};
    } else {
      const int mid = (r.y0 + r.y1) / 2;
      stack[top++] = {r.x0, r.y0, r.x1, mid};
      stack[top++] = {r.x0, mid + 1, r.x1, r.y1};
    }
  }
  return best;
}

float ProjectiveIntegrator::exact_value(const DepthRangeTable& depths, int x0, int y0, int x1,
                                        int y1, const Eigen::Isometry3d& world_T_camera,
                                        const Eigen::Vector3d& cell_lo) const {
  const Eigen::Matrix3f r = world_T_camera.linear().cast<float>();
  const Eigen::Vector3f rel_lo = (cell_lo - world_T_camera.translation()).cast<float>();
  const Eigen::Vector3f rel_hi =
      rel_lo + Eigen::Vector3f::Constant(static_cast<float>(cell_size_m_));
  const Eigen::Vector3f du = r.col(0) / static_cast<float>(camera_.fx);
  const Eigen::Vector3f dv = r.col(1) / static_cast<float>(camera_.fy);
  const Eigen::Vector3f w00 =
      r * Eigen::Vector3f(static_cast<float>(-camera_.cx / camera_.fx),
                          static_cast<float>(-camera_.cy / camera_.fy), 1.0f);
  // The cell's δ-support bounds every ray's part in it: a tile whose best possible
  // value cannot beat the best so far is skipped without looking at its rays.
  float a = 1e30f, b = -1e30f;
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3f corner((k & 1) ? rel_hi.x() : rel_lo.x(),
                                 (k & 2) ? rel_hi.y() : rel_lo.y(),
                                 (k & 4) ? rel_hi.z() : rel_lo.z());
    const float depth = r.col(2).dot(corner);
    a = std::min(a, depth);
    b = std::max(b, depth);
  }
  a = std::max(a, d_min_);
  constexpr int kTile = 4;
  float best = kNoRay;
  for (int ty = y0; ty <= y1; ty += kTile) {
    for (int tx = x0; tx <= x1; tx += kTile) {
      const int ex = std::min(tx + kTile - 1, x1), ey = std::min(ty + kTile - 1, y1);
      std::uint16_t lo = 0, hi = 0;
      depths.range(tx, ty, ex, ey, &lo, &hi);
      if (lo > hi) continue;
      float bound = std::max(value_for_code(lo, a, b), value_for_code(hi, a, b));
      if (static_cast<float>(hi) * code_to_m_ >= a && static_cast<float>(lo) * code_to_m_ <= b)
        bound = 1.0f;
      if (bound <= best) continue;
      for (int v = ty; v <= ey; ++v) {
        const std::uint16_t* row = depths.codes() + static_cast<std::size_t>(v) * depths.width();
        Eigen::Vector3f w = w00 + static_cast<float>(tx) * du + static_cast<float>(v) * dv;
        for (int u = tx; u <= ex; ++u, w += du) {
          const std::uint16_t code = row[u];
          if (code == DepthRangeTable::kMissing) continue;
          float t0 = d_min_;
          float t1 = 1e30f;
          for (int k = 0; k < 3; ++k) {
            const float inv = 1.0f / w[k];  // ±inf for an axis-parallel ray: handled below
            float ta = rel_lo[k] * inv, tb = rel_hi[k] * inv;
            if (ta > tb) std::swap(ta, tb);
            if (!(ta <= tb)) {  // NaN: 0 * inf, the ray runs in a slab face
              ta = -1e30f;
              tb = 1e30f;
            }
            t0 = std::max(t0, ta);
            t1 = std::min(t1, tb);
          }
          if (t0 >= t1) continue;  // this ray misses the cell
          best = std::max(best, value_for_code(code, t0, t1));
          if (best >= 1.0f) return best;
        }
      }
    }
  }
  return best;
}

std::int64_t ProjectiveIntegrator::draw(const DepthRangeTable& depths,
                                        const Eigen::Isometry3d& world_T_camera,
                                        LocalGrid& grid) const {
  const double s = cell_size_m_;
  const std::array<int, 3>& dims = grid.dims();
  const CellIndex origin = grid.origin();
  const Eigen::Matrix3d r = world_T_camera.linear();
  const Eigen::Matrix3d rt = r.transpose();
  const Eigen::Vector3d t = world_T_camera.translation();
  // Half extents of a cell along the camera axes (the camera-frame AABB of a cube).
  const Eigen::Vector3d half = 0.5 * s * r.cwiseAbs().colwise().sum().transpose();
  const double margin = 0.5 * s * std::sqrt(3.0);
  const int w = camera_.width, h = camera_.height;
  const double fx = camera_.fx, fy = camera_.fy, cx = camera_.cx, cy = camera_.cy;

  // Frustum planes in the camera frame (n . p >= c), widened by a cell's half diagonal.
  const double kl = (0.0 - cx) / fx, kr = (w - 1 - cx) / fx;
  const double kt = (0.0 - cy) / fy, kb = (h - 1 - cy) / fy;
  Eigen::Vector3d normals[6] = {{1, 0, -kl}, {-1, 0, kr}, {0, 1, -kt},
                                {0, -1, kb}, {0, 0, 1},   {0, 0, -1}};
  double offsets[6] = {0, 0, 0, 0, d_min_ - half.z(), -(d_max_ + half.z())};
  for (int i = 0; i < 6; ++i) {
    const double len = normals[i].norm();
    normals[i] /= len;
    offsets[i] /= len;
    offsets[i] -= margin;
    // To the world frame: n_c . R^T (p - t) >= c  <=>  (R n_c) . p >= c + (R n_c) . t
    normals[i] = r * normals[i];
    offsets[i] += normals[i].dot(t);
  }
  // Cell (x, y, z) of the grid has its centre at base + (x, y, z) * s.
  const Eigen::Vector3d base =
      (Eigen::Vector3d(origin.x, origin.y, origin.z) + Eigen::Vector3d::Constant(0.5)) * s;
  Eigen::Vector3d corners[8];
  for (int k = 0; k < 8; ++k) {
    corners[k] = rt * Eigen::Vector3d((k & 1) ? 0.5 * s : -0.5 * s, (k & 2) ? 0.5 * s : -0.5 * s,
                                      (k & 4) ? 0.5 * s : -0.5 * s);
  }
  const Eigen::Vector3d step_x_camera = rt.col(0) * s;

  std::int64_t evaluated = 0;
  int touched_lo[3] = {dims[0], dims[1], dims[2]};
  int touched_hi[3] = {-1, -1, -1};
  for (int z = 0; z < dims[2]; ++z) {
    for (int y = 0; y < dims[1]; ++y) {
      // The x range of this row inside every plane.
      double x_lo = 0.0, x_hi = dims[0] - 1;
      const double wy = base.y() + y * s, wz = base.z() + z * s;
      for (int i = 0; i < 6 && x_lo <= x_hi; ++i) {
        const Eigen::Vector3d& n = normals[i];
        const double rest = n.y() * wy + n.z() * wz - offsets[i];  // n.x * X + rest >= 0
        if (std::fabs(n.x()) < 1e-12) {
          if (rest < 0.0) x_hi = -1.0;
          continue;
        }
        const double bound = (-rest / n.x() - base.x()) / s;  // in cells
        if (n.x() > 0.0) {
          x_lo = std::max(x_lo, std::ceil(bound));
        } else {
          x_hi = std::min(x_hi, std::floor(bound));
        }
      }
      if (x_lo > x_hi) continue;
      const int xa = static_cast<int>(x_lo), xb = static_cast<int>(x_hi);
      touched_lo[0] = std::min(touched_lo[0], xa);
      touched_hi[0] = std::max(touched_hi[0], xb);
      touched_lo[1] = std::min(touched_lo[1], y);
      touched_hi[1] = std::max(touched_hi[1], y);
      touched_lo[2] = std::min(touched_lo[2], z);
      touched_hi[2] = std::max(touched_hi[2], z);
      Eigen::Vector3d pc = rt * (Eigen::Vector3d(base.x() + xa * s, wy, wz) - t);
      for (int x = xa; x <= xb; ++x, pc += step_x_camera) {
        const double zc = pc.z();
        const double a = std::max(zc - half.z(), static_cast<double>(d_min_));
        const double b = zc + half.z();
        if (b < d_min_ || a > d_max_) continue;
        // The image box of the cube's eight projected corners: the pixels whose
        // rays can cross the cell.
        double u0 = 1e300, u1 = -1e300, v0 = 1e300, v1 = -1e300;
        bool behind = false;
        for (const Eigen::Vector3d& o : corners) {
          const Eigen::Vector3d q = pc + o;
          if (q.z() < 1e-6) {
            behind = true;
            break;
          }
          const double inv = 1.0 / q.z();
          const double u = fx * q.x() * inv, v = fy * q.y() * inv;
          u0 = std::min(u0, u);
          u1 = std::max(u1, u);
          v0 = std::min(v0, v);
          v1 = std::max(v1, v);
        }
        if (behind) {
          u0 = v0 = -1e300;
          u1 = v1 = 1e300;
        } else {
          u0 += cx;
          u1 += cx;
          v0 += cy;
          v1 += cy;
        }
        const int px0 = std::max(0, static_cast<int>(std::ceil(u0)));
        const int px1 = std::min(w - 1, static_cast<int>(std::floor(u1)));
        const int py0 = std::max(0, static_cast<int>(std::ceil(v0)));
        const int py1 = std::min(h - 1, static_cast<int>(std::floor(v1)));
        if (px0 > px1 || py0 > py1) continue;
        ++evaluated;
        float value =
            best_value(depths, px0, py0, px1, py1, static_cast<float>(a), static_cast<float>(b));
        // Near a surface the value depends on which rays cross the cell and where:
        // settle it ray by ray, as the reference does.
        if (value > -1.0f) {
          value = exact_value(depths, px0, py0, px1, py1, world_T_camera,
                              (Eigen::Vector3d(origin.x + x, origin.y + y, origin.z + z)) * s);
        }
        if (value >= -1.0f) grid.write_max(x, y, z, quantize(value));
      }
    }
  }
  grid.extend_touched(touched_lo[0], touched_lo[1], touched_lo[2], touched_hi[0], touched_hi[1],
                      touched_hi[2]);
  return evaluated;
}

}  // namespace zonemap
