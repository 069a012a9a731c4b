// The feature map (paper §IV): flood fill, boxes, quadtree footprints, ground
// split, re-integration, cross-zone merge, store policy (no allocation:
// tests/test_core_allocations.cpp).
#include <gtest/gtest.h>

#include <algorithm>

#include <vector>

#include "features/feature_test_zone.hpp"
#include "tools/sim/scene.hpp"
#include "zonemap/containers/quadtree.hpp"
#include "zonemap/containers/window_min.hpp"
#include "zonemap/features/feature_map.hpp"

namespace zonemap {
namespace {

using testing::feature_config;
using testing::TestZone;

std::vector<const Feature*> features_of(const FeatureMap& map, FeatureKind kind) {
  std::vector<const Feature*> out;
  for (const Feature* f = map.begin(); f != map.end(); ++f)
    if (f->in_use && f->kind == kind) out.push_back(f);
  return out;
}

// --- quadtree -------------------------------------------------------------------

// --- extraction -----------------------------------------------------------------

TEST(FeatureExtraction, SixConnectivityNotDiagonals) {
  const std::array<int, 3> dims = {8, 8, 8};
  FeatureMap map(feature_config(dims, false), true);
  TestZone zone(dims, {0, 0, 0});
  // Two cells sharing a face: one object.
  zone.set(1, 1, 1);
  zone.set(2, 1, 1);
  // Two cells sharing only an edge: two objects (26-connectivity would join them).
  zone.set(5, 5, 1);
  zone.set(6, 6, 1);
  // Sharing only a corner: two more.
  zone.set(1, 5, 5);
  zone.set(2, 6, 6);
  map.extract(zone.view);
  const auto objects = features_of(map, FeatureKind::kObstacle);
  ASSERT_EQ(objects.size(), 5u);
  int pairs = 0;
  for (const Feature* f : objects) {
    if (f->cells == 2) {
      ++pairs;
      EXPECT_EQ(f->min, (CellIndex{1, 1, 1}));
      EXPECT_EQ(f->max, (CellIndex{2, 1, 1}));
    } else {
      EXPECT_EQ(f->cells, 1);
    }
  }
  EXPECT_EQ(pairs, 1);
}

TEST(FeatureExtraction, BoxAndFootprintOfAnLShape) {
  const std::array<int, 3> dims = {10, 10, 6};
  FeatureMap map(feature_config(dims, false), true);
  TestZone zone(dims, {2, -1, 0});  // world cells x 20..29, y -10..-1
  for (int z = 1; z <= 3; ++z) {
    for (int x = 2; x <= 6; ++x) zone.set(x, 2, z);
    for (int y = 3; y <= 5; ++y) zone.set(2, y, z);
  }
  map.extract(zone.view);
  const auto objects = features_of(map, FeatureKind::kObstacle);
  ASSERT_EQ(objects.size(), 1u);
  const Feature& f = *objects[0];
  EXPECT_EQ(f.cells, 3 * (5 + 3));
  EXPECT_EQ(f.min, (CellIndex{22, -8, 1}));
  EXPECT_EQ(f.max, (CellIndex{26, -5, 3}));
  EXPECT_TRUE(f.has_shape);
  EXPECT_TRUE(map.feature_contains(f, {22, -8, 2}));
  EXPECT_TRUE(map.feature_contains(f, {26, -8, 2}));
  EXPECT_TRUE(map.feature_contains(f, {22, -5, 3}));
  EXPECT_FALSE(map.feature_contains(f, {25, -6, 2})) << "inside the box, outside the L";
  EXPECT_FALSE(map.feature_contains(f, {22, -8, 4})) << "above the box";
}

TEST(FeatureExtraction, PostOnAPlaneIsOneObstacleAndGround) {
  const std::array<int, 3> dims = {30, 30, 12};
  FeatureMap map(feature_config(dims, true), true);
  TestZone zone(dims, {0, 0, 0});
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 30; ++x) {
      zone.set(x, y, 2);                                            // the field
      for (int z = 3; z < 12; ++z) zone.set(x, y, z, -kCellScale);  // free air above
    }
  for (int z = 3; z <= 9; ++z) zone.set(15, 12, z);  // a post
  map.extract(zone.view);
  const auto obstacles = features_of(map, FeatureKind::kObstacle);
  const auto ground = features_of(map, FeatureKind::kGround);
  ASSERT_EQ(obstacles.size(), 1u);
  ASSERT_EQ(ground.size(), 1u);
  EXPECT_EQ(obstacles[0]->min.x, 15);
  EXPECT_EQ(obstacles[0]->max.x, 15);
  EXPECT_EQ(obstacles[0]->min.y, 12);
  EXPECT_EQ(obstacles[0]->max.y, 12);
  EXPECT_EQ(obstacles[0]->min.z, 2) << "reaches into the terrain cell (z = 2), where the ground is";
  EXPECT_EQ(obstacles[0]->max.z, 9);
  EXPECT_EQ(ground[0]->min, (CellIndex{0, 0, 2}));
  EXPECT_EQ(ground[0]->max, (CellIndex{29, 29, 3}));
}

TEST(FeatureExtraction, APostWhoseFootTheTrimTookStillStandsOnTheGround) {
  // The trim takes a thin thing's lowest cells beside a saturated ground for the
  // ground's halo: a post whose cells start two cells above the field still
  // stands on it (its box reaches the terrain cell); a sign four cells above the
  // field hangs in the air.
  const std::array<int, 3> dims = {30, 30, 14};
  FeatureMap map(feature_config(dims, true), true);
  TestZone zone(dims, {0, 0, 0});
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 30; ++x) {
      zone.set(x, y, 2);  // the field
      for (int z = 3; z < 14; ++z) zone.set(x, y, z, -kCellScale);
    }
  for (int z = 5; z <= 10; ++z) zone.set(8, 8, z);   // the post, z 3 and 4 trimmed
  for (int z = 7; z <= 9; ++z) zone.set(20, 20, z);  // the sign
  map.extract(zone.view);
  const auto obstacles = features_of(map, FeatureKind::kObstacle);
  ASSERT_EQ(obstacles.size(), 2u);
  for (const Feature* f : obstacles) {
    if (f->min.x == 8) {
      EXPECT_EQ(f->min.z, 2) << "down into the terrain cell";
    } else {
      EXPECT_EQ(f->min.z, 7) << "the sign stays where it is";
    }
  }
}

