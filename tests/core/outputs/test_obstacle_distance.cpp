// The 72-sector obstacle distances in the body frame: nearest first, unseen
// sectors unknown, footprints tighter than boxes, the exact wedge distance,
// sectors resent for where the vehicle has moved to.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "zonemap/outputs/obstacle_distance.hpp"

using namespace zonemap;

namespace {

ObstacleBox box(Eigen::Vector3d lo, Eigen::Vector3d hi, FeatureKind kind = FeatureKind::kObstacle) {
  ObstacleBox b;
  b.min = lo;
  b.max = hi;
  b.kind = kind;
  return b;
}

// Brute force: the nearest point of the rectangle inside each sector's wedge, by
// sampling the rectangle densely (an upper bound that converges to the exact value).
double sampled_nearest(const ObstacleBox& b, const Eigen::Vector3d& p, double heading, int sector) {
  double best = 1e9;
  const double step = 2 * M_PI / 72;
  for (int i = 0; i <= 150; ++i) {
    for (int j = 0; j <= 150; ++j) {
      const double x = b.min.x() + (b.max.x() - b.min.x()) * i / 150.0 - p.x();
      const double y = b.min.y() + (b.max.y() - b.min.y()) * j / 150.0 - p.y();
      // NED: clockwise from heading = atan2(east, north) - heading.
      double a = std::atan2(y, x) - heading;
      while (a < 0) a += 2 * M_PI;
      while (a >= 2 * M_PI) a -= 2 * M_PI;
      // Sector s is centred on s * step.
      if (static_cast<int>(std::floor(a / step + 0.5)) % 72 == sector)
        best = std::min(best, std::hypot(x, y));
    }
  }
  return best;
}

SectorMask all_seen() {
  SectorMask m;
  m.fill(true);
  return m;
}
const SectorMask kAllSeen = all_seen();

}  // namespace

TEST(ObstacleDistance, SectorsInTheBodyFrameNearestFirst) {
  SectorConfig config;
  Eigen::Isometry3d body = Eigen::Isometry3d::Identity();  // NED, heading north
  body.translation() = Eigen::Vector3d(0, 0, -20);         // 20 m up
  // A post 10 m ahead (north), 1 m wide, from the ground to 30 m high.
  ObstacleBox post = box({10, -0.5, -30}, {11, 0.5, 0});
  ObstacleDistances d = obstacle_distances(&post, 1, {}, body, false, config, kAllSeen);
  // Sector 0 is [-2.5, 2.5) deg; the post spans +-2.86 deg: sectors 71, 0 and 1.
  EXPECT_EQ(d.distances_cm[0], 1000);
  EXPECT_EQ(d.distances_cm[1], 1000);
  EXPECT_EQ(d.distances_cm[71], 1000);
  EXPECT_EQ(d.distances_cm[36], d.max_distance_cm + 1);
  EXPECT_EQ(d.sectors_with_obstacle, 3);
  // Heading east: the post is now 90 deg to the left (270 deg clockwise: sector 54).
  body.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  d = obstacle_distances(&post, 1, {}, body, false, config, kAllSeen);
  EXPECT_EQ(d.distances_cm[54], 1000);
  EXPECT_EQ(d.distances_cm[53], 1000);
  EXPECT_EQ(d.distances_cm[55], 1000);
  EXPECT_EQ(d.sectors_with_obstacle, 3);
  EXPECT_EQ(d.distances_cm[0], d.max_distance_cm + 1);
  // Out of the vertical band (all below 30 m under the vehicle) or ground: nothing.
  ObstacleBox low = box({10, -0.5, 0}, {11, 0.5, 5});
  ObstacleBox ground = box({10, -0.5, -30}, {11, 0.5, 0}, FeatureKind::kGround);
  EXPECT_EQ(obstacle_distances(&low, 1, {}, body, false, config, kAllSeen).sectors_with_obstacle,
            0);
  EXPECT_EQ(obstacle_distances(&ground, 1, {}, body, false, config, kAllSeen).sectors_with_obstacle,
            0);
  // Inside a box's footprint: every sector blocked at the minimum distance.
  ObstacleBox around = box({-1, -1, -25}, {1, 1, -15});
  d = obstacle_distances(&around, 1, {}, body, false, config, kAllSeen);
  EXPECT_EQ(d.sectors_with_obstacle, 72);
  EXPECT_EQ(d.distances_cm[17], d.min_distance_cm);
}

