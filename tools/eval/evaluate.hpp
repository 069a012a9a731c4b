// Evaluation of a run's obstacle boxes against a sequence's ground truth
// (objects.yaml): detection per object, recall, boxes touching no object, and
// x-y centre errors. Used by zonemap-eval and by the scenario regression tests.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

namespace zonemap::tools {

struct TruthObject {
  std::string name;
  Eigen::Vector3d min;  // axis-aligned bounds (a cylinder's bounding box)
  Eigen::Vector3d max;
  Eigen::Vector2d centre;  // x-y centre (a cylinder's axis)
};

struct RunBox {
  unsigned id = 0;
  std::string kind;
  Eigen::Vector3d min;
  Eigen::Vector3d max;
  int cells = 0;
};

struct ObjectResult {
  std::string name;
  bool detected = false;
  unsigned box_id = 0;
  double centre_error_xy_m = 0.0;
  Eigen::Vector2d box_centre = Eigen::Vector2d::Zero();
};

struct Evaluation {
  std::vector<ObjectResult> objects;
  int obstacle_boxes = 0;
  int boxes_touching_no_object = 0;
  double recall = 0.0;
  double false_box_fraction = 0.0;
};

bool load_objects_yaml(const std::string& path, std::vector<TruthObject>* objects,
                       std::string* error);
bool load_boxes_csv(const std::string& path, std::vector<RunBox>* boxes, std::string* error);

// An object is detected by an obstacle box that overlaps it grown by `tolerance_m`
// (one cell); its box is the one whose x-y centre is nearest the object's.
Evaluation evaluate(const std::vector<TruthObject>& objects, const std::vector<RunBox>& boxes,
                    double tolerance_m);

std::string to_json(const Evaluation& evaluation);
std::string to_table(const Evaluation& evaluation);

}  // namespace zonemap::tools