// A field whose ground band stereo smeared 4 cells thick (z 2..5), under free
// air, with a post standing on it.
TestZone thick_band_field(const std::array<int, 3>& dims) {
  TestZone zone(dims, {0, 0, 0});
  for (int y = 0; y < dims[1]; ++y)
    for (int x = 0; x < dims[0]; ++x) {
      for (int z = 2; z <= 5; ++z) zone.set(x, y, z);
      for (int z = 6; z < dims[2]; ++z) zone.set(x, y, z, -kCellScale);
    }
  for (int z = 6; z <= 11; ++z) zone.set(15, 12, z);
  return zone;
}

// The ground band measured (up to 6 cells), over the 1-cell thickness.
MapConfig measured_band_config(const std::array<int, 3>& dims) {
  MapConfig config = feature_config(dims, true);
  config.features.ground_band_percentile = 0.3;
  config.features.ground_max_thickness_m = 6.0;
  return config;
}

TEST(FeatureGround, AThickBandIsAllObstacleWithTheThicknessAlone) {
  const std::array<int, 3> dims = {30, 30, 14};
  FeatureMap map(feature_config(dims, true), true);
  TestZone zone = thick_band_field(dims);
  map.extract(zone.view);
  const auto obstacles = features_of(map, FeatureKind::kObstacle);
  ASSERT_EQ(obstacles.size(), 1u) << "the band's top and the post are one object";
  EXPECT_EQ(obstacles[0]->max.x - obstacles[0]->min.x, 29) << "it spans the field";
}

TEST(FeatureGround, AMeasuredBandIsGroundAndThePostStandsOnIt) {
  const std::array<int, 3> dims = {30, 30, 14};
  FeatureMap map(measured_band_config(dims), true);
  TestZone zone = thick_band_field(dims);
  map.extract(zone.view);
  const auto obstacles = features_of(map, FeatureKind::kObstacle);
  ASSERT_EQ(obstacles.size(), 1u);
  EXPECT_EQ(obstacles[0]->min, (CellIndex{15, 12, 2})) << "down into the terrain cell (z = 2)";
  EXPECT_EQ(obstacles[0]->max, (CellIndex{15, 12, 11}));
  ASSERT_EQ(features_of(map, FeatureKind::kGround).size(), 1u);
  EXPECT_EQ(features_of(map, FeatureKind::kGround)[0]->max.z, 6)
      << "the band, and the post's foot within its cell of scatter";
}