TEST(ObstacleDistance, UnseenSectorsAreUnknownButRememberedObstaclesStay) {
  SectorConfig config;
  Eigen::Isometry3d body = Eigen::Isometry3d::Identity();
  body.translation() = Eigen::Vector3d(0, 0, -20);
  ObstacleBox behind = box({-11, -0.5, -30}, {-10, 0.5, 0});  // 10 m behind
  SectorMask ahead_only{};
  for (int s : {70, 71, 0, 1, 2}) ahead_only[static_cast<std::size_t>(s)] = true;
  const ObstacleDistances d = obstacle_distances(&behind, 1, {}, body, false, config, ahead_only);
  EXPECT_EQ(d.distances_cm[36], 1000);                  // not seen now, but remembered: an obstacle
  EXPECT_EQ(d.distances_cm[0], d.max_distance_cm + 1);  // seen: free
  EXPECT_EQ(d.distances_cm[18], kSectorUnknown);        // never seen: unknown, not free
  EXPECT_EQ(d.sectors_unknown, 72 - 5 - 3);
}

TEST(ObstacleDistance, FootprintRectanglesAreTighterThanTheBox) {
  // An L-shaped obstacle: its box covers the vehicle's right-front, its footprint
  // only a wall 20 m ahead and a wall 20 m to the right.
  SectorConfig config;
  Eigen::Isometry3d body = Eigen::Isometry3d::Identity();
  body.translation() = Eigen::Vector3d(0, 0, -5);
  const ObstacleBox l = box({5, 5, -10}, {20, 20, 0});
  const FootprintRect rects[2] = {{19, 5, 20, 20}, {5, 19, 20, 20}};
  const std::uint32_t offsets[1] = {0}, counts[1] = {2};
  const ObstacleDistances loose = obstacle_distances(&l, 1, {}, body, false, config, kAllSeen);
  const ObstacleDistances tight =
      obstacle_distances(&l, 1, {rects, offsets, counts}, body, false, config, kAllSeen);
  // Sector 9 (45 deg, towards the box's near corner at (5, 5)).
  EXPECT_EQ(loose.distances_cm[9], 707);
  // The wedge's edge at 42.5 deg meets the L's inner face x = 19 at 25.77 m.
  EXPECT_EQ(tight.distances_cm[9], 2577);
  NearestObstacle nearest[4];
  ASSERT_EQ(nearest_obstacles(&l, 1, {rects, offsets, counts}, body, false, config, nearest, 4),
            1u);
  // The nearest point of the L's prisms: (19, 5, -5) in NED = body FRD here.
  EXPECT_NEAR(nearest[0].body_frd.x(), 19.0, 1e-9);
  EXPECT_NEAR(nearest[0].body_frd.y(), 5.0, 1e-9);
  EXPECT_NEAR(nearest[0].body_frd.z(), 0.0, 1e-9);
}

