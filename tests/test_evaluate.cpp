// zonemap-eval's measures on hand-made boxes: a box holding two objects
// separates neither, a neighbour's box is not an object's own, a moving object is
// judged by what it left behind.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "test_support.hpp"
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

// Two trees (as boxes) 4 m wide with a 1.3 m gap between them along x.
std::vector<TruthObject> two_trees_1_3_m_apart() {
  return {box_object("left", {0, 0, 0}, {4, 4, 10}),
          box_object("right", {5.3, 0, 0}, {9.3, 4, 10})};
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

TEST(Evaluate, ANeighboursBoxEndingInTheGapIsTheNeighbours) {
  // Two trees 1.3 m apart, each in a box of its own with 0.49 m between the boxes: the
  // right one's box is within the 0.5 m tolerance of the left tree, and is not its box.
  const std::vector<TruthObject> objects = two_trees_1_3_m_apart();
  const std::vector<RunBox> boxes = {obstacle(1, {-0.5, 0, 0}, {4.0, 4, 10}),
                                     obstacle(2, {4.49, 0, 0}, {9.5, 4, 10})};
  const Evaluation e = evaluate(objects, boxes, 0.5);
  EXPECT_DOUBLE_EQ(e.separated, 1.0);
  EXPECT_EQ(e.objects[0].boxes, 1);
  EXPECT_NEAR(e.excess_max_m, 0.81, 1e-9) << "the right box reaches 0.81 m past its tree";
}

TEST(Evaluate, ABoxJustShortOfAnObjectStillFindsIt) {
  const std::vector<TruthObject> objects = {box_object("post", {0, 0, 0}, {1, 1, 5})};
  const Evaluation e = evaluate(objects, {obstacle(1, {1.3, 0, 0}, {2, 1, 5})}, 0.5);
  EXPECT_DOUBLE_EQ(e.recall, 1.0);
  EXPECT_EQ(e.objects[0].boxes, 1);
  EXPECT_DOUBLE_EQ(e.excess_max_m, 1.0);
}

TEST(Evaluate, AJoinedBoxReachingIntoTheGapStillJoins) {
  // The left tree has a box of its own, but another box overlapping it by a cell also
  // holds the right tree 1.3 m away: not separated.
  const std::vector<TruthObject> objects = two_trees_1_3_m_apart();
  const std::vector<RunBox> boxes = {obstacle(1, {-0.5, 0, 0}, {3.5, 4, 10}),
                                     obstacle(2, {3.5, 0, 0}, {9.5, 4, 10})};
  const Evaluation e = evaluate(objects, boxes, 0.5);
  EXPECT_DOUBLE_EQ(e.separated, 0.0);
  EXPECT_DOUBLE_EQ(e.separated_wide, 1.0) << "a 1.3 m gap may join";
  EXPECT_NEAR(e.excess_max_m, 5.5, 1e-9);
}

// Separated over gaps a helicopter fits through (>= 2.5 m): three posts, 1.5 m and
// 3 m apart, all in one box: none separated; over wide gaps only the close pair's
// joining is forgiven, the box still swallows the far post.
TEST(Evaluate, SeparatedOverWideGapsForgivesOnlyTheNarrowOnes) {
  const std::vector<TruthObject> objects = {box_object("a", {0, 0, 0}, {1, 1, 5}),
                                            box_object("b", {2.5, 0, 0}, {3.5, 1, 5}),
                                            box_object("c", {6.5, 0, 0}, {7.5, 1, 5})};
  Evaluation e = evaluate(objects, {obstacle(1, {0, 0, 0}, {7.5, 1, 5})}, 0.5);
  EXPECT_DOUBLE_EQ(e.separated, 0.0);
  EXPECT_DOUBLE_EQ(e.separated_wide, 0.0);
  // a and b share a box, c has its own: only the 1.5 m gap is joined.
  e = evaluate(objects,
               {obstacle(1, {0, 0, 0}, {3.5, 1, 5}), obstacle(2, {6.5, 0, 0}, {7.5, 1, 5})}, 0.5);
  EXPECT_NEAR(e.separated, 1.0 / 3.0, 1e-12);
  EXPECT_DOUBLE_EQ(e.separated_wide, 1.0);
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

TEST(Evaluate, JsonHoldsEveryObjectWhateverItsNameAndPlace) {
  // A long name far from the origin: each object's line is whole (it was once cut
  // at a fixed buffer's end, leaving eval.json unreadable).
  const std::string name(120, 'n');
  const std::vector<TruthObject> objects = {
      box_object(name.c_str(), {-123456, -123456, 0}, {-123455, -123455, 2})};
  const std::string json =
      to_json(evaluate(objects, {obstacle(1, {-123456, -123456, 0}, {-123455, -123455, 2})}, 0.5));
  EXPECT_NE(json.find("\"name\": \"" + name + "\", \"seen\": true"), std::string::npos) << json;
  EXPECT_NE(json.find("\"z_coverage_seen\": 1.000}\n  ]\n}"), std::string::npos) << json;
}

TEST(Evaluate, ATopNeverSeenCountsInZCoverageAndApartInTheSeenShare) {
  // A tree 16.9 m tall flown at 15.1 m by a camera pitched down by half its field of
  // view: nothing above 15.1 m was ever in view, and the box stops at 15 m.
  TruthObject tree = box_object("tree", {0, 0, 0}, {4, 4, 16.9});
  tree.seen_top_z = 15.1;
  const TruthObject post = box_object("post", {10, 0, 0}, {11, 1, 5});  // no seen_top_z given
  const std::vector<RunBox> boxes = {obstacle(1, {0, 0, 0}, {4, 4, 15.0}),
                                     obstacle(2, {10, 0, 0}, {11, 1, 4.0})};
  const Evaluation e = evaluate({tree, post}, boxes, 0.5);
  EXPECT_NEAR(e.objects[0].z_coverage, 15.0 / 16.9, 1e-9) << "the plain share stays as it is";
  EXPECT_NEAR(e.objects[0].z_coverage_seen, 15.0 / 15.1, 1e-9);
  EXPECT_NEAR(e.objects[1].z_coverage, 0.8, 1e-9);
  EXPECT_NEAR(e.objects[1].z_coverage_seen, 0.8, 1e-9) << "not given: the whole height";
  EXPECT_NEAR(e.z_coverage_min, 0.8, 1e-9);
  EXPECT_NEAR(e.z_coverage_seen_min, 0.8, 1e-9);
}

TEST(Evaluate, ExcessIsJudgedAgainstWhatTheNearestViewAllows) {
  // Eq. (1) with the paper camera (0.25 px, 0.3 m, 669 px): Δd = d² / 803. A post
  // seen from 10 m at its nearest is allowed the 1.5 m floor; a tree seen from 45 m
  // at best 2.52 m. Both boxes reach 2 m past their object.
  const double factor = 0.25 / (0.3 * 669.0);
  TruthObject post = box_object("post", {0, 0, 0}, {1, 1, 5});
  post.nearest_seen_m = 10.0;
  TruthObject tree = box_object("tree", {20, 0, 0}, {24, 4, 10});
  tree.nearest_seen_m = 45.0;
  const TruthObject hut = box_object("hut", {40, 0, 0}, {44, 4, 3});  // no nearest given
  const std::vector<RunBox> boxes = {obstacle(1, {-2, 0, 0}, {1, 1, 5}),
                                     obstacle(2, {18, 0, 0}, {24, 4, 10}),
                                     obstacle(3, {40, 0, 0}, {44, 4, 3})};
  const Evaluation e = evaluate({post, tree, hut}, boxes, 0.5, factor);
  EXPECT_NEAR(e.objects[0].excess_m, 2.0, 1e-9);
  EXPECT_NEAR(e.objects[0].excess_allowed_m, kExcessFloorM, 1e-9);
  EXPECT_NEAR(e.objects[1].excess_allowed_m, 45.0 * 45.0 * factor, 1e-9);
  EXPECT_TRUE(std::isnan(e.objects[2].excess_allowed_m));
  EXPECT_EQ(e.excess_judged, 2);
  EXPECT_EQ(e.excess_within, 1) << "the tree's box is within, the post's is not";
  EXPECT_NE(to_table(e).find("within what the views allow"), std::string::npos);
  EXPECT_EQ(evaluate({post, tree, hut}, boxes, 0.5).excess_judged, 0) << "no camera: not judged";
}

TEST(Evaluate, ObjectsYamlGivesTheNearestDepthSeen) {
  testing::TempDir dir;
  const std::string path = dir / "objects.yaml";
  std::ofstream(path) << "objects:\n  - {name: post, type: cylinder, center: [1, 2], radius: 0.25, "
                         "z: [0, 5], pixel_hits: 4000, seen_top_z: 5.0, nearest_seen_m: 12.5}\n";
  std::vector<TruthObject> objects;
  std::string error;
  ASSERT_TRUE(load_objects_yaml(path, &objects, &error)) << error;
  ASSERT_EQ(objects.size(), 1u);
  EXPECT_DOUBLE_EQ(objects[0].nearest_seen_m, 12.5);
}

}  // namespace
}  // namespace zonemap::tools