// The band's counts are kept modulo 2^16: past 65536 columns the tables wrap,
// and a window's count must still come out exact (here at the far corner, where
// the corners' sums are largest).
TEST(FeatureGround, AMeasuredBandHoldsInAZoneOfMoreThan65536Columns) {
  const std::array<int, 3> dims = {272, 248, 14};  // 67,456 columns
  FeatureMap map(measured_band_config(dims), true);
  TestZone zone = thick_band_field(dims);
  for (int z = 6; z <= 11; ++z) zone.set(260, 240, z);
  map.extract(zone.view);
  const auto obstacles = features_of(map, FeatureKind::kObstacle);
  ASSERT_EQ(obstacles.size(), 2u);
  for (const Feature* post : obstacles) {
    EXPECT_EQ(post->min.z, 2) << "down into the terrain cell (z = 2)";
    EXPECT_EQ(post->max.z, 11);
  }
  ASSERT_EQ(features_of(map, FeatureKind::kGround).size(), 1u);
  EXPECT_EQ(features_of(map, FeatureKind::kGround)[0]->max.z, 6);
}

TEST(FeatureGround, AThingCutByTheZonesBottomIsNoBand) {
  // A field at z = 0 for x < 8; beside it a hut 5 cells tall that the zone's
  // bottom face cuts (its ground lies in the zone below). Too small to be a
  // surface, its columns borrow the field's terrain; their runs are the hut, not
  // a band: measured as one, they made the whole hut ground.
  const std::array<int, 3> dims = {30, 30, 12};
  FeatureMap map(measured_band_config(dims), true);
  TestZone zone(dims, {0, 0, 0});
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 30; ++x)
      for (int z = 0; z < 12; ++z) zone.set(x, y, z, -kCellScale);
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 8; ++x) zone.set(x, y, 0);
  for (int y = 13; y <= 15; ++y)
    for (int x = 11; x <= 13; ++x)
      for (int z = 0; z <= 4; ++z) zone.set(x, y, z);
  map.extract(zone.view);
  const auto obstacles = features_of(map, FeatureKind::kObstacle);
  ASSERT_EQ(obstacles.size(), 1u) << "the hut";
  EXPECT_EQ(obstacles[0]->min, (CellIndex{11, 13, 0}));
  EXPECT_EQ(obstacles[0]->max, (CellIndex{13, 15, 4}));
}

TEST(FeatureGround, RunsOfMixedHeightsAreNotABand) {
  // A thin field (z = 2) and a row of bushes 3 cells tall (x 11..13): every window
  // holding bushes holds field too, so its runs spread and the thickness holds.
  const std::array<int, 3> dims = {30, 30, 10};
  FeatureMap map(measured_band_config(dims), true);
  TestZone zone(dims, {0, 0, 0});
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 30; ++x) {
      zone.set(x, y, 2);
      for (int z = 3; z < 10; ++z) zone.set(x, y, z, -kCellScale);
    }
  for (int y = 0; y < 30; ++y)
    for (int x = 11; x <= 13; ++x)
      for (int z = 3; z <= 5; ++z) zone.set(x, y, z);
  map.extract(zone.view);
  const auto obstacles = features_of(map, FeatureKind::kObstacle);
  ASSERT_EQ(obstacles.size(), 1u);
  EXPECT_EQ(obstacles[0]->min, (CellIndex{11, 0, 2}));
  EXPECT_EQ(obstacles[0]->max, (CellIndex{13, 29, 5}));
}

