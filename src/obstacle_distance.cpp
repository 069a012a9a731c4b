#include "zonemap/obstacle_distance.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace zonemap {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kInf = std::numeric_limits<double>::infinity();

// Distance along the unit ray (0,0)+t*dir to the rectangle [lo, hi], +inf if missed.
double ray_entry(const Eigen::Vector2d& dir, const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) {
  double t_near = 0.0, t_far = kInf;
  for (int a = 0; a < 2; ++a) {
    if (std::abs(dir[a]) < 1e-12) {
      if (lo[a] > 0.0 || hi[a] < 0.0) return kInf;
      continue;
    }
    double t0 = lo[a] / dir[a], t1 = hi[a] / dir[a];
    if (t0 > t1) std::swap(t0, t1);
    t_near = std::max(t_near, t0);
    t_far = std::min(t_far, t1);
  }
  return t_near <= t_far ? t_near : kInf;
}

// Clockwise angle from `forward` to `v` in [0, 2 pi), both in (forward, right) terms.
double clockwise_angle(const Eigen::Vector2d& v) {
  double a = std::atan2(v.y(), v.x());
  if (a < 0.0) a += 2.0 * kPi;
  return a;
}

}  // namespace

ObstacleDistances obstacle_distances(const ObstacleBox* boxes, std::size_t count,
                                     const Eigen::Isometry3d& world_T_body, bool world_z_up,
                                     const SectorConfig& config) {
  ObstacleDistances out;
  out.min_distance_cm = static_cast<std::uint16_t>(std::lround(config.min_distance_m * 100.0));
  out.max_distance_cm = static_cast<std::uint16_t>(
      std::clamp(std::lround(config.max_distance_m * 100.0), 1L, 65534L));
  double nearest[kObstacleSectors];
  std::fill(std::begin(nearest), std::end(nearest), kInf);

  // Horizontal (forward, right) axes of the body in the world frame.
  const Eigen::Vector3d down = world_z_up ? Eigen::Vector3d(0, 0, -1) : Eigen::Vector3d(0, 0, 1);
  Eigen::Vector3d forward = world_T_body.linear().col(0);
  forward.z() = 0.0;
  if (forward.norm() < 1e-6) forward = world_T_body.linear().col(2);  // looking straight down
  forward.z() = 0.0;
  forward.normalize();
  const Eigen::Vector3d right = down.cross(forward);
  const Eigen::Vector3d position = world_T_body.translation();
  // Heights measured upwards whatever the world's convention.
  const double up_sign = world_z_up ? 1.0 : -1.0;
  const double vehicle_height = up_sign * position.z();
  const double step = 2.0 * kPi / kObstacleSectors;

  for (std::size_t b = 0; b < count; ++b) {
    const ObstacleBox& box = boxes[b];
    if (box.kind != FeatureKind::kObstacle) continue;
    const double h0 = std::min(up_sign * box.min.z(), up_sign * box.max.z());
    const double h1 = std::max(up_sign * box.min.z(), up_sign * box.max.z());
    if (h1 < vehicle_height - config.band_below_m || h0 > vehicle_height + config.band_above_m) {
      continue;
    }
    // The rectangle's corners in (forward, right) coordinates about the vehicle.
    Eigen::Vector2d corners[4];
    int k = 0;
    for (const double x : {box.min.x(), box.max.x()}) {
      for (const double y : {box.min.y(), box.max.y()}) {
        const Eigen::Vector3d d = Eigen::Vector3d(x, y, position.z()) - position;
        corners[k++] = {d.dot(forward), d.dot(right)};
      }
    }
    // In body axes the rectangle is rotated: clip each sector's wedge against it
    // in the world-aligned frame instead, where it is axis-aligned.
    const Eigen::Vector2d lo(box.min.x() - position.x(), box.min.y() - position.y());
    const Eigen::Vector2d hi(box.max.x() - position.x(), box.max.y() - position.y());
    const Eigen::Vector2d closest = lo.cwiseMax(Eigen::Vector2d::Zero()).cwiseMin(hi);
    const double closest_distance = closest.norm();
    if (closest_distance > config.max_distance_m) continue;
    if (closest_distance == 0.0) {  // inside the box's footprint: everything is blocked
      std::fill(std::begin(nearest), std::end(nearest), 0.0);
      break;
    }
    const Eigen::Vector2d closest_body(Eigen::Vector3d(closest.x(), closest.y(), 0.0).dot(forward),
                                       Eigen::Vector3d(closest.x(), closest.y(), 0.0).dot(right));
    const double closest_angle = clockwise_angle(closest_body);
    // The sectors the rectangle spans: from its corners' angular extent (the
    // rectangle does not contain the vehicle, so it spans less than 180 degrees).
    double a_min = kInf, a_max = -kInf;
    const double reference = closest_angle;
    for (const Eigen::Vector2d& c : corners) {
      double a = clockwise_angle(c) - reference;
      if (a > kPi) a -= 2.0 * kPi;
      if (a < -kPi) a += 2.0 * kPi;
      a_min = std::min(a_min, a);
      a_max = std::max(a_max, a);
    }
    const int s_first = static_cast<int>(std::floor((reference + a_min) / step));
    const int s_last = static_cast<int>(std::floor((reference + a_max) / step));
    for (int s_unwrapped = s_first; s_unwrapped <= s_last; ++s_unwrapped) {
      const int s = ((s_unwrapped % kObstacleSectors) + kObstacleSectors) % kObstacleSectors;
      // Nearest point of the rectangle inside the wedge [s*step, (s+1)*step):
      // the rectangle's closest point if its bearing is inside, else where one of
      // the wedge's edges enters the rectangle.
      double d = kInf;
      const double w0 = s * step, w1 = (s + 1) * step;
      if (closest_angle >= w0 && closest_angle < w1) d = closest_distance;
      for (const double edge : {w0, w1}) {
        const Eigen::Vector3d dir3 = forward * std::cos(edge) + right * std::sin(edge);
        d = std::min(d, ray_entry(Eigen::Vector2d(dir3.x(), dir3.y()), lo, hi));
      }
      nearest[s] = std::min(nearest[s], d);
    }
  }
  for (int s = 0; s < kObstacleSectors; ++s) {
    if (nearest[s] <= config.max_distance_m) {
      const double cm = std::max(nearest[s], config.min_distance_m) * 100.0;
      out.distances_cm[s] = static_cast<std::uint16_t>(std::min(std::floor(cm), 65534.0));
      ++out.sectors_with_obstacle;
    } else {
      out.distances_cm[s] = static_cast<std::uint16_t>(out.max_distance_cm + 1);
    }
  }
  return out;
}

}  // namespace zonemap
