// Geodetic -> NED, the INS plausibility gate, the 72-sector obstacle distances and
// their MAVLink encoding.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>

#include "hal/mavlink/obstacle_distance_mavlink.hpp"
#include "zonemap/geodetic.hpp"
#include "zonemap/ins_gate.hpp"
#include "zonemap/obstacle_distance.hpp"

using namespace zonemap;

TEST(Geodetic, KnownPointsAndRoundTrip) {
  const Eigen::Vector3d equator = geodetic_to_ecef({0.0, 0.0, 0.0});
  EXPECT_NEAR(equator.x(), 6378137.0, 1e-6);
  EXPECT_NEAR(geodetic_to_ecef({90.0, 0.0, 0.0}).z(), 6356752.314245, 1e-5);  // semi-minor axis
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> lat(-89.0, 89.0), lon(-180.0, 180.0), h(-100.0, 10000.0);
  for (int i = 0; i < 1000; ++i) {
    const Geodetic g{lat(rng), lon(rng), h(rng)};
    const Geodetic back = ecef_to_geodetic(geodetic_to_ecef(g));
    EXPECT_NEAR(back.latitude_deg, g.latitude_deg, 1e-10);
    EXPECT_NEAR(back.longitude_deg, g.longitude_deg, 1e-10);
    EXPECT_NEAR(back.height_m, g.height_m, 1e-5);
  }
  const LocalTangentPlane plane({48.0, 11.0, 500.0});
  const Eigen::Vector3d up = plane.to_ned({48.0, 11.0, 600.0});
  EXPECT_NEAR(up.z(), -100.0, 1e-6);
  EXPECT_NEAR(up.head<2>().norm(), 0.0, 1e-6);
  const Eigen::Vector3d ned(1234.5, -678.9, -42.0);
  EXPECT_LT((plane.to_ned(plane.to_geodetic(ned)) - ned).norm(), 1e-5);
}

namespace {

InsSolution valid_at(double t, Eigen::Vector3d p) {
  InsSolution s;
  s.time_s = t;
  s.position_m = p;
  s.attitude_valid = s.position_valid = true;
  s.position_sigma_m = 0.3;
  return s;
}

}  // namespace

TEST(InsGate, RefusesEveryImplausibleSolutionAndCountsWhy) {
  InsGate gate;
  InsRejection why{};
  EXPECT_TRUE(gate.check(valid_at(1.0, {0, 0, -50}), &why));
  InsSolution nan = valid_at(1.01, {0, 0, -50});
  nan.position_m.x() = std::nan("");
  EXPECT_FALSE(gate.check(nan, &why));
  EXPECT_EQ(why, InsRejection::kNotFinite);
  InsSolution bad_q = valid_at(1.01, {0, 0, -50});
  bad_q.attitude.coeffs() *= 1.5;
  EXPECT_FALSE(gate.check(bad_q, &why));
  EXPECT_EQ(why, InsRejection::kBadQuaternion);
  InsSolution invalid = valid_at(1.01, {0, 0, -50});
  invalid.position_valid = false;
  EXPECT_FALSE(gate.check(invalid, &why));
  EXPECT_EQ(why, InsRejection::kFlagsInvalid);
  InsSolution vague = valid_at(1.01, {0, 0, -50});
  vague.position_sigma_m = 12.0;
  EXPECT_FALSE(gate.check(vague, &why));
  EXPECT_EQ(why, InsRejection::kInaccurate);
  EXPECT_FALSE(gate.check(valid_at(0.99, {0, 0, -50}), &why));
  EXPECT_EQ(why, InsRejection::kTimeNotIncreasing);
  EXPECT_FALSE(gate.check(valid_at(1.0, {0, 0, -50}), &why));
  // A 100 m jump in 10 ms.
  EXPECT_FALSE(gate.check(valid_at(1.01, {100, 0, -50}), &why));
  EXPECT_EQ(why, InsRejection::kJump);
  // Normal flight goes on.
  EXPECT_TRUE(gate.check(valid_at(1.02, {0.5, 0, -50}), &why));
  const InsGateCounters& c = gate.counters();
  EXPECT_EQ(c.accepted, 2);
  EXPECT_EQ(c.rejected_total(), 7);
  EXPECT_EQ(c.rejected[static_cast<int>(InsRejection::kTimeNotIncreasing)], 2);
}

TEST(InsGate, SilenceThenResumeIsNotAJumpAndAPersistentJumpReanchors) {
  InsGate gate;
  InsRejection why{};
  ASSERT_TRUE(gate.check(valid_at(0.0, {0, 0, 0}), &why));
  // INS silent for 2 s while flying 20 m/s: 40 m further is plausible.
  EXPECT_TRUE(gate.check(valid_at(2.0, {40, 0, 0}), &why));
  // A jump of 100 m that persists (GNSS re-acquired): refused for 1 s, then taken.
  int refused = 0;
  bool taken = false;
  for (int i = 1; i <= 150 && !taken; ++i) {
    const double t = 2.0 + i * 0.01;
    taken = gate.check(valid_at(t, {140 + 0.2 * i, 0, 0}), &why);
    if (!taken) ++refused;
  }
  EXPECT_TRUE(taken);
  EXPECT_GE(refused, 99);
  EXPECT_LE(refused, 101);
  EXPECT_EQ(gate.counters().reanchors, 1);
}