TEST(FeatureGround, TheRimOfARisingSlopeIsGround) {
  // A slope rising a cell every four columns (x <= 29), and beyond it the rim of
  // what was seen: columns under free air where only three rows (y 10..12) hold
  // the ground at x = 31, too few for a surface. The rim borrows the terrain of
  // the slope beside it (one window radius); the lowest within three radii lies
  // a cell lower on the slope, and the rim's ground stood out as an obstacle.
  const std::array<int, 3> dims = {40, 30, 16};
  FeatureMap map(feature_config(dims, true), true);
  TestZone zone(dims, {0, 0, 0});
  const auto ground_z = [](int x) { return x / 4; };
  for (int y = 0; y < 30; ++y) {
    for (int x = 0; x <= 29; ++x) {
      zone.set(x, y, ground_z(x));
      for (int z = ground_z(x) + 1; z < 16; ++z) zone.set(x, y, z, -kCellScale);
    }
    for (int x = 30; x <= 35; ++x) {
      const bool seen_ground = x == 31 && y >= 10 && y <= 12;
      for (int z = 0; z < 16; ++z) zone.set(x, y, z, -kCellScale);
      if (seen_ground) zone.set(x, y, ground_z(x));
    }
  }
  map.extract(zone.view);
  EXPECT_EQ(features_of(map, FeatureKind::kObstacle).size(), 0u);
  EXPECT_FALSE(features_of(map, FeatureKind::kGround).empty());
}

TEST(FeatureExtraction, ThingInFreeSpaceIsNotGround) {
  // A crown cut by the zone's bottom face: low, but surrounded by free air, so
  // not a surface (it fills 16 of the 121 columns of a 10 m window); it stays an
  // obstacle.
  const std::array<int, 3> dims = {30, 30, 12};
  MapConfig config = feature_config(dims, true);
  config.features.ground_window_m = 10.0;
  FeatureMap map(config, true);
  TestZone zone(dims, {0, 0, 1});
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 30; ++x)
      for (int z = 0; z < 12; ++z) zone.set(x, y, z, -kCellScale);
  for (int y = 10; y < 14; ++y)
    for (int x = 10; x < 14; ++x)
      for (int z = 0; z < 3; ++z) zone.set(x, y, z);
  map.extract(zone.view);
  EXPECT_EQ(features_of(map, FeatureKind::kGround).size(), 0u);
  ASSERT_EQ(features_of(map, FeatureKind::kObstacle).size(), 1u);
  EXPECT_EQ(features_of(map, FeatureKind::kObstacle)[0]->cells, 4 * 4 * 3);
}

TEST(FeatureExtraction, ReExtractionUpdatesInsteadOfDuplicating) {
  const std::array<int, 3> dims = {10, 10, 6};
  FeatureMap map(feature_config(dims, false), true);
  TestZone zone(dims, {0, 0, 0});
  for (int x = 2; x <= 4; ++x) zone.set(x, 2, 2);
  map.set_context(1.0, {0, 0, 0});
  map.extract(zone.view);
  ASSERT_EQ(map.count(), 1u);
  const std::uint32_t id =
      map.begin()->id == 0 ? 0 : features_of(map, FeatureKind::kObstacle)[0]->id;
  zone.set(5, 2, 2);  // the object grew
  map.set_context(2.0, {0, 0, 0});
  map.extract(zone.view);
  const auto objects = features_of(map, FeatureKind::kObstacle);
  ASSERT_EQ(objects.size(), 1u);
  EXPECT_EQ(objects[0]->id, id) << "stable id";
  EXPECT_EQ(objects[0]->cells, 4);
  EXPECT_EQ(objects[0]->first_seen_s, 1.0);
  EXPECT_EQ(objects[0]->last_seen_s, 2.0);
  EXPECT_EQ(map.counters().features_updated, 1);
  // The grid no longer holds it (free evidence cleared it): the feature goes.
  std::fill(zone.cells.begin(), zone.cells.end(), FusedCell{0});
  map.extract(zone.view);
  EXPECT_EQ(map.count(), 0u);
  EXPECT_EQ(map.counters().features_removed, 1);
  EXPECT_EQ(map.shapes().groups_free(), map.shapes().groups_total());
}

