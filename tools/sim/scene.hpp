// Generated flights: a scene of ground plane, boxes and vertical cylinders seen by
// a stereo camera along a trajectory, rendered with stereo noise per eq. (1),
// holes and a bright flat sky. Deterministic for a given seed. Computation only
// (it links the core alone, so the core's tests render with it);
// sequence_writer.hpp writes a flight in the replay layout of FORMATS.md §1.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "zonemap/common/camera.hpp"

namespace zonemap::sim {

struct Box {
  std::string name;
  Eigen::Vector3d min;  // where it stands at time 0
  Eigen::Vector3d max;
  Eigen::Vector3d velocity_mps = Eigen::Vector3d::Zero();  // a moving object (a car) ...
  double departs_s = 0.0;                                  // ... standing still until then
  // Painted white with no texture (a house wall, a white van): as bright and flat
  // as the sky, and stereo matches none of it.
  bool white = false;
  bool moving() const { return !velocity_mps.isZero(); }
};

struct Cylinder {
  std::string name;
  Eigen::Vector2d center;
  double radius = 0.0;
  double z_min = 0.0;
  double z_max = 0.0;
};

struct Scene {
  bool has_ground = true;
  double ground_z = 0.0;
  // Terrain that rises (slope > 0) or falls along +x from slope_start_x on: the
  // ground is flat at ground_z before it and ground_z + slope (x - slope_start_x)
  // beyond (12% = 0.12).
  double slope = 0.0;
  double slope_start_x = 0.0;
  double ground_height(double x) const {
    return ground_z + (x > slope_start_x ? slope * (x - slope_start_x) : 0.0);
  }
  std::vector<Box> boxes;
  std::vector<Cylinder> cylinders;
  // The scene at time t: each moving box moved along its velocity.
  Scene at(double time_s) const;
};

struct TimedPose {
  double time_s = 0.0;
  Eigen::Isometry3d world_T_camera = Eigen::Isometry3d::Identity();
};

struct RenderOptions {
  double max_range_m = 60.0;          // farther surfaces give no depth (textured, so not sky)
  double noise_sigma_px = 0.125;      // matching noise actually applied (eq. 1 with this sigma)
  double hole_fraction = 0.02;        // pixels dropped at random
  double hole_block_fraction = 0.01;  // 8x8 blocks dropped (failed matches)
  std::uint64_t seed = 1;
};

// Deterministic random numbers (splitmix64), the same on every platform.
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next();
  double uniform();   // [0, 1)
  double gaussian();  // N(0, 1), Box-Muller

 private:
  std::uint64_t state_;
};

// Camera looking along heading `yaw` (radians from +x towards +y), pitched down by
// `pitch_down` radians, in a z-up world. Optical frame: x right, y down, z forward.
Eigen::Isometry3d look_pose(const Eigen::Vector3d& position, double yaw, double pitch_down);

// The z-depth along the optical axis of the first surface hit by pixel (u, v), or
// a negative value when the ray hits nothing (sky). *surface_id tells what was hit
// (0 ground, 1.. objects) for texturing.
double cast_pixel(const Scene& scene, const CameraModel& camera, const Eigen::Isometry3d& pose,
                  double u, double v, Eigen::Vector3d* hit_point, int* object = nullptr);

// objects.yaml's pixel_hits: valid depth pixels on the object within these ranges
// (the paper configurations' d_max and the sensor environment's half width), the
// evaluation's test of whether the camera saw the object well enough to map it.
inline constexpr double kSeenRangeM = 50.0;
inline constexpr double kSeenHorizontalM = 40.0;

// What the camera saw of each object (one entry per cylinder, then per box) over a
// flight: the valid depth pixels on it within kSeenRangeM / kSeenHorizontalM, and
// the highest of those points (world z; -inf: none). An object's top above the
// camera's view (a tree taller than the flight's altitude, seen from a camera
// pitched down by half its field of view) is never seen, so never mapped.
struct ObjectSightings {
  std::vector<std::int64_t> pixel_hits;
  std::vector<double> top_z;
  std::vector<double> nearest_m;  // the least depth (along the optical axis) of a hit on it
  explicit ObjectSightings(std::size_t objects);
};

// Renders one frame: depth in units of 1/camera.depth_scale metres (0 = none) and
// the left intensity image; with `sightings`, adds what this frame saw to them.
void render(const Scene& scene, const CameraModel& camera, const Eigen::Isometry3d& pose,
            const RenderOptions& options, Rng& rng, std::uint16_t* depth, std::uint8_t* left,
            ObjectSightings* sightings = nullptr);

}  // namespace zonemap::sim
