#include "tools/sim/scene.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace zonemap::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Ray p(δ) = o + δ w against an axis-aligned box: entry δ or +inf.
double hit_box(const Box& b, const Eigen::Vector3d& o, const Eigen::Vector3d& w) {
  double t0 = 0.0;
  double t1 = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (std::fabs(w[a]) < 1e-12) {
      if (o[a] < b.min[a] || o[a] > b.max[a]) return std::numeric_limits<double>::infinity();
      continue;
    }
    double ta = (b.min[a] - o[a]) / w[a];
    double tb = (b.max[a] - o[a]) / w[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  return t0 <= t1 && t0 > 0.0 ? t0 : std::numeric_limits<double>::infinity();
}

double hit_cylinder(const Cylinder& c, const Eigen::Vector3d& o, const Eigen::Vector3d& w) {
  double best = std::numeric_limits<double>::infinity();
  // Side wall.
  const Eigen::Vector2d d(o.x() - c.center.x(), o.y() - c.center.y());
  const double a = w.x() * w.x() + w.y() * w.y();
  if (a > 1e-12) {
    const double b = 2.0 * (d.x() * w.x() + d.y() * w.y());
    const double cc = d.squaredNorm() - c.radius * c.radius;
    const double disc = b * b - 4.0 * a * cc;
    if (disc >= 0.0) {
      const double t = (-b - std::sqrt(disc)) / (2.0 * a);
      const double z = o.z() + t * w.z();
      if (t > 0.0 && z >= c.z_min && z <= c.z_max) best = t;
    }
  }
  // Top and bottom caps.
  if (std::fabs(w.z()) > 1e-12) {
    for (double zc : {c.z_max, c.z_min}) {
      const double t = (zc - o.z()) / w.z();
      if (t <= 0.0 || t >= best) continue;
      const Eigen::Vector2d p(o.x() + t * w.x() - c.center.x(), o.y() + t * w.y() - c.center.y());
      if (p.squaredNorm() <= c.radius * c.radius) best = t;
    }
  }
  return best;
}

// Stable surface texture from the world position: a value noise in [0, 1).
double texture(const Eigen::Vector3d& p) {
  const auto q = (p * 4.0).array().floor().cast<long long>();
  std::uint64_t h = static_cast<std::uint64_t>(q.x()) * 0x9E3779B97F4A7C15ULL ^
                    static_cast<std::uint64_t>(q.y()) * 0xC2B2AE3D27D4EB4FULL ^
                    static_cast<std::uint64_t>(q.z()) * 0x165667B19E3779F9ULL;
  h ^= h >> 29;
  h *= 0xBF58476D1CE4E5B9ULL;
  h ^= h >> 32;
  return static_cast<double>(h >> 11) / static_cast<double>(1ULL << 53);
}

constexpr double kNoHit = std::numeric_limits<double>::infinity();

// The ground is two planes: flat up to slope_start_x, inclined beyond; a ray hits
// each only on its own side of the crease.
double hit_ground(const Scene& scene, const Eigen::Vector3d& o, const Eigen::Vector3d& w) {
  double best = kNoHit;
  if (w.z() < -1e-12) {
    const double t = (scene.ground_z - o.z()) / w.z();
    if (t > 0.0 && (scene.slope == 0.0 || o.x() + t * w.x() <= scene.slope_start_x)) best = t;
  }
  const double approach = w.z() - scene.slope * w.x();  // < 0: the ray nears the incline
  if (scene.slope != 0.0 && approach < -1e-12) {
    const double incline_at_o = scene.ground_z + scene.slope * (o.x() - scene.slope_start_x);
    const double t = (incline_at_o - o.z()) / approach;
    if (t > 0.0 && o.x() + t * w.x() >= scene.slope_start_x) best = std::min(best, t);
  }
  return best;
}

}  // namespace