TEST(FeatureExtraction, LastSeenMovesOnlyWhileTheObjectIsInView) {
  const std::array<int, 3> dims = {20, 20, 6};
  MapConfig config = feature_config(dims, false);
  config.d_max_m = 30.0;
  FeatureMap map(config, true);
  CameraModel camera;
  camera.width = 64;
  camera.height = 48;
  camera.fx = camera.fy = 40.0;
  camera.cx = 31.5;
  camera.cy = 23.5;
  map.set_camera(camera);
  TestZone zone(dims, {0, 0, 0});
  for (int x = 14; x <= 16; ++x) zone.set(x, 10, 2);  // 14-17 m along x
  const Eigen::Vector3d from(2.0, 10.5, 2.5);
  map.set_context(1.0, sim::look_pose(from, 0.0, 0.0));  // looking at it along +x
  map.extract(zone.view);
  ASSERT_EQ(map.count(), 1u);
  EXPECT_EQ(map.begin()->last_seen_s, 1.0);
  map.set_context(2.0, sim::look_pose(from, 3.14159, 0.0));  // turned away
  map.extract(zone.view);
  const Feature* f = features_of(map, FeatureKind::kObstacle)[0];
  EXPECT_EQ(f->last_seen_s, 1.0) << "still held, not seen";
  map.set_context(3.0, sim::look_pose(from, 0.1, 0.0));  // its edge of the image
  map.extract(zone.view);
  EXPECT_EQ(f->last_seen_s, 3.0);
  map.set_context(4.0, sim::look_pose(Eigen::Vector3d(-20.0, 10.5, 2.5), 0.0, 0.0));
  map.extract(zone.view);
  EXPECT_EQ(f->last_seen_s, 3.0) << "beyond d_max";
  ObstacleBox box;
  ASSERT_EQ(map.merged(&box, 1, false), 1u);
  EXPECT_EQ(box.first_seen_s, 1.0);
  EXPECT_EQ(box.last_seen_s, 3.0);
}

TEST(FeatureExtraction, SmallObjectsAreCountedAsNoise) {
  const std::array<int, 3> dims = {10, 10, 6};
  MapConfig config = feature_config(dims, false);
  config.features.min_cells = 3;
  FeatureMap map(config, true);
  TestZone zone(dims, {0, 0, 0});
  zone.set(1, 1, 1);
  for (int x = 4; x <= 6; ++x) zone.set(x, 4, 4);
  map.extract(zone.view);
  EXPECT_EQ(map.count(), 1u);
  EXPECT_EQ(map.counters().objects_too_small, 1);
}

// --- re-integration (§IV-B) -----------------------------------------------------

// Two columns 4 cells apart, joined by a low bridge of weaker cells (what the
// blur and far views leave between trees of a line): two objects, split through
// the bridge; the paper's extraction (split_touching off) gives one.
void two_columns_and_a_bridge(TestZone* zone, FusedCell bridge) {
  for (int z = 0; z < 6; ++z) {
    for (int x = 2; x <= 3; ++x) {
      for (int y = 2; y <= 3; ++y) zone->set(x, y, z, 30 * kCellScale);  // column A
      for (int y = 8; y <= 9; ++y) zone->set(x, y, z, 20 * kCellScale);  // column B, weaker
    }
  }
  for (int y = 4; y <= 7; ++y) zone->set(2, y, 1, bridge);
}

TEST(FeatureSplit, ObjectsJoinedThroughAValueDipAreSplitThroughIt) {
  const std::array<int, 3> dims = {12, 12, 8};
  for (const bool split : {true, false}) {
    TestZone zone(dims, {0, 0, 0});
    two_columns_and_a_bridge(&zone, 3 * kCellScale);
    MapConfig config = feature_config(dims, false);
    config.features.split_touching = split;
    FeatureMap map(config, true);
    map.extract(zone.view);
    const auto objects = features_of(map, FeatureKind::kObstacle);
    if (!split) {
      ASSERT_EQ(objects.size(), 1u);
      EXPECT_EQ(objects[0]->cells, 2 * 24 + 4);
      continue;
    }
    ASSERT_EQ(objects.size(), 2u);
    EXPECT_EQ(map.counters().objects_split, 1);
    EXPECT_EQ(objects[0]->cells + objects[1]->cells, 2 * 24 + 4) << "every cell in one of them";
    for (const Feature* f : objects) {
      // Each box holds one column and at most the bridge's half on its side.
      EXPECT_EQ(f->max.y - f->min.y, 3) << f->min.y << ".." << f->max.y;
      EXPECT_EQ(f->min.x, 2);
      EXPECT_EQ(f->max.x, 3);
    }
  }
}

