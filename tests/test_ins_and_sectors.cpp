// Geodetic -> NED, the INS plausibility gate, the 72-sector obstacle distances and
// their MAVLink encoding.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>

#include "hal/mavlink/obstacle_distance_mavlink.hpp"
#include "test_support.hpp"
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

using zonemap::testing::valid_at;

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

namespace {

// CRC_EXTRA from a message's definition, as the MAVLink generator computes it:
// the name and every base field's type and name (wire order), array lengths too.
std::uint8_t crc_extra(const char* name,
                       std::initializer_list<std::pair<const char*, const char*>> fields) {
  std::string text = std::string(name) + " ";
  std::uint16_t crc =
      mavlink::crc_x25(reinterpret_cast<const std::uint8_t*>(text.data()), text.size());
  for (const auto& [type, field] : fields) {
    const std::string t = std::string(type) + " ", f = std::string(field) + " ";
    crc = mavlink::crc_x25(reinterpret_cast<const std::uint8_t*>(t.data()), t.size(), crc);
    crc = mavlink::crc_x25(reinterpret_cast<const std::uint8_t*>(f.data()), f.size(), crc);
  }
  return static_cast<std::uint8_t>((crc & 0xFF) ^ (crc >> 8));
}

}  // namespace

TEST(Mavlink, CrcExtrasFollowFromTheMessageDefinitions) {
  EXPECT_EQ(crc_extra("HEARTBEAT", {{"uint32_t", "custom_mode"},
                                    {"uint8_t", "type"},
                                    {"uint8_t", "autopilot"},
                                    {"uint8_t", "base_mode"},
                                    {"uint8_t", "system_status"},
                                    {"uint8_t", "mavlink_version"}}),
            mavlink::kHeartbeatCrcExtra);
  EXPECT_EQ(crc_extra("OBSTACLE_DISTANCE_3D", {{"uint32_t", "time_boot_ms"},
                                               {"float", "x"},
                                               {"float", "y"},
                                               {"float", "z"},
                                               {"float", "min_distance"},
                                               {"float", "max_distance"},
                                               {"uint16_t", "obstacle_id"},
                                               {"uint8_t", "sensor_type"},
                                               {"uint8_t", "frame"}}),
            mavlink::kObstacleDistance3dCrcExtra);
}

TEST(Mavlink, HeartbeatAndObstacle3dFrames) {
  std::uint8_t buf[64];
  const mavlink::LinkIds ids{7, 195};
  std::size_t n = mavlink::encode_heartbeat(ids, 3, buf);
  ASSERT_EQ(n, 12u + 9u);  // mavlink_version (3) is the last byte: nothing truncated
  EXPECT_EQ(buf[5], 7);
  EXPECT_EQ(buf[6], 195);
  EXPECT_EQ(buf[7] | buf[8] << 8 | buf[9] << 16, 0);
  EXPECT_EQ(buf[10 + 4], mavlink::kTypeOnboardController);
  EXPECT_EQ(buf[10 + 5], mavlink::kAutopilotInvalid);
  mavlink::Obstacle3d o;
  o.time_boot_ms = 1234;
  o.obstacle_id = 42;
  o.x = 8.0f;
  o.max_distance = 50.0f;
  n = mavlink::encode_obstacle_distance_3d(o, ids, 4, buf);
  ASSERT_EQ(n, 12u + 28u);  // frame BODY_FRD (12) ends the payload
  EXPECT_EQ(buf[7] | buf[8] << 8 | buf[9] << 16, 11037);
  EXPECT_EQ(buf[10 + 27], mavlink::kFrameBodyFrd);
  EXPECT_EQ(buf[10 + 24] | buf[10 + 25] << 8, 42);
}
