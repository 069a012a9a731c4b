// A prior map (the paper's a-priori knowledge): read strictly (one bad row and the
// file is refused, naming file and line), in the map from the first frame, marked
// prior until a view finds it occupied, removed when views see its cells free.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "hal/config/prior_map.hpp"
#include "replay_support.hpp"
#include "test_support.hpp"
#include "tools/replay/replay_run.hpp"
#include "zonemap/common/geodetic.hpp"
#include "zonemap/features/feature_map.hpp"

namespace zonemap {
namespace {

using testing::TempDir;

constexpr const char* kHeader = "id,kind,xmin,ymin,zmin,xmax,ymax,zmax,cells,last_seen_s\n";

std::string write_prior(const TempDir& dir, const std::string& rows) {
  const std::string path = dir / "prior.csv";
  std::ofstream(path) << kHeader << rows;
  return path;
}

TEST(PriorMapFile, ReadsObstacleRowsAndSkipsGround) {
  TempDir dir;
  const std::string path =
      write_prior(dir,
                  "1,obstacle,-20,-0.25,0,-19.5,0.25,5,0,0\n2,ground,0,0,0,10,10,0.5,0,0\n"
                  "7,obstacle,1,2,3,4,5,6,12,3.5,0\n");
  hal::PriorMap map;
  std::string error;
  ASSERT_TRUE(hal::load_prior_map(path, true, &map, &error)) << error;
  ASSERT_EQ(map.boxes.size(), 2u);
  EXPECT_EQ(map.ground_rows_skipped, 1);
  EXPECT_EQ(map.boxes[0].min, Eigen::Vector3d(-20, -0.25, 0));
  EXPECT_EQ(map.boxes[1].max, Eigen::Vector3d(4, 5, 6));
  EXPECT_EQ(map.boxes[1].line, 4);
}

TEST(PriorMapFile, OneBadRowRefusesTheFileNamingItsLine) {
  TempDir dir;
  const std::pair<const char*, const char*> bad[] = {
      {"1,obstacle,0,0,0,1,1,nan,0,0\n", "prior.csv:2: a coordinate is not a number"},
      {"1,obstacle,0,0,0,1,1,5,0,0\n2,obstacle,0,0,0,1,x,5,0,0\n", "prior.csv:3: 'x' is not"},
      {"1,obstacle,5,0,0,1,1,5,0,0\n", "prior.csv:2: the box is inside out"},
      {"1,obstacle,0,0,0,1500,1,5,0,0\n", "prior.csv:2: the box is wider than 1 km"},
      {"1,obstacle,0,0,-1200,1,1,-1100,0,0\n", "prior.csv:2: the box reaches below -1 km"},
      {"1,obstacle,4e6,0,0,4e6,1,5,0,0\n", "over 1,000 km"},
      {"1,tree,0,0,0,1,1,5,0,0\n", "kind must be obstacle or ground"},
      {"1,obstacle,0,0,0,1,1\n", "prior.csv:2: expected id,kind"}};
  for (const auto& [rows, expected] : bad) {
    hal::PriorMap map;
    std::string error;
    EXPECT_FALSE(hal::load_prior_map(write_prior(dir, rows), true, &map, &error)) << rows;
    EXPECT_NE(error.find(expected), std::string::npos) << error;
    EXPECT_TRUE(map.boxes.empty()) << "never a partial prior";
  }
  std::ofstream(dir / "other.csv") << "x,y,z\n1,2,3\n";
  hal::PriorMap map;
  std::string error;
  EXPECT_FALSE(hal::load_prior_map(dir / "other.csv", true, &map, &error));
  EXPECT_NE(error.find("other.csv:1: not a boxes.csv"), std::string::npos) << error;
}

// A survey: obstacles by WGS84 position about the map's origin, NED (or NED turned
// about north for a z-up world).
TEST(PriorMapFile, ASurveyBecomesBoxesAboutTheOrigin) {
  TempDir dir;
  const Geodetic origin{48.1, 11.5, 520.0};
  const LocalTangentPlane plane(origin);
  const Geodetic base = plane.to_geodetic({100.0, 50.0, -1.0});  // 1 m above the origin
  char row[160];
  std::snprintf(row, sizeof row, "mast,%.9f,%.9f,%.4f,0.5,30\n", base.latitude_deg,
                base.longitude_deg, base.height_m);
  const std::string path = dir / "survey.csv";
  std::ofstream(path) << "# zonemap survey\norigin,48.1,11.5,520.0\n"
                      << "name,latitude_deg,longitude_deg,base_height_m,radius_m,height_m\n"
                      << row;
  hal::PriorMap ned, up;
  std::string error;
  ASSERT_TRUE(hal::load_prior_map(path, false, &ned, &error)) << error;
  ASSERT_EQ(ned.boxes.size(), 1u);
  EXPECT_TRUE(ned.boxes[0].min.isApprox(Eigen::Vector3d(99.5, 49.5, -31.0), 1e-6));
  EXPECT_TRUE(ned.boxes[0].max.isApprox(Eigen::Vector3d(100.5, 50.5, -1.0), 1e-6));
  EXPECT_EQ(ned.boxes[0].line, 4);
  ASSERT_TRUE(hal::load_prior_map(path, true, &up, &error)) << error;
  EXPECT_TRUE(up.boxes[0].min.isApprox(Eigen::Vector3d(99.5, -50.5, 1.0), 1e-6));
  EXPECT_TRUE(up.boxes[0].max.isApprox(Eigen::Vector3d(100.5, -49.5, 31.0), 1e-6));

  const std::pair<const char*, const char*> bad[] = {
      {"name,latitude_deg,longitude_deg,base_height_m,radius_m,height_m\n",
       "survey.csv:2: a survey first gives origin"},
      {"origin,95,11.5,520\n", "survey.csv:2: the origin is not a WGS84"},
      {"origin,48.1,11.5,520\nmast,48.1,11.5,520,0.5,30\n", "survey.csv:3: expected the header"},
      {"origin,48.1,11.5,520\nname,latitude_deg,longitude_deg,base_height_m,radius_m,height_m\n"
       "mast,48.1,11.5,520,0,30\n",
       "survey.csv:4: radius and height must be > 0"},
      {"origin,48.1,11.5,520\nname,latitude_deg,longitude_deg,base_height_m,radius_m,height_m\n"
       "mast,48.1,191,520,1,30\n",
       "survey.csv:4: not a WGS84"},
      {"", "a survey without its origin"}};
  for (const auto& [rows, expected] : bad) {
    std::ofstream(path) << "# zonemap survey\n" << rows;
    hal::PriorMap map;
    EXPECT_FALSE(hal::load_prior_map(path, false, &map, &error)) << rows;
    EXPECT_NE(error.find(expected), std::string::npos) << error;
    EXPECT_TRUE(map.boxes.empty());
  }
}

TEST(PriorMap, ABoxAcrossAZoneFaceIsOneBoxInTheOutputMarkedPrior) {
  MapConfig config;  // 1 m cells, zones of 80 x 80 x 10
  FeatureMap features(config, true);
  ASSERT_TRUE(features.add_prior({78.5, 10, 0}, {81.5, 12, 5}));  // across x = 80
  EXPECT_EQ(features.counters().priors_added, 2);
  ObstacleBox out[4];
  ASSERT_EQ(features.merged(out, 4, false), 1u);
  EXPECT_TRUE(out[0].prior);
  EXPECT_EQ(out[0].min, Eigen::Vector3d(78, 10, 0));
  EXPECT_EQ(out[0].max, Eigen::Vector3d(82, 12, 5));
}

TEST(PriorMap, WhenTheStoreIsFullTheLeastRelevantPiecesAreCountedOut) {
  MapConfig config;
  config.features.capacity = 2;
  FeatureMap features(config, true);
  features.set_context(0.0, Eigen::Vector3d::Zero());
  EXPECT_TRUE(features.add_prior({10, 10, 0}, {11, 11, 5}));
  EXPECT_TRUE(features.add_prior({20, 20, 0}, {21, 21, 5}));
  // A third as large but farther: the least relevant, not stored.
  EXPECT_FALSE(features.add_prior({300, 300, 0}, {301, 301, 5}));
  EXPECT_EQ(features.counters().priors_dropped, 1);
  // A larger one nearby outranks the farthest stored one, which is evicted.
  EXPECT_TRUE(features.add_prior({5, 5, 0}, {9, 9, 8}));
  EXPECT_EQ(features.counters().features_evicted, 1);
  EXPECT_EQ(features.count(), 2u);
}

// The posts flown through (posts at x 40, y +-3.5; the flight from x 0 to 55): a
// post 20 m behind the start the camera never sees, a box standing in the open
// space the camera looks across, and a box on post_a.
TEST(PriorMap, AnUnseenPostStaysPriorOneSeenFreeGoesOneOnAPostIsConfirmed) {
  TempDir dir;
  const std::string sequence = dir / "seq";
  const std::string config = testing::write_test_scenario("posts-through", sequence, 10.0, 4);
  ASSERT_FALSE(config.empty());
  tools::ReplayOptions options = testing::quiet_replay(sequence, config);
  options.prior_path = write_prior(dir,
                                   "1,obstacle,-20,-0.25,0,-19.5,0.25,5,0,0\n"
                                   "2,obstacle,25,-1,0,26,1,5,0,0\n"
                                   "3,obstacle,39.75,-3.75,0,40.25,-3.25,5,0,0\n");
  tools::ReplayRun run;
  std::string error;
  ASSERT_TRUE(run.open(options, &error)) << error;
  run.run_frames(0, 1);
  run.extract_live_zones();
  // From the first update: all three, the unseen one and the open-space one prior.
  int prior_boxes = 0;
  for (const ObstacleBox& b : run.boxes(false)) prior_boxes += b.prior ? 1 : 0;
  EXPECT_GE(prior_boxes, 2);
  run.run_frames(1, run.sequence().frame_count());
  run.finish();
  const FeatureCounters& c = run.stats().feature_counters;
  EXPECT_EQ(c.priors_added, 5);  // 2 + 2 + 1 pieces: two boxes span the zone face y = 0
  EXPECT_GE(c.priors_removed, 2);
  EXPECT_EQ(c.priors_confirmed, 1);
  EXPECT_EQ(run.stats().heap_allocations_after_init, 0);
  int unseen = 0, on_post = 0, in_the_open = 0, obstacles = 0;
  for (const ObstacleBox& b : run.boxes(false)) {
    ++obstacles;
    const Eigen::Vector3d centre = (b.min + b.max) / 2;
    if (centre.x() < -10) unseen += b.prior ? 1 : 100;
    if (std::abs(centre.x() - 25.5) < 3 && std::abs(centre.y()) < 3) ++in_the_open;
    if (std::abs(centre.x() - 40) < 1.5 && std::abs(centre.y() + 3.5) < 1.5) {
      on_post += b.prior ? 100 : 1;
    }
  }
  EXPECT_EQ(unseen, 1) << "the unseen post stays, marked prior";
  EXPECT_EQ(in_the_open, 0) << "the box the views saw free is gone";
  EXPECT_EQ(on_post, 1) << "post_a: one box, confirmed";
  EXPECT_EQ(obstacles, 3) << "the unseen post and the two real posts";
}

// The map outlives the flight: a second replay of the same flight with the first
// one's boxes.csv as its prior holds the same obstacle boxes (within a cell) from
// its first frame, and ends with them too, none still marked prior.
TEST(PriorMap, ASecondFlightWithTheFirstsMapHasItsBoxesFromTheFirstFrame) {
  TempDir dir;
  const std::string sequence = dir / "seq";
  const std::string config = testing::write_test_scenario("posts-through", sequence, 10.0, 4);
  ASSERT_FALSE(config.empty());
  std::string error;
  tools::ReplayRun first;
  ASSERT_TRUE(first.open(testing::quiet_replay(sequence, config), &error)) << error;
  first.run();
  ASSERT_TRUE(first.write_outputs(dir / "first", &error)) << error;
  EXPECT_FALSE(std::filesystem::exists(dir / "first/boxes.csv.tmp"));
  const std::vector<ObstacleBox> saved = first.boxes(false);
  ASSERT_EQ(saved.size(), 2u);

  tools::ReplayOptions options = testing::quiet_replay(sequence, config);
  options.prior_path = dir / "first/boxes.csv";
  tools::ReplayRun second;
  ASSERT_TRUE(second.open(options, &error)) << error;
  const double cell = second.config().cell_size_m;
  const auto same_boxes = [&](const std::vector<ObstacleBox>& boxes, const char* when) {
    ASSERT_EQ(boxes.size(), saved.size()) << when;
    for (const ObstacleBox& want : saved) {
      bool found = false;
      for (const ObstacleBox& got : boxes) {
        found |= (got.min - want.min).cwiseAbs().maxCoeff() <= cell + 1e-9 &&
                 (got.max - want.max).cwiseAbs().maxCoeff() <= cell + 1e-9;
      }
      EXPECT_TRUE(found) << when << ": no box within a cell of " << want.min.transpose() << " - "
                         << want.max.transpose();
    }
  };
  same_boxes(second.boxes(false), "before the first frame");
  second.run_frames(0, 1);
  second.extract_live_zones();
  same_boxes(second.boxes(false), "after the first frame");
  second.run_frames(1, second.sequence().frame_count());
  second.finish();
  const std::vector<ObstacleBox> last = second.boxes(false);
  same_boxes(last, "at the end");
  for (const ObstacleBox& b : last) EXPECT_FALSE(b.prior) << "both posts were seen";
}

}  // namespace
}  // namespace zonemap