TEST(FeatureSplit, OneObjectWithoutADipStaysWhole) {
  // The same cells at one value: no part rises apart, nothing to split.
  const std::array<int, 3> dims = {12, 12, 8};
  TestZone zone(dims, {0, 0, 0});
  two_columns_and_a_bridge(&zone, 20 * kCellScale);
  for (int z = 0; z < 6; ++z)
    for (int x = 2; x <= 3; ++x)
      for (int y = 2; y <= 3; ++y) zone.set(x, y, z, 20 * kCellScale);
  FeatureMap map(feature_config(dims, false), true);
  map.extract(zone.view);
  const auto objects = features_of(map, FeatureKind::kObstacle);
  ASSERT_EQ(objects.size(), 1u);
  EXPECT_EQ(map.counters().objects_split, 0);
  EXPECT_EQ(objects[0]->min.y, 2);
  EXPECT_EQ(objects[0]->max.y, 9);
}

TEST(FeatureSplit, NeighboursPartWhereTheyDipNotHalfwayBetweenTheirCores) {
  // Along y: A's narrow peak (y 2) and its long high body (y 3-9), a valley
  // (y 10-11), B (y 12-13). Halfway between the cores (y 2, y 12) would give B
  // A's far body; flooded down the column peaks, each keeps its side of the valley.
  const std::array<int, 3> dims = {12, 16, 8};  // levels kept for 1/16 of the cells
  TestZone zone(dims, {0, 0, 0});
  const auto level_at = [](int y) {
    if (y == 2) return 40;
    if (y <= 9) return 30;
    if (y <= 11) return 10;
    return 25;
  };
  for (int z = 0; z < 4; ++z)
    for (int x = 2; x <= 3; ++x)
      for (int y = 2; y <= 13; ++y)
        zone.set(x, y, z, static_cast<FusedCell>(level_at(y) * kCellScale));
  MapConfig config = feature_config(dims, false);
  config.features.split_touching = true;
  FeatureMap map(config, true);
  map.extract(zone.view);
  auto objects = features_of(map, FeatureKind::kObstacle);
  ASSERT_EQ(objects.size(), 2u);
  std::sort(objects.begin(), objects.end(),
            [](const Feature* a, const Feature* b) { return a->min.y < b->min.y; });
  EXPECT_EQ(objects[0]->min.y, 2);
  EXPECT_EQ(objects[0]->max.y, 10) << "A keeps its body and its half of the valley";
  EXPECT_EQ(objects[1]->min.y, 11);
  EXPECT_EQ(objects[1]->max.y, 13);
}

TEST(FeatureSplit, ASpeckAboveTheRestIsNotACore) {
  // One block of 27 cells with two single hot cells in it: fewer than
  // core_min_cells, so no split into specks.
  const std::array<int, 3> dims = {12, 12, 8};
  TestZone zone(dims, {0, 0, 0});
  for (int x = 3; x < 6; ++x)
    for (int y = 3; y < 6; ++y)
      for (int z = 0; z < 3; ++z) zone.set(x, y, z, 10 * kCellScale);
  zone.set(3, 3, 0, 40 * kCellScale);
  zone.set(5, 5, 2, 40 * kCellScale);
  FeatureMap map(feature_config(dims, false), true);
  map.extract(zone.view);
  EXPECT_EQ(features_of(map, FeatureKind::kObstacle).size(), 1u);
  EXPECT_EQ(map.counters().objects_split, 0);
}

TEST(FeatureReintegration, ExactlyTheShapeCellsBecomeOccupied) {
  const std::array<int, 3> dims = {10, 10, 6};
  MapConfig config = feature_config(dims, false);
  FeatureMap map(config, true);
  TestZone zone(dims, {1, 0, 0});
  for (int z = 1; z <= 3; ++z) {
    for (int x = 2; x <= 6; ++x) zone.set(x, 2, z);
    for (int y = 3; y <= 5; ++y) zone.set(2, y, z);
  }
  map.extract(zone.view);
  TestZone fresh(dims, {1, 0, 0});  // the zone allocated again, cleared
  map.on_zone_allocated(fresh.view);
  const FusedCell high = static_cast<FusedCell>(to_fixed(4.0f));
  for (int z = 0; z < 6; ++z)
    for (int y = 0; y < 10; ++y)
      for (int x = 0; x < 10; ++x) {
        const bool in_shape =
            z >= 1 && z <= 3 && ((y == 2 && x >= 2 && x <= 6) || (x == 2 && y >= 3 && y <= 5));
        ASSERT_EQ(fresh.at(x, y, z), in_shape ? high : 0) << x << "," << y << "," << z;
      }
  EXPECT_EQ(map.counters().cells_reintegrated, 24);
  // Another zone gets nothing.
  TestZone other(dims, {2, 0, 0});
  map.on_zone_allocated(other.view);
  for (FusedCell c : other.cells) ASSERT_EQ(c, 0);
}