std::uint64_t Rng::next() {
  std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

double Rng::uniform() {
  return static_cast<double>(next() >> 11) / static_cast<double>(1ULL << 53);
}

double Rng::gaussian() {
  const double u1 = std::max(uniform(), 1e-300);
  const double u2 = uniform();
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
}

Eigen::Isometry3d look_pose(const Eigen::Vector3d& position, double yaw, double pitch_down) {
  const Eigen::Vector3d forward(std::cos(pitch_down) * std::cos(yaw),
                                std::cos(pitch_down) * std::sin(yaw), -std::sin(pitch_down));
  const Eigen::Vector3d right(std::sin(yaw), -std::cos(yaw), 0.0);
  const Eigen::Vector3d down = forward.cross(right);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear().col(0) = right;
  pose.linear().col(1) = down;
  pose.linear().col(2) = forward;
  pose.translation() = position;
  return pose;
}

double cast_pixel(const Scene& scene, const CameraModel& camera, const Eigen::Isometry3d& pose,
                  double u, double v, Eigen::Vector3d* hit_point, int* object) {
  const Eigen::Vector3d o = pose.translation();
  const Eigen::Vector3d w = pose.linear() * Eigen::Vector3d((u - camera.cx) / camera.fx,
                                                            (v - camera.cy) / camera.fy, 1.0);
  double best = scene.has_ground ? hit_ground(scene, o, w) : kNoHit;
  int hit_object = -1;  // the ground
  const int cylinders = static_cast<int>(scene.cylinders.size());
  for (int k = 0; k < cylinders; ++k) {
    const double t = hit_cylinder(scene.cylinders[static_cast<std::size_t>(k)], o, w);
    if (t < best) {
      best = t;
      hit_object = k;
    }
  }
  for (std::size_t k = 0; k < scene.boxes.size(); ++k) {
    const double t = hit_box(scene.boxes[k], o, w);
    if (t < best) {
      best = t;
      hit_object = cylinders + static_cast<int>(k);
    }
  }
  if (object != nullptr) *object = hit_object;
  if (!std::isfinite(best)) return -1.0;
  *hit_point = o + best * w;
  return best;  // δ is the z-depth because w has unit optical-axis component
}

ObjectSightings::ObjectSightings(std::size_t objects)
    : pixel_hits(objects, 0), top_z(objects, -INFINITY), nearest_m(objects, INFINITY) {}

void render(const Scene& scene, const CameraModel& camera, const Eigen::Isometry3d& pose,
            const RenderOptions& options, Rng& rng, std::uint16_t* depth, std::uint8_t* left,
            ObjectSightings* sightings) {
  const int w = camera.width;
  const int h = camera.height;
  // Failed matches come in blocks: choose them first.
  const int bw = (w + 7) / 8;
  const int bh = (h + 7) / 8;
  std::vector<bool> dropped_block(static_cast<std::size_t>(bw * bh));
  for (std::size_t i = 0; i < dropped_block.size(); ++i) {
    dropped_block[i] = rng.uniform() < options.hole_block_fraction;
  }
  const double noise_factor = options.noise_sigma_px / (camera.baseline_m * camera.fx);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * w + u;
      Eigen::Vector3d hit;
      int object = -1;
      const double d = cast_pixel(scene, camera, pose, u, v, &hit, &object);
      const double noise = rng.gaussian();
      const double drop = rng.uniform();
      const double grain = rng.uniform();
      if (d < 0.0) {
        // Sky: bright and flat, no stereo match.
        left[i] = static_cast<std::uint8_t>(232 + static_cast<int>(grain * 3.0));
        depth[i] = 0;
        continue;
      }
      const int cylinders = static_cast<int>(scene.cylinders.size());
      if (object >= cylinders && scene.boxes[static_cast<std::size_t>(object - cylinders)].white) {
        // A white, textureless surface: a little brighter than the sky (their
        // boundary stays flat), and no stereo match anywhere on it.
        left[i] = static_cast<std::uint8_t>(236 + static_cast<int>(grain * 3.0));
        depth[i] = 0;
        continue;
      }
      left[i] = static_cast<std::uint8_t>(40 + static_cast<int>(texture(hit) * 150.0));
      const double noisy = d + noise * d * d * noise_factor;  // eq. (1) with the true sigma
      const bool hole = drop < options.hole_fraction ||
                        dropped_block[static_cast<std::size_t>((v / 8) * bw + u / 8)];
      const double value = std::round(noisy * camera.depth_scale);
      if (hole || d > options.max_range_m || value < 1.0 || value > 65535.0) {
        depth[i] = 0;
      } else {
        depth[i] = static_cast<std::uint16_t>(value);
        const double horizontal = (hit - pose.translation()).head<2>().norm();
        if (sightings != nullptr && object >= 0 && d <= kSeenRangeM &&
            horizontal <= kSeenHorizontalM) {
          const auto k = static_cast<std::size_t>(object);
          ++sightings->pixel_hits[k];
          sightings->top_z[k] = std::max(sightings->top_z[k], hit.z());
          sightings->nearest_m[k] = std::min(sightings->nearest_m[k], d);
        }
      }
    }
  }
}

Scene Scene::at(double time_s) const {
  Scene moved = *this;
  for (Box& b : moved.boxes) {
    const double driven_s = std::max(0.0, time_s - b.departs_s);
    b.min += b.velocity_mps * driven_s;
    b.max += b.velocity_mps * driven_s;
  }
  return moved;
}

}  // namespace zonemap::sim