TEST(ObstacleDistance, NearestObstaclesInTheBodyFrameNearestFirst) {
  SectorConfig config;
  // NED, heading east (body x = east), 10 m up.
  Eigen::Isometry3d body = Eigen::Isometry3d::Identity();
  body.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  body.translation() = Eigen::Vector3d(0, 0, -10);
  ObstacleBox boxes[3] = {box({30, -1, -15}, {31, 1, 0}),   // 30 m north: on the left
                          box({-1, 8, -15}, {1, 9, 0}),     // 8 m east: ahead
                          box({-1, 60, -15}, {1, 61, 0})};  // beyond max distance
  boxes[0].id = 7;
  boxes[1].id = 9;
  NearestObstacle out[8];
  ASSERT_EQ(nearest_obstacles(boxes, 3, {}, body, false, config, out, 8), 2u);
  EXPECT_EQ(out[0].id, 9u);
  EXPECT_NEAR(out[0].body_frd.x(), 8.0, 1e-9);  // forward
  EXPECT_NEAR(out[0].body_frd.y(), 0.0, 1e-9);
  EXPECT_EQ(out[1].id, 7u);
  EXPECT_NEAR(out[1].body_frd.x(), 0.0, 1e-9);
  EXPECT_NEAR(out[1].body_frd.y(), -30.0, 1e-9);  // left = negative right
  ASSERT_EQ(nearest_obstacles(boxes, 3, {}, body, false, config, out, 1), 1u);
  EXPECT_EQ(out[0].id, 9u);  // capacity 1 keeps the nearest
}

TEST(ObstacleDistance, AWallAcrossThreeWedgesGivesEachItsNearestPoint) {
  // NED, heading north, 10 m up; a wall 10 m ahead from 20 m left to 20 m right
  // spans ArduPilot's sectors 7 (-45), 0 and 1 (+45): one point in each.
  SectorConfig config;
  Eigen::Isometry3d body = Eigen::Isometry3d::Identity();
  body.translation() = Eigen::Vector3d(0, 0, -10);
  ObstacleBox wall = box({10, -20, -15}, {11, 20, 0});
  wall.id = 5;
  NearestObstacle out[8];
  ASSERT_EQ(nearest_obstacles(&wall, 1, {}, body, false, config, out, 8, 8), 3u);
  EXPECT_EQ(out[0].wedge, 0);
  EXPECT_NEAR(out[0].body_frd.x(), 10.0, 1e-9);
  EXPECT_NEAR(out[0].body_frd.y(), 0.0, 1e-9);
  for (int k = 1; k < 3; ++k) {
    // Where the wedge's near edge (22.5 deg) meets the wall.
    EXPECT_NEAR(out[k].distance_m, 10.0 / std::cos(M_PI / 8), 1e-9);
    EXPECT_NEAR(out[k].body_frd.x(), 10.0, 1e-9);
    EXPECT_NEAR(std::abs(out[k].body_frd.y()), 10.0 * std::tan(M_PI / 8), 1e-9);
    EXPECT_EQ(out[k].body_frd.y() > 0 ? 1 : 7, out[k].wedge);
  }
  // One wedge: the box's nearest point alone.
  ASSERT_EQ(nearest_obstacles(&wall, 1, {}, body, false, config, out, 8), 1u);
  EXPECT_NEAR(out[0].distance_m, 10.0, 1e-9);
}

TEST(ObstacleDistance, EveryWedgeWithAnObstacleKeepsItsNearestPointWhateverTheCapacity) {
  // Eight posts close ahead and one far behind: with room for eight points the
  // one behind still comes (in place of the farthest post ahead).
  SectorConfig config;
  Eigen::Isometry3d body = Eigen::Isometry3d::Identity();
  body.translation() = Eigen::Vector3d(0, 0, -5);
  ObstacleBox boxes[9];
  for (int i = 0; i < 8; ++i) {
    const double y = -4.0 + i;
    boxes[i] = box({8.0 + i, y, -10}, {8.5 + i, y + 0.5, 0});
    boxes[i].id = static_cast<std::uint32_t>(i + 1);
  }
  boxes[8] = box({-40, -1, -10}, {-39, 1, 0});
  boxes[8].id = 99;
  NearestObstacle out[8];
  const std::size_t n = nearest_obstacles(boxes, 9, {}, body, false, config, out, 8, 8);
  ASSERT_EQ(n, 8u);
  EXPECT_TRUE(std::any_of(out, out + n, [](const NearestObstacle& o) { return o.id == 99; }));
  EXPECT_EQ(out[n - 1].id, 99u);  // still nearest first
  EXPECT_EQ(out[n - 1].wedge, 4);
}