TEST(InsGate, CameraPoseFollowsTheMount) {
  InsSolution s = valid_at(1.0, {10, 20, -30});
  s.attitude = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ());  // heading east
  Eigen::Isometry3d body_T_camera = Eigen::Isometry3d::Identity();
  body_T_camera.translation() = Eigen::Vector3d(1.0, 0.0, 0.5);  // 1 m ahead, 0.5 m below
  const PoseSample p = camera_pose_sample(s, body_T_camera);
  EXPECT_LT((p.position - Eigen::Vector3d(10, 21, -29.5)).norm(), 1e-12);
}

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
      if (static_cast<int>(a / step) == sector) best = std::min(best, std::hypot(x, y));
    }
  }
  return best;
}

}  // namespace

TEST(ObstacleDistance, SectorsInTheBodyFrameNearestFirst) {
  SectorConfig config;
  Eigen::Isometry3d body = Eigen::Isometry3d::Identity();  // NED, heading north
  body.translation() = Eigen::Vector3d(0, 0, -20);         // 20 m up
  // A post 10 m ahead (north), 1 m wide, from the ground to 30 m high.
  ObstacleBox post = box({10, -0.5, -30}, {11, 0.5, 0});
  ObstacleDistances d = obstacle_distances(&post, 1, body, false, config);
  EXPECT_EQ(d.distances_cm[0], 1000);
  EXPECT_EQ(d.distances_cm[71], 1000);
  EXPECT_EQ(d.distances_cm[36], d.max_distance_cm + 1);
  EXPECT_EQ(d.sectors_with_obstacle, 2);
  // Heading east: the post is now on the left (counter-clockwise, sectors ~54..71).
  body.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  d = obstacle_distances(&post, 1, body, false, config);
  EXPECT_EQ(d.distances_cm[53], 1000);  // 270 deg clockwise = 90 deg left
  EXPECT_EQ(d.distances_cm[54], 1000);
  EXPECT_EQ(d.distances_cm[0], d.max_distance_cm + 1);
  // Out of the vertical band (all below 30 m under the vehicle) or ground: nothing.
  ObstacleBox low = box({10, -0.5, 0}, {11, 0.5, 5});
  ObstacleBox ground = box({10, -0.5, -30}, {11, 0.5, 0}, FeatureKind::kGround);
  EXPECT_EQ(obstacle_distances(&low, 1, body, false, config).sectors_with_obstacle, 0);
  EXPECT_EQ(obstacle_distances(&ground, 1, body, false, config).sectors_with_obstacle, 0);
  // Inside a box's footprint: every sector blocked at the minimum distance.
  ObstacleBox around = box({-1, -1, -25}, {1, 1, -15});
  d = obstacle_distances(&around, 1, body, false, config);
  EXPECT_EQ(d.sectors_with_obstacle, 72);
  EXPECT_EQ(d.distances_cm[17], d.min_distance_cm);
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
    const ObstacleDistances d = obstacle_distances(&b, 1, body, false, config);
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

TEST(Mavlink, CrcCheckValueAndObstacleDistanceRoundTrip) {
  const std::uint8_t check[] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
  EXPECT_EQ(mavlink::crc_x25(check, sizeof check), 0x6F91);  // CRC-16/MCRF4XX check value
  ObstacleDistances d;
  d.min_distance_cm = 50;
  d.max_distance_cm = 5000;
  for (int s = 0; s < 72; ++s)
    d.distances_cm[s] = static_cast<std::uint16_t>(s % 3 ? 5001 : 100 * s + 60);
  std::uint8_t buf[mavlink::kMaxFrameBytes];
  const std::size_t n = mavlink::encode_obstacle_distance(d, 123456789012ull, {}, 42, buf);
  ASSERT_EQ(n, 12u + 167u);  // the last payload byte (frame = 12) is not zero
  mavlink::DecodedObstacleDistance out;
  ASSERT_TRUE(mavlink::decode_obstacle_distance(buf, n, &out));
  EXPECT_EQ(out.time_usec, 123456789012ull);
  EXPECT_EQ(0, std::memcmp(out.distances, d.distances_cm, sizeof d.distances_cm));
  EXPECT_EQ(out.min_distance, 50);
  EXPECT_EQ(out.max_distance, 5000);
  EXPECT_EQ(out.increment, 5);
  EXPECT_FLOAT_EQ(out.increment_f, 5.0f);
  EXPECT_EQ(out.frame, mavlink::kFrameBodyFrd);
  EXPECT_EQ(out.sequence, 42);
  for (std::size_t i = 1; i < n; ++i) {
    std::uint8_t corrupt[mavlink::kMaxFrameBytes];
    std::memcpy(corrupt, buf, n);
    corrupt[i] ^= 0x10;
    EXPECT_FALSE(mavlink::decode_obstacle_distance(corrupt, n, &out)) << "byte " << i;
  }
}
