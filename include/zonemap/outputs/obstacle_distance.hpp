// The feature map as an autopilot's obstacle input: distances to the nearest
// obstacle in equal horizontal sectors around the vehicle, body frame, sector 0
// straight ahead and angles growing clockwise seen from above (MAVLink
// OBSTACLE_DISTANCE, frame BODY_FRD; PX4 and ArduPilot use 72 sectors of 5 deg).
// Sector j is centred on j * increment (angle_offset 0): ArduPilot takes
// j * increment + angle_offset as the sector's middle and PX4 bins the message the
// same way, so sector 0 covers [-2.5, 2.5) deg.
// Only obstacle boxes (not ground) reaching into a vertical band around the
// vehicle count; each box is taken as its footprint rectangles where the update
// has them (tighter), else its horizontal rectangle (conservative).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include <Eigen/Geometry>

#include "zonemap/features/feature_map.hpp"

namespace zonemap {

class ZoneMap;

inline constexpr int kObstacleSectors = 72;
inline constexpr std::uint16_t kSectorUnknown = 65535;  // UINT16_MAX: not seen

struct SectorConfig {
  double min_distance_m = 0.5;   // the nearest distance the sensor reports
  double max_distance_m = 50.0;  // beyond this: no obstacle
  double band_below_m = 5.0;     // boxes reaching into [vehicle - below, vehicle + above]
  double band_above_m = 5.0;
  // A sector reads "no obstacle" only when no longer unseen stretch lies along it
  // (observed_sectors).
  double max_unseen_gap_m = 2.0;
};

// Which sectors the map has looked into (true = observed).
using SectorMask = std::array<bool, kObstacleSectors>;

struct ObstacleDistances {
  // Centimetres per sector: max_distance+1 = observed, no obstacle; kSectorUnknown
  // = never observed and no remembered obstacle (MAVLink's conventions).
  std::uint16_t distances_cm[kObstacleSectors] = {};
  std::uint16_t min_distance_cm = 0;
  std::uint16_t max_distance_cm = 0;
  float increment_deg = 360.0f / kObstacleSectors;
  int sectors_with_obstacle = 0;
  int sectors_unknown = 0;
};

// The footprint rectangles of box i: rects[offsets[i] .. + counts[i]] (a count of
// 0: the box itself). All three may be null: every box is its rectangle.
struct FootprintView {
  const FootprintRect* rects = nullptr;
  const std::uint32_t* offsets = nullptr;
  const std::uint32_t* counts = nullptr;
};

// world_T_body: the vehicle's body pose (x forward). world_z_up: the world's z axis
// points up (false: NED, z down). Exact per sector: the nearest point of each
// rectangle inside the sector's wedge. A sector with no obstacle reads "no
// obstacle" only where `observed` says it was seen. Allocation-free,
// O(rectangles x sectors).
ObstacleDistances obstacle_distances(const ObstacleBox* boxes, std::size_t count,
                                     const FootprintView& footprints,
                                     const Eigen::Isometry3d& world_T_body, bool world_z_up,
                                     const SectorConfig& config, const SectorMask& observed);

// The sectors of an update as they read from where the vehicle has moved to
// since (then -> now: position and heading), for a message resent between
// updates: an autopilot takes each sector as it comes, so sectors for where the
// vehicle was read an obstacle ahead farther than it is. All a sector says is
// that its wedge's nearest obstacle lies on the arc at its distance, so each is
// taken as possibly occupied from that arc outwards (a chord: never farther),
// bounded along the wedge edges where its neighbours read farther; a sector
// seen free is free out to max_distance, one unknown is unknown. Per sector
// now: the nearest possibly occupied point inside its wedge, else unknown where
// an unknown wedge's edge lies inside it within max_distance, else free. An
// obstacle may spread into a neighbour sector (where it could be); it never
// reads farther than the update allows. Unmoved: the sectors as they were.
// Allocation-free, O(sectors^2).
ObstacleDistances moved_obstacle_distances(const ObstacleDistances& then_distances,
                                           const Eigen::Isometry3d& world_T_body_then,
                                           const Eigen::Isometry3d& world_T_body_now,
                                           bool world_z_up);

// Which sectors are observed for a vehicle turned since the mask was made
// (then -> now, heading only: what the map saw lies in directions, and a resend
// comes within half a second): a sector now is observed when every sector it
// overlaps then was.
SectorMask turned_sector_mask(const SectorMask& observed,
                              const Eigen::Isometry3d& world_T_body_then,
                              const Eigen::Isometry3d& world_T_body_now, bool world_z_up);

// A sector counts as observed when each of three lines of its wedge (its centre
// line and 0.4 of a sector either side), from min_distance out to max_distance a
// cell a step, has at least four steps inside the zones holding a grid, at least
// half of those with a seen cell (fused value != 0, free or occupied) at one of
// five heights from the vehicle's down to the band's bottom, and no unseen
// stretch longer than max_unseen_gap_m between seen steps nor past the last one
// longer than a fifth of max_distance (what a surface stereo never matched, a
// white wall, leaves: not free; "free" is seen free out to 80% of max_distance).
// The band's top does not count: it is seen free over such a wall.
// Reads at most 72 x 3 x 5 x (max_distance / cell) cells; allocation-free.
SectorMask observed_sectors(const ZoneMap& zones, double cell_size_m,
                            const Eigen::Isometry3d& world_T_body, bool world_z_up,
                            const SectorConfig& config);

// Nearest points of the nearest obstacles, for MAVLink OBSTACLE_DISTANCE_3D: per
// obstacle box in range and in the band, and per one of `wedges` equal horizontal
// wedges about the vehicle (wedge 0 centred straight ahead, clockwise; ArduPilot's
// proximity boundary has 8) that the box reaches into, the point of its footprint
// prisms (or box) nearest to the vehicle there, in the body frame (FRD), nearest
// first, at most `capacity` (one wedge: each box's nearest point). Each wedge's
// nearest point overall is always among them (capacity >= wedges), so that a
// direction with an obstacle never reads empty. A box over or under the vehicle
// gives the point straight above or below; one holding it, a point at
// min_distance in every wedge. Allocation-free, O(rectangles x wedges).
inline constexpr int kMaxObstacleWedges = 8;
struct NearestObstacle {
  std::uint32_t id = 0;  // the box's feature id (stable while the feature lives)
  int wedge = -1;        // which wedge (0 with one)
  Eigen::Vector3d body_frd = Eigen::Vector3d::Zero();
  double distance_m = 0.0;
};
std::size_t nearest_obstacles(const ObstacleBox* boxes, std::size_t count,
                              const FootprintView& footprints,
                              const Eigen::Isometry3d& world_T_body, bool world_z_up,
                              const SectorConfig& config, NearestObstacle* out,
                              std::size_t capacity, int wedges = 1);

// The vehicle's forward and right axes in the world's horizontal plane, and down.
struct HorizontalAxes {
  Eigen::Vector3d forward, right, down;
};
HorizontalAxes horizontal_axes(const Eigen::Isometry3d& world_T_body, bool world_z_up);

}  // namespace zonemap