// --- merge across zones ---------------------------------------------------------

TEST(FeatureMerge, ObjectCutByAZoneFaceIsOneBox) {
  const std::array<int, 3> dims = {10, 10, 6};
  FeatureMap map(feature_config(dims, false), true);
  TestZone left(dims, {0, 0, 0});
  TestZone right(dims, {1, 0, 0});
  for (int z = 1; z <= 2; ++z) {
    for (int x = 7; x <= 9; ++x) left.set(x, 4, z);   // world x 7..9
    for (int x = 0; x <= 1; ++x) right.set(x, 4, z);  // world x 10..11
  }
  left.set(2, 8, 1);  // a separate object in the left zone
  left.set(3, 8, 1);
  map.extract(left.view);
  map.extract(right.view);
  EXPECT_EQ(map.count(), 3u) << "storage stays per zone";
  std::vector<ObstacleBox> boxes(8);
  const std::size_t n = map.merged(boxes.data(), boxes.size(), false);
  ASSERT_EQ(n, 2u);
  const ObstacleBox& joined = boxes[0].parts == 2 ? boxes[0] : boxes[1];
  EXPECT_EQ(joined.parts, 2);
  EXPECT_EQ(joined.cells, 10);
  EXPECT_DOUBLE_EQ(joined.min.x(), 7.0);
  EXPECT_DOUBLE_EQ(joined.max.x(), 12.0);
  EXPECT_DOUBLE_EQ(joined.min.z(), 1.0);
  EXPECT_DOUBLE_EQ(joined.max.z(), 3.0);
}

TEST(FeatureMerge, APostInTwoPartsOneAboveTheOtherIsOneBox) {
  // A post whose middle the halo trim took for the halo of its stronger ends
  // comes out of extraction as two parts in one zone, one above the other: two
  // cells apart, one box; a thing four cells above another is its own.
  const std::array<int, 3> dims = {20, 20, 16};
  FeatureMap map(feature_config(dims, false), true);
  TestZone zone(dims, {0, 0, 0});
  for (int z = 1; z <= 4; ++z) zone.set(5, 5, z);    // the post's foot
  for (int z = 7; z <= 10; ++z) zone.set(5, 5, z);   // its top, z 5 and 6 trimmed
  for (int z = 1; z <= 3; ++z) zone.set(14, 5, z);   // a pole
  for (int z = 8; z <= 10; ++z) zone.set(14, 5, z);  // a lamp four cells above it
  map.extract(zone.view);
  ASSERT_EQ(map.count(), 4u);
  std::vector<ObstacleBox> boxes(8);
  const std::size_t n = map.merged(boxes.data(), boxes.size(), false);
  ASSERT_EQ(n, 3u);
  int posts = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (boxes[i].min.x() != 5.0) continue;
    ++posts;
    EXPECT_EQ(boxes[i].parts, 2);
    EXPECT_DOUBLE_EQ(boxes[i].min.z(), 1.0);
    EXPECT_DOUBLE_EQ(boxes[i].max.z(), 11.0);
  }
  EXPECT_EQ(posts, 1);
}

// --- store policy ---------------------------------------------------------------

