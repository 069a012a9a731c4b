// The feature map as an autopilot's obstacle input: distances to the nearest
// obstacle in equal horizontal sectors around the vehicle, body frame, sector 0
// straight ahead and angles growing clockwise seen from above (MAVLink
// OBSTACLE_DISTANCE, frame BODY_FRD; PX4 and ArduPilot use 72 sectors of 5 deg).
// Only obstacle boxes (not ground) reaching into a vertical band around the
// vehicle count; each box is taken as its horizontal rectangle (conservative).
#pragma once

#include <cstddef>
#include <cstdint>

#include <Eigen/Geometry>

#include "zonemap/feature_map.hpp"

namespace zonemap {

inline constexpr int kObstacleSectors = 72;

struct SectorConfig {
  double min_distance_m = 0.5;   // the nearest distance the sensor reports
  double max_distance_m = 50.0;  // beyond this: no obstacle
  double band_below_m = 5.0;     // boxes reaching into [vehicle - below, vehicle + above]
  double band_above_m = 5.0;
};

struct ObstacleDistances {
  // Centimetres per sector: max_distance+1 = no obstacle (MAVLink's convention).
  std::uint16_t distances_cm[kObstacleSectors] = {};
  std::uint16_t min_distance_cm = 0;
  std::uint16_t max_distance_cm = 0;
  float increment_deg = 360.0f / kObstacleSectors;
  int sectors_with_obstacle = 0;
};

// world_T_body: the vehicle's body pose (x forward). world_z_up: the world's z axis
// points up (false: NED, z down). Exact per sector: the nearest point of each box
// rectangle inside the sector's wedge. Allocation-free, O(boxes x sectors).
ObstacleDistances obstacle_distances(const ObstacleBox* boxes, std::size_t count,
                                     const Eigen::Isometry3d& world_T_body, bool world_z_up,
                                     const SectorConfig& config);

}  // namespace zonemap