TEST(ObstacleDistance, ABoxOverTheVehicleGivesThePointStraightAbove) {
  SectorConfig config;
  Eigen::Isometry3d body = Eigen::Isometry3d::Identity();
  body.translation() = Eigen::Vector3d(0, 0, -5);
  const ObstacleBox roof = box({-3, -3, -8}, {3, 3, -7});  // 2 m above (NED)
  NearestObstacle out[8];
  ASSERT_EQ(nearest_obstacles(&roof, 1, {}, body, false, config, out, 8, 8), 1u);
  EXPECT_NEAR(out[0].body_frd.z(), -2.0, 1e-9);  // up is -z in FRD
  EXPECT_NEAR(out[0].body_frd.head<2>().norm(), 0.0, 1e-9);
  // Inside it: a point at min_distance in every wedge.
  const ObstacleBox around = box({-3, -3, -8}, {3, 3, 0});
  ASSERT_EQ(nearest_obstacles(&around, 1, {}, body, false, config, out, 8, 8), 8u);
  for (const NearestObstacle& o : out) EXPECT_NEAR(o.distance_m, config.min_distance_m, 1e-9);
}

TEST(ObstacleDistance, ExactWedgeDistanceAgreesWithDenseSampling) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-30.0, 30.0), size(0.2, 8.0), angle(-M_PI, M_PI);
  SectorConfig config;
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Vector3d lo(u(rng), u(rng), -10.0);
    const ObstacleBox b = box(lo, lo + Eigen::Vector3d(size(rng), size(rng), 10.0));
    if (std::abs(b.min.x()) < 9 && std::abs(b.min.y()) < 9) continue;
    const double heading = angle(rng);
    Eigen::Isometry3d body = Eigen::Isometry3d::Identity();
    body.linear() = Eigen::AngleAxisd(heading, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    body.translation() = Eigen::Vector3d(0, 0, -5);
    const ObstacleDistances d = obstacle_distances(&b, 1, {}, body, false, config, kAllSeen);
    for (int s = 0; s < 72; ++s) {
      const double sampled = sampled_nearest(b, body.translation(), heading, s);
      if (sampled > config.max_distance_m) {
        // Sampling may miss a sliver; exact may still see it, never farther than 5 cm.
        continue;
      }
      ASSERT_LT(d.distances_cm[s], d.max_distance_cm + 1) << "trial " << trial << " sector " << s;
      EXPECT_LE(d.distances_cm[s], sampled * 100.0 + 1.0) << "trial " << trial << " sector " << s;
      EXPECT_GE(d.distances_cm[s], sampled * 100.0 - 15.0) << "trial " << trial << " sector " << s;
    }
  }
}

namespace {

Eigen::Isometry3d ned_pose(double north, double east, double heading) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::AngleAxisd(heading, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  pose.translation() = Eigen::Vector3d(north, east, -10);
  return pose;
}

}  // namespace

