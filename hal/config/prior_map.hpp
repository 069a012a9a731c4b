// A prior map: obstacles known before the flight (a saved map, a survey), read at
// start-up into a fixed list that FeatureMap::add_prior takes. Formats
// (docs/FORMATS.md §2, §2b): the project's own boxes.csv (obstacle rows; ground
// rows are skipped and counted), world frame, metres; or a survey (first line
// "# zonemap survey"): the map's WGS84 origin, then one obstacle a row by
// latitude, longitude, base height, radius and height, turned into a box about
// the origin (NED; a z-up world is NED turned about north: x north, y west, z up).
// Every row is checked: a number that does not parse, NaN, a box inside out,
// wider than 1 km or reaching below -1 km or past 1,000 km is an error naming the
// file and line; the map is then not used at all (never a partial prior).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace zonemap::hal {

struct PriorBox {
  Eigen::Vector3d min = Eigen::Vector3d::Zero();
  Eigen::Vector3d max = Eigen::Vector3d::Zero();
  int line = 0;  // in its file, for messages
};

struct PriorMap {
  std::vector<PriorBox> boxes;
  int ground_rows_skipped = 0;
};

inline constexpr double kPriorMaxExtentM = 1000.0;  // wider: not an obstacle, a mistake
inline constexpr double kPriorLowestM = -1000.0;
inline constexpr double kPriorFarthestM = 1.0e6;

// Why a box cannot be an obstacle (not a number, inside out, wider than 1 km,
// reaching below -1 km, over 1,000 km out), or empty: for every box from outside.
std::string prior_box_problem(const PriorBox& box, bool world_z_up);

bool load_prior_map(const std::string& path, bool world_z_up, PriorMap* map, std::string* error);

}  // namespace zonemap::hal
