// The feature map's numbers on the generated paper scenarios (issue: posts within
// 0.5 m, recall 100%, <= 5% false boxes, out-and-back keeps every obstacle).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "replay_support.hpp"
#include "test_support.hpp"
#include "tools/eval/evaluate.hpp"
#include "tools/replay/replay_run.hpp"
#include "tools/sim/sequence_writer.hpp"

namespace zonemap {
namespace {

using testing::TempDir;

struct ScenarioRun {
  tools::Evaluation evaluation;
  std::vector<tools::RunBox> boxes;
  std::vector<tools::TruthObject> objects;
};

ScenarioRun map_and_evaluate(const std::string& name, double rate, int pixel_step) {
  ScenarioRun result;
  TempDir dir;
  const std::string sequence = dir / "seq";
  const std::string config = testing::write_test_scenario(name, sequence, rate, pixel_step);
  tools::ReplayRun run;
  tools::ReplayOptions options = testing::quiet_replay(sequence, config);
  std::string error;
  if (!run.open(options, &error)) {
    ADD_FAILURE() << error;
    return result;
  }
  run.run();
  EXPECT_EQ(run.stats().heap_allocations_after_init, 0);
  EXPECT_TRUE(run.write_outputs(dir / "out", &error)) << error;
  EXPECT_TRUE(tools::load_objects_yaml(sequence + "/objects.yaml", &result.objects, &error))
      << error;
  EXPECT_TRUE(tools::load_boxes_csv(dir / "out/boxes.csv", &result.boxes, &error)) << error;
  result.evaluation = tools::evaluate(result.objects, result.boxes, run.config().cell_size_m);
  std::printf("[ %s ]\n%s", name.c_str(), tools::to_table(result.evaluation).c_str());
  return result;
}

// The same at the paper camera's own matching noise (eq. 1 with sigma 0.25 px, as
// every config assumes; the test flights are rendered at half of it) and 4% of
// the pixels dropped, every frame at 10 Hz.
tools::Evaluation map_with_noise(const std::string& name, std::uint64_t seed, double noise_px,
                                 double holes) {
  TempDir dir;
  const std::string sequence = dir / "seq";
  sim::Scenario scenario;
  std::string error;
  EXPECT_TRUE(sim::make_scenario(name, {640, 10.0, seed}, &scenario, &error)) << error;
  sim::RenderOptions render;
  render.noise_sigma_px = noise_px;
  render.hole_fraction = holes;
  render.seed = seed;
  EXPECT_TRUE(sim::write_sequence(sequence, scenario.scene, scenario.camera, scenario.trajectory,
                                  render, &error))
      << error;
  tools::ReplayRun run;
  if (!run.open(testing::quiet_replay(sequence, testing::source_path(scenario.config)), &error)) {
    ADD_FAILURE() << error;
    return {};
  }
  run.run();
  EXPECT_TRUE(run.write_outputs(dir / "out", &error)) << error;
  std::vector<tools::TruthObject> objects;
  std::vector<tools::RunBox> boxes;
  EXPECT_TRUE(tools::load_objects_yaml(sequence + "/objects.yaml", &objects, &error)) << error;
  EXPECT_TRUE(tools::load_boxes_csv(dir / "out/boxes.csv", &boxes, &error)) << error;
  const tools::Evaluation e = tools::evaluate(objects, boxes, run.config().cell_size_m);
  std::printf("[ %s seed %llu, %.3g px ] ground patches taken for ground: %lld\n%s", name.c_str(),
              static_cast<unsigned long long>(seed), noise_px,
              static_cast<long long>(run.features().counters().objects_in_ground_band),
              tools::to_table(e).c_str());
  return e;
}

tools::Evaluation map_at_full_noise(const std::string& name, std::uint64_t seed) {
  return map_with_noise(name, seed, 0.25, 0.04);
}

bool detected(const tools::Evaluation& e, const std::string& name) {
  for (const tools::ObjectResult& o : e.objects) {
    if (o.name == name && o.detected) return true;
  }
  return false;
}

std::vector<tools::RunBox> obstacles(const std::vector<tools::RunBox>& boxes) {
  std::vector<tools::RunBox> out;
  for (const auto& b : boxes)
    if (b.kind == "obstacle") out.push_back(b);
  return out;
}

void expect_two_posts(const ScenarioRun& r) {
  ASSERT_EQ(obstacles(r.boxes).size(), 2u) << "exactly two obstacle boxes";
  ASSERT_EQ(r.evaluation.objects.size(), 2u);
  for (const auto& o : r.evaluation.objects) {
    EXPECT_TRUE(o.detected) << o.name;
    EXPECT_LE(o.centre_error_xy_m, 0.5) << o.name;
  }
  const double spacing =
      (r.evaluation.objects[0].box_centre - r.evaluation.objects[1].box_centre).norm();
  EXPECT_NEAR(spacing, 7.0, 0.5);
}

TEST(FeatureScenarios, PostsFlownThroughAndAroundAgree) {
  const ScenarioRun through = map_and_evaluate("posts-through", 5.0, 4);
  const ScenarioRun around = map_and_evaluate("posts-around", 3.0, 4);
  expect_two_posts(through);
  expect_two_posts(around);
  if (through.evaluation.objects.size() == 2 && around.evaluation.objects.size() == 2) {
    for (int i = 0; i < 2; ++i) {
      EXPECT_LE((through.evaluation.objects[static_cast<std::size_t>(i)].box_centre -
                 around.evaluation.objects[static_cast<std::size_t>(i)].box_centre)
                    .norm(),
                0.5)
          << "both flights put post " << i << " in the same place";
    }
  }
}

// Far grazing views smear the ground into runs that vary column to column; where
// they rose a cell or two above the measured band, patches of it stood as
// obstacles (3 on the tree line seed 1, 2 on the field seed 6 before the rule
// that an obstacle must rise above the ground around it).
TEST(FeatureScenarios, GroundSeenAtFullNoiseMakesNoObstacle) {
  for (const auto& [name, seed] : {std::pair<const char*, std::uint64_t>{"treeline", 1},
                                   std::pair<const char*, std::uint64_t>{"field-grazing", 6}}) {
    const tools::Evaluation e = map_at_full_noise(name, seed);
    EXPECT_EQ(e.boxes_touching_no_object, 0) << name;
    EXPECT_EQ(e.objects_found, e.objects_seen) << name;
    EXPECT_GE(e.objects_seen, 3) << name;
  }
}

// A hover 3 m up turning on the spot: two posts thinner than a cell, a wall and a
// crate 3-7 m away, seen from nowhere farther. With the paper's 8 m d_min none of
// them reached the map; with 2 m the blur still erased the posts (one occupied
// cell between cells the rays beside them saw free) until a blur pass kept half
// of an occupied cell its neighbours would erase. The 1.2 m crate is lower than
// the ground band's 1.5 m: ground, by that rule.
TEST(FeatureScenarios, AHoverSeesThePostsAndTheWallBesideIt) {
  for (const std::uint64_t seed : {1u, 7u}) {
    const tools::Evaluation e = map_at_full_noise("hover-near", seed);
    for (const char* name : {"post_a", "post_b", "wall", "tree"}) {
      EXPECT_TRUE(detected(e, name)) << name << ", seed " << seed;
    }
    EXPECT_EQ(e.boxes_touching_no_object, 0) << "seed " << seed;
  }
}

// At half the noise a post seen from 3-6 m straddles fewer cells, one column of
// them: a frame's +1 kept a quarter of it through the blur (+1/8 where it spans
// two cells) against the frames that saw it free, and seed 7's post_a fell into
// fragments under min_cells. Within blur.keep_near_m it keeps half.
TEST(FeatureScenarios, AHoverSeesBothThinPostsAtHalfTheNoise) {
  const tools::Evaluation e = map_with_noise("hover-near", 7, 0.125, 0.02);
  for (const char* name : {"post_a", "post_b", "wall", "tree"}) {
    EXPECT_TRUE(detected(e, name)) << name;
  }
  EXPECT_EQ(e.boxes_touching_no_object, 0);
}

TEST(FeatureScenarios, BushesAndAircraftAllFound) {
  const ScenarioRun r = map_and_evaluate("bushes", 4.0, 4);
  EXPECT_EQ(r.evaluation.recall, 1.0);
  EXPECT_LE(r.evaluation.false_box_fraction, 0.05);
}

TEST(FeatureScenarios, TreeLineAllTreesFoundEachItsOwnBox) {
  const ScenarioRun r = map_and_evaluate("treeline", 2.0, 4);
  EXPECT_EQ(r.evaluation.recall, 1.0);
  EXPECT_LE(r.evaluation.false_box_fraction, 0.05);
  // The trees stand 7 m apart: the ground model keeps them apart.
  EXPECT_EQ(obstacles(r.boxes).size(), r.objects.size());
}

TEST(FeatureScenarios, OutAndBackKeepsEveryObstacle) {
  TempDir dir;
  const std::string sequence = dir / "seq";
  const std::string config = testing::write_test_scenario("out-and-back", sequence, 2.5, 4);
  tools::ReplayRun run;
  tools::ReplayOptions options = testing::quiet_replay(sequence, config);
  std::string error;
  ASSERT_TRUE(run.open(options, &error)) << error;
  const std::size_t half = run.sequence().frame_count() / 2;
  run.run_frames(0, half);  // out to x = 200 m
  run.extract_live_zones();
  const std::vector<ObstacleBox> outbound = run.boxes(false);
  run.run_frames(half, run.sequence().frame_count());  // and back
  run.finish();
  const std::vector<ObstacleBox> final_boxes = run.boxes(false);
  EXPECT_GT(run.stats().zones_discarded, 4) << "the route discards zones";
  EXPECT_GT(run.stats().feature_counters.cells_reintegrated, 0) << "and allocates them again";
  EXPECT_GE(outbound.size(), 4u);
  EXPECT_LE(final_boxes.size(), outbound.size()) << "the box count does not grow on the way back";
  const double cell = run.config().cell_size_m;
  for (const ObstacleBox& seen : outbound) {
    bool kept = false;
    for (const ObstacleBox& b : final_boxes) {
      kept = kept || ((seen.min.array() <= b.max.array() + cell).all() &&
                      (b.min.array() <= seen.max.array() + cell).all());
    }
    EXPECT_TRUE(kept) << "obstacle " << seen.id << " seen on the way out is still mapped";
  }
  EXPECT_EQ(run.stats().heap_allocations_after_init, 0);
}

// A car stands in the field for the first 3 s, then drives away: mapped while it
// stands (in its own box, down to the ground), forgotten once its place is seen
// free. The same car parked for the whole flight stays found.
TEST(FeatureScenarios, ACarThatDrivesOffIsForgottenAndAParkedOneKept) {
  const ScenarioRun parked = map_and_evaluate("parked-car", 5.0, 4);
  EXPECT_EQ(parked.evaluation.recall, 1.0) << "the car, the post and the shed";
  EXPECT_EQ(parked.evaluation.boxes_touching_no_object, 0);

  TempDir dir;
  const std::string sequence = dir / "seq";
  const std::string config = testing::write_test_scenario("crossing-car", sequence, 5.0, 4);
  tools::ReplayRun run;
  tools::ReplayOptions options = testing::quiet_replay(sequence, config);
  std::string error;
  ASSERT_TRUE(run.open(options, &error)) << error;
  run.run_frames(0, 15);  // 0-2.8 s: the car stands at x 36-41, y -2.25..2.25
  run.extract_live_zones();
  bool car_mapped = false;
  for (const ObstacleBox& b : run.boxes(false)) {
    car_mapped = car_mapped || (b.min.x() < 41.0 && b.max.x() > 36.0 && b.min.y() < 2.25 &&
                                b.max.y() > -2.25 && b.max.z() < 3.0);
  }
  EXPECT_TRUE(car_mapped) << "the standing car has a box";
  run.run_frames(15, run.sequence().frame_count());
  run.finish();
  EXPECT_GT(run.stats().feature_counters.features_removed, 0);
  EXPECT_TRUE(run.write_outputs(dir / "out", &error)) << error;
  std::vector<tools::TruthObject> objects;
  std::vector<tools::RunBox> boxes;
  ASSERT_TRUE(tools::load_objects_yaml(sequence + "/objects.yaml", &objects, &error)) << error;
  ASSERT_TRUE(tools::load_boxes_csv(dir / "out/boxes.csv", &boxes, &error)) << error;
  const tools::Evaluation e = tools::evaluate(objects, boxes, run.config().cell_size_m);
  std::printf("[ crossing-car ]\n%s", tools::to_table(e).c_str());
  EXPECT_EQ(e.moving_objects, 1);
  EXPECT_EQ(e.recall, 1.0) << "the post and the shed";
  EXPECT_LE(e.boxes_touching_no_object, 1) << "at most one box where the car stood";
  EXPECT_EQ(run.stats().frames_ground_below_environment, 0);
}

}  // namespace
}  // namespace zonemap
