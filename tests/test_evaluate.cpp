// zonemap-eval's measures on hand-made boxes: a box holding two objects
// separates neither, a moving object is judged by what it left behind.
#include <gtest/gtest.h>

#include "tools/eval/evaluate.hpp"

namespace zonemap::tools {
namespace {

TruthObject box_object(const char* name, Eigen::Vector3d min, Eigen::Vector3d max) {
  TruthObject o;
  o.name = name;
  o.min = min;
  o.max = max;
  o.centre = Eigen::Vector2d((min.x() + max.x()) / 2, (min.y() + max.y()) / 2);
  return o;
}

RunBox obstacle(unsigned id, Eigen::Vector3d min, Eigen::Vector3d max) {
  return RunBox{id, "obstacle", min, max, 10};
}

TEST(Evaluate, OneBoxOverTwoObjectsSeparatesNeither) {
  const std::vector<TruthObject> objects = {box_object("a", {0, 0, 0}, {1, 1, 2}),
                                            box_object("b", {4, 0, 0}, {5, 1, 2})};
  const Evaluation e = evaluate(objects, {obstacle(1, {0, 0, 0}, {5, 1, 2})}, 0.5);
  EXPECT_DOUBLE_EQ(e.recall, 1.0);
  EXPECT_DOUBLE_EQ(e.separated, 0.0);
  EXPECT_DOUBLE_EQ(e.excess_max_m, 4.0);
  EXPECT_LT(e.purity, 0.8);
}

TEST(Evaluate, AMovingObjectCountsWhereItEndsAndItsOldPlaceIsAFalseBox) {
  TruthObject car = box_object("car", {10, 10, 0}, {12, 14, 1.5});  // where it is at the end
  car.moving = true;
  const std::vector<TruthObject> objects = {box_object("post", {0, 0, 0}, {1, 1, 5}), car};
  const std::vector<RunBox> boxes = {obstacle(1, {0, 0, 0}, {1, 1, 5}),
                                     obstacle(2, {10, -10, 0}, {12, -6, 1.5})};  // where it was
  const Evaluation e = evaluate(objects, boxes, 0.5);
  EXPECT_EQ(e.moving_objects, 1);
  EXPECT_EQ(e.objects_seen, 1) << "the car is not in recall";
  EXPECT_DOUBLE_EQ(e.recall, 1.0);
  EXPECT_EQ(e.boxes_touching_no_object, 1) << "the box left where the car was";
  EXPECT_TRUE(e.objects[1].moving);
}

}  // namespace
}  // namespace zonemap::tools