// A feature the extraction does not find again goes, and its counter says why:
// its cells seen free, its cells now part of another obstacle, or its cells
// still occupied but no obstacle's (here: too few to be one).
TEST(FeatureStore, EveryRemovalIsCountedByWhatTheGridHoldsWhereItStood) {
  const std::array<int, 3> dims = {12, 12, 8};
  MapConfig config = feature_config(dims, false);
  config.features.min_cells = 3;
  FeatureMap map(config, true);
  TestZone zone(dims, {0, 0, 0});
  for (int z = 0; z < 4; ++z) zone.set(1, 1, z);  // a post of 4 cells
  for (int z = 0; z < 4; ++z) {                   // two more, two cells apart
    zone.set(5, 5, z);
    zone.set(8, 5, z);
  }
  for (int z = 0; z < 4; ++z) zone.set(10, 10, z);  // a fourth post
  map.extract(zone.view);
  ASSERT_EQ(map.count(FeatureKind::kObstacle), 4u);

  for (int z = 0; z < 4; ++z) zone.set(1, 1, z, 0);  // seen free
  for (int z = 0; z < 4; ++z) {                      // the gap filled: one wall of 16 cells
    zone.set(6, 5, z);
    zone.set(7, 5, z);
  }
  zone.set(10, 10, 2, 0);  // two of its cells left: too small for an obstacle
  zone.set(10, 10, 3, 0);
  map.extract(zone.view);
  const FeatureCounters& c = map.counters();
  EXPECT_EQ(c.removed_seen_free, 1);
  EXPECT_EQ(c.removed_joined, 1);
  EXPECT_EQ(c.removed_other, 1);
  EXPECT_EQ(c.removed_unseen, 0);
  EXPECT_EQ(c.features_removed, 3);
  EXPECT_EQ(map.count(FeatureKind::kObstacle), 1u);
  // Each removal recorded with its evidence, for the edges to log.
  ASSERT_EQ(map.removals_recorded(), 3);
  int seen_free = 0;
  for (std::int64_t n = 0; n < 3; ++n) {
    const FeatureRemoval& r = map.removal(n);
    EXPECT_GT(r.id, 0u);
    if (r.cause == RemovalCause::kSeenFree) {
      ++seen_free;
      EXPECT_EQ(r.min, (CellIndex{1, 1, 0}));
      EXPECT_EQ(r.occupied, 0);
      EXPECT_EQ(r.cells, 4);
    }
    if (r.cause == RemovalCause::kOther) {
      EXPECT_EQ(r.occupied, 2);
    }
  }
  EXPECT_EQ(seen_free, 1);
}

TEST(FeatureStore, FullStoreKeepsTheMostRelevantAndSaysSo) {
  const std::array<int, 3> dims = {20, 20, 6};
  MapConfig config = feature_config(dims, false);
  config.features.capacity = 2;
  FeatureMap map(config, true);
  map.set_context(0.0, {5.0, 5.0, 2.0});
  TestZone zone(dims, {0, 0, 0});
  auto block = [&](int x0, int size) {
    for (int x = x0; x < x0 + size; ++x)
      for (int y = 2; y < 2 + size; ++y) zone.set(x, y, 2);
  };
  block(1, 2);   // 4 cells, near the vehicle
  block(7, 3);   // 9 cells, near
  block(15, 1);  // 1 cell, far: the least relevant
  map.extract(zone.view);
  EXPECT_EQ(map.count(), 2u);
  EXPECT_EQ(map.counters().features_dropped + map.counters().features_evicted, 1);
  for (const Feature* f : features_of(map, FeatureKind::kObstacle)) EXPECT_NE(f->cells, 1);
  // A big object near the vehicle in another zone evicts the weakest.
  TestZone next(dims, {0, 1, 0});
  for (int x = 0; x < 6; ++x)
    for (int y = 0; y < 6; ++y) next.set(x, y, 2);
  map.extract(next.view);
  EXPECT_EQ(map.count(), 2u);
  EXPECT_GE(map.counters().features_evicted, 1);
  bool has_big = false;
  for (const Feature* f : features_of(map, FeatureKind::kObstacle))
    has_big = has_big || f->cells == 36;
  EXPECT_TRUE(has_big);
}

TEST(FeatureStore, ObstaclesOutrankGroundWhenFull) {
  const std::array<int, 3> dims = {30, 30, 12};
  MapConfig config = feature_config(dims, true);
  config.features.capacity = 1;
  FeatureMap map(config, true);
  TestZone zone(dims, {0, 0, 0});
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 30; ++x) zone.set(x, y, 2);  // 900 ground cells
  for (int z = 3; z <= 9; ++z) zone.set(15, 12, z);  // a 7-cell post
  map.extract(zone.view);
  ASSERT_EQ(map.count(), 1u);
  EXPECT_EQ(map.count(FeatureKind::kObstacle), 1u);
  EXPECT_EQ(map.counters().features_dropped + map.counters().features_evicted, 1);
}

}  // namespace
}  // namespace zonemap