// Resent between updates, the sectors read from where the vehicle is now: an
// obstacle ahead nearer by the distance flown, a turn shifts them, and nothing
// changes for a vehicle that has not moved.
TEST(ObstacleDistance, MovedSectorsReadFromWhereTheVehicleIsNow) {
  const ObstacleBox wall = box({19.5, -3, -20}, {20.5, 3, 0});  // 19.5 m north, 6 m wide
  const Eigen::Isometry3d then = ned_pose(0, 0, 0);
  const ObstacleDistances at_update =
      obstacle_distances(&wall, 1, {}, then, false, SectorConfig{}, kAllSeen);
  ASSERT_EQ(at_update.distances_cm[0], 1950);

  const ObstacleDistances same = moved_obstacle_distances(at_update, then, then, false);
  EXPECT_TRUE(std::equal(std::begin(same.distances_cm), std::end(same.distances_cm),
                         std::begin(at_update.distances_cm)));

  const ObstacleDistances ahead =
      moved_obstacle_distances(at_update, then, ned_pose(1.2, 0, 0), false);
  EXPECT_NEAR(ahead.distances_cm[0], 1830, 2);  // the arc's chord: at most 0.1% nearer
  EXPECT_EQ(ahead.distances_cm[36], at_update.distances_cm[36]) << "behind: seen free";

  // Turned 10 degrees right (clockwise from above): what was sector 2 is now sector 0.
  const ObstacleDistances turned =
      moved_obstacle_distances(at_update, then, ned_pose(0, 0, 10 * M_PI / 180), false);
  for (int s = 0; s < 72; ++s) {
    const int was = (s + 2) % 72;
    if (at_update.distances_cm[was] > at_update.max_distance_cm) {
      EXPECT_EQ(turned.distances_cm[s], at_update.distances_cm[was]) << s;
    } else {
      EXPECT_LE(turned.distances_cm[s], at_update.distances_cm[was]) << s;
      EXPECT_GE(turned.distances_cm[s], at_update.distances_cm[was] * 0.998) << s;
    }
  }
}

// Whatever the field and however the vehicle moved (up to 2 m and 15 degrees),
// every sector that has an obstacle from where it is now reads one no farther,
// one the update's sectors could not rule out; unseen sectors stay unknown.
TEST(ObstacleDistance, MovedSectorsNeverReadFartherThanTheObstacles) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  SectorMask seen = kAllSeen;
  for (int s = 40; s < 50; ++s) seen[static_cast<std::size_t>(s)] = false;  // behind, left
  int checked = 0, spread = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    std::vector<ObstacleBox> boxes;
    for (int i = 0; i < 6; ++i) {
      const double r = 5.0 + 35.0 * unit(rng), a = 2 * M_PI * unit(rng);
      const Eigen::Vector3d c(r * std::cos(a), r * std::sin(a), 0);
      const Eigen::Vector3d half(0.3 + 3 * unit(rng), 0.3 + 3 * unit(rng), 0);
      boxes.push_back(box(c - half - Eigen::Vector3d(0, 0, 20), c + half));
    }
    const Eigen::Isometry3d then = ned_pose(0, 0, 2 * M_PI * unit(rng));
    const double step = 2.0 * unit(rng), dir = 2 * M_PI * unit(rng);
    const Eigen::Isometry3d now = ned_pose(
        step * std::cos(dir), step * std::sin(dir),
        std::atan2(then.linear()(1, 0), then.linear()(0, 0)) + (unit(rng) - 0.5) * 30 * M_PI / 180);
    const ObstacleDistances at_update =
        obstacle_distances(boxes.data(), boxes.size(), {}, then, false, SectorConfig{}, seen);
    const ObstacleDistances truth =
        obstacle_distances(boxes.data(), boxes.size(), {}, now, false, SectorConfig{}, kAllSeen);
    const ObstacleDistances moved = moved_obstacle_distances(at_update, then, now, false);
    for (int s = 0; s < 72; ++s) {
      if (truth.distances_cm[s] > truth.max_distance_cm) {  // no obstacle there now
        spread += moved.distances_cm[s] <= moved.max_distance_cm;
        continue;
      }
      ++checked;
      ASSERT_LE(moved.distances_cm[s], truth.distances_cm[s] + 1)
          << "trial " << trial << " sector " << s;
    }
  }
  EXPECT_GT(checked, 20000);
  // What it costs: obstacles spread into sectors where they could be (measured 25%).
  EXPECT_LT(spread, checked * 3 / 10);
  // The unseen wedge of a vehicle that did not turn stays unknown where nothing stands.
  const ObstacleDistances empty =
      obstacle_distances(nullptr, 0, {}, ned_pose(0, 0, 0), false, SectorConfig{}, seen);
  const ObstacleDistances moved =
      moved_obstacle_distances(empty, ned_pose(0, 0, 0), ned_pose(1, 0, 0), false);
  for (int s = 41; s < 49; ++s) EXPECT_EQ(moved.distances_cm[s], kSectorUnknown) << s;
  EXPECT_EQ(moved.distances_cm[0], empty.max_distance_cm + 1);
}

