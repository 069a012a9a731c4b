// Evaluation of a run's obstacle boxes against a sequence's ground truth
// (objects.yaml), as a planner needs them: every object the camera saw found
// (recall), each in a box of its own (separated), boxes tight around it (excess,
// purity), down to the ground (z coverage), and no box where nothing is (false
// boxes). A box holding twelve objects is one detection that separates none. A
// moving object counts where it is at the end: boxes left where it was are false.
// Used by zonemap-eval and by the scenario regression tests.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace zonemap::tools {

struct TruthObject {
  std::string name;
  Eigen::Vector3d min;  // axis-aligned bounds (a cylinder's bounding box)
  Eigen::Vector3d max;
  Eigen::Vector2d centre;  // x-y centre (a cylinder's axis)
  bool cylinder = false;
  double radius = 0.0;
  std::int64_t pixel_hits = -1;  // objects.yaml's count of depth pixels on it; -1: not given
  double seen_top_z = NAN;       // objects.yaml's highest point seen on it; NaN: not given
  double nearest_seen_m = NAN;   // the least depth it was seen from (objects.yaml); NaN: not given
  bool moving = false;           // given where it is at the end of the flight
  // Horizontal distance from (x, y) to the object's footprint (0 inside).
  double distance_xy(double x, double y) const;
};

inline constexpr std::int64_t kSeenPixelHits = 1000;  // the camera saw it well enough to map
inline constexpr double kPurityMarginM = 0.5;         // box area this near an object is object
inline constexpr double kSeparationM = 1.0;           // objects this far apart need two boxes
inline constexpr double kWideGapM = 2.5;              // a gap a helicopter fits through
inline constexpr double kExcessFloorM = 1.5;          // a box may reach this far past its object

struct RunBox {
  unsigned id = 0;
  std::string kind;
  Eigen::Vector3d min;
  Eigen::Vector3d max;
  int cells = 0;
};

struct ObjectResult {
  std::string name;
  bool seen = true;     // pixel_hits >= kSeenPixelHits (or not given)
  bool moving = false;  // judged only by the false boxes it leaves where it was
  bool detected = false;
  unsigned box_id = 0;
  double centre_error_xy_m = 0.0;
  Eigen::Vector2d box_centre = Eigen::Vector2d::Zero();
  int boxes = 0;                // its obstacle boxes: overlapping it, else within the tolerance
  bool separated = false;       // none of them overlaps another object >= kSeparationM away
  bool separated_wide = false;  // none overlaps another object >= kWideGapM away
  double excess_m = 0.0;  // how far its boxes' union reaches past its x-y extent (largest side)
  // What the views allow: max(kExcessFloorM, Δd of eq. 1 at the nearest depth it
  // was seen from); NaN when that depth or the camera is not known.
  double excess_allowed_m = NAN;
  double z_coverage = 0.0;  // share of its height its boxes cover
  // The same share of the height the camera saw (up to seen_top_z): what a map of
  // these views could hold. Equal to z_coverage when all of it was in view.
  double z_coverage_seen = 0.0;
};

struct Evaluation {
  std::vector<ObjectResult> objects;
  int obstacle_boxes = 0;
  int boxes_touching_no_object = 0;         // false boxes
  int objects_seen = 0, objects_found = 0;  // standing objects (moving ones apart)
  int moving_objects = 0;
  double recall = 0.0;  // found / seen
  double false_box_fraction = 0.0;
  double separated = 0.0;       // of the objects found
  double separated_wide = 0.0;  // the same over gaps >= kWideGapM (narrower ones may join)
  double excess_median_m = 0.0, excess_max_m = 0.0;
  int excess_judged = 0, excess_within = 0;  // found objects with an allowance, and within it
  double purity = 0.0;  // obstacle-box x-y area within kPurityMarginM of an object / all of it
  double z_coverage_median = 0.0, z_coverage_min = 0.0;
  double z_coverage_seen_median = 0.0, z_coverage_seen_min = 0.0;
};

bool load_objects_yaml(const std::string& path, std::vector<TruthObject>* objects,
                       std::string* error);
bool load_boxes_csv(const std::string& path, std::vector<RunBox>* boxes, std::string* error);

// An object is detected by an obstacle box that overlaps it grown by `tolerance_m`
// (one cell); its box is the one whose x-y centre is nearest the object's.
// `range_resolution_factor` (σ / (b f) of the sequence's camera, eq. 1: Δd = d²
// times it; 0: unknown) sets each object's excess allowance.
Evaluation evaluate(const std::vector<TruthObject>& objects, const std::vector<RunBox>& boxes,
                    double tolerance_m, double range_resolution_factor = 0.0);

std::string to_json(const Evaluation& evaluation);
std::string to_table(const Evaluation& evaluation);

}  // namespace zonemap::tools