// Turned right by two sectors, what was seen from ahead to the right is seen from
// two sectors left of ahead; turned by a sector and a half, a sector is seen only
// where both it overlaps were; the position plays no part.
TEST(ObstacleDistance, TheSeenSectorsTurnWithTheVehicle) {
  SectorMask seen{};
  for (int s = 0; s <= 10; ++s) seen[static_cast<std::size_t>(s)] = true;  // 0..50 deg right
  const Eigen::Isometry3d then = ned_pose(0, 0, 0);
  const SectorMask by_two = turned_sector_mask(seen, then, ned_pose(3, 1, 10 * M_PI / 180), false);
  for (int s = 0; s < 72; ++s) EXPECT_EQ(by_two[s], s <= 8 || s >= 70) << s;
  const SectorMask by_one_and_half =
      turned_sector_mask(seen, then, ned_pose(0, 0, 7.5 * M_PI / 180), false);
  for (int s = 0; s < 72; ++s) EXPECT_EQ(by_one_and_half[s], s <= 8 || s == 71) << s;
  const SectorMask left = turned_sector_mask(seen, then, ned_pose(0, 0, -10 * M_PI / 180), false);
  for (int s = 0; s < 72; ++s) EXPECT_EQ(left[s], s >= 2 && s <= 12) << s;
}

// Moved up to (or past) where the update's obstacle ahead may stand: blocked
// all round, as a vehicle inside a box; beside an unseen wedge, the obstacle's
// wedge is entered from the side and read, not called unknown.
TEST(ObstacleDistance, MovedOntoAnObstaclesReachIsBlockedAllRound) {
  const ObstacleBox post = box({1.5, -0.3, -20}, {2.1, 0.3, 0});  // 1.5 m ahead
  const Eigen::Isometry3d then = ned_pose(0, 0, 0);
  const ObstacleDistances at_update =
      obstacle_distances(&post, 1, {}, then, false, SectorConfig{}, kAllSeen);
  const ObstacleDistances onto =
      moved_obstacle_distances(at_update, then, ned_pose(1.6, 0, 0), false);
  for (int s = 0; s < 72; ++s) EXPECT_EQ(onto.distances_cm[s], at_update.min_distance_cm) << s;

  SectorMask seen = kAllSeen;
  for (int s = 1; s < 10; ++s) seen[static_cast<std::size_t>(s)] = false;  // right of ahead
  const ObstacleBox wall = box({10, -1, -20}, {11, 1, 0});  // 10 m ahead, sectors 71-1
  const ObstacleDistances partly =
      obstacle_distances(&wall, 1, {}, then, false, SectorConfig{}, seen);
  ASSERT_EQ(partly.distances_cm[2], kSectorUnknown);
  // 2 m to the right: the wall is ahead-left now; sector 0 looks past the wall's
  // wedge edge from the unseen side and must read it no farther than it stands.
  const ObstacleDistances moved = moved_obstacle_distances(partly, then, ned_pose(0, 2, 0), false);
  const ObstacleDistances truth =
      obstacle_distances(&wall, 1, {}, ned_pose(0, 2, 0), false, SectorConfig{}, kAllSeen);
  for (int s : {70, 71, 0}) {
    if (truth.distances_cm[s] <= truth.max_distance_cm) {
      EXPECT_LE(moved.distances_cm[s], truth.distances_cm[s] + 1) << s;
    }
  }
}
