// MAVLink framing as the autopilots read it: CRC check value, CRC_EXTRA from the
// message definitions, OBSTACLE_DISTANCE, HEARTBEAT and OBSTACLE_DISTANCE_3D
// frames; the sink's message set per autopilot.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include <vector>

#include "hal/mavlink/mavlink_udp_sink.hpp"
#include "hal/mavlink/obstacle_distance_mavlink.hpp"
#include "hal/os/allocation_counter.hpp"
#include "zonemap/outputs/obstacle_distance.hpp"

using namespace zonemap;

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

namespace {

// The sink's datagrams, by message id, with OBSTACLE_DISTANCE_3D's fields read
// back from their wire offsets.
struct Captured final : mavlink::DatagramOut {
  struct Point {
    std::uint32_t time_boot_ms;
    float x, y, z;
    std::uint16_t id;
  };
  std::vector<std::uint32_t> ids;
  std::vector<Point> points;
  std::vector<mavlink::DecodedObstacleDistance> sectors;  // OBSTACLE_DISTANCE
  bool send(const std::uint8_t* d, std::size_t size, double) override {
    const std::uint32_t id = d[7] | d[8] << 8 | d[9] << 16;
    ids.push_back(id);
    mavlink::DecodedObstacleDistance decoded;
    if (id == 330 && mavlink::decode_obstacle_distance(d, size, &decoded)) {
      sectors.push_back(decoded);
    }
    if (id == 11037 && size >= 12 + 28) {
      Point p;
      std::memcpy(&p.time_boot_ms, d + 10, 4);
      std::memcpy(&p.x, d + 14, 4);
      std::memcpy(&p.y, d + 18, 4);
      std::memcpy(&p.z, d + 22, 4);
      std::memcpy(&p.id, d + 34, 2);
      points.push_back(p);
    }
    return true;
  }
  long count(std::uint32_t id) const { return std::count(ids.begin(), ids.end(), id); }
};

ObstacleBox post(std::uint32_t id, double north, double east) {
  ObstacleBox b;
  b.id = id;
  b.min = {north - 0.5, east - 0.5, -20};
  b.max = {north + 0.5, east + 0.5, 0};
  return b;
}

hal::ObstacleUpdate update_of(const ObstacleBox* boxes, std::size_t count, double time_s) {
  hal::ObstacleUpdate u;
  u.time_s = time_s;
  u.world_z_up = false;  // NED, the vehicle at the origin 10 m up, heading north
  u.world_T_body.translation() = Eigen::Vector3d(0, 0, -10);
  u.boxes = boxes;
  u.count = count;
  u.sectors_observed.fill(true);
  return u;
}

mavlink::MavlinkUdpConfig config_for(const char* autopilot, const char* messages = "") {
  mavlink::MavlinkUdpConfig c;
  c.autopilot = autopilot;
  c.messages = messages;
  c.rate_hz = 10;
  return c;
}

}  // namespace

TEST(MavlinkSink, ConfigNamesTheAutopilotAndNeverSendsBothKinds) {
  EXPECT_NE(mavlink::validate(config_for("")).find("autopilot must be"), std::string::npos);
  EXPECT_NE(mavlink::validate(config_for("apm")).find("autopilot must be"), std::string::npos);
  EXPECT_NE(mavlink::validate(config_for("px4", "3d")).find("PX4 reads no"), std::string::npos);
  EXPECT_NE(mavlink::validate(config_for("ardupilot", "both")).find("2d or 3d"), std::string::npos);
  for (const char* ok : {"px4", "ardupilot"}) {
    EXPECT_EQ(mavlink::validate(config_for(ok)), "");
  }
  EXPECT_EQ(mavlink::validate(config_for("ardupilot", "2d")), "");
  mavlink::MavlinkUdpConfig few = config_for("ardupilot");
  few.max_obstacles_3d = 4;  // fewer than ArduPilot's eight sectors
  EXPECT_NE(mavlink::validate(few), "");
}

// ArduPilot replaces its whole boundary on each OBSTACLE_DISTANCE: its sink sends
// scans of 3-D points alone, each under a time_boot_ms newer than the last.
TEST(MavlinkSink, ArduPilotGetsScansOf3dPointsAloneEachUnderANewTime) {
  Captured out;
  mavlink::MavlinkUdpSink sink(config_for("ardupilot"), out);
  const ObstacleBox posts[] = {post(5, 20, 0), post(9, 0, 15)};  // ahead, right
  for (int i = 0; i < 5; ++i) {
    const double now = 0.0001 * i;  // faster than a millisecond: times must still rise
    sink.publish(update_of(posts, 2, now), now);
    sink.tick(now + 0.2);
  }
  EXPECT_EQ(out.count(330), 0);  // no OBSTACLE_DISTANCE
  ASSERT_FALSE(out.points.empty());
  std::vector<std::uint32_t> scan_times;
  for (const auto& p : out.points) {
    if (scan_times.empty() || scan_times.back() != p.time_boot_ms) {
      if (!scan_times.empty()) {
        EXPECT_GT(p.time_boot_ms, scan_times.back());
      }
      scan_times.push_back(p.time_boot_ms);
    }
  }
  EXPECT_GE(scan_times.size(), 2u);
  bool ahead = false, right = false;
  for (const auto& p : out.points) {
    ahead |= std::abs(p.x - 19.5f) < 0.01f && std::abs(p.y) < 0.6f;
    right |= std::abs(p.y - 14.5f) < 0.01f && std::abs(p.x) < 0.6f;
    EXPECT_NE(p.id, mavlink::kUnknownObstacleId);
  }
  EXPECT_TRUE(ahead);
  EXPECT_TRUE(right);
  EXPECT_NE(mavlink::obstacle_id_3d(5, 0), mavlink::obstacle_id_3d(9, 2));
}

namespace {

// Two updates 0.1 s apart of a vehicle flying north at 4 m/s.
void fly_north_two_updates(mavlink::MavlinkUdpSink& sink, const ObstacleBox* boxes,
                           std::size_t count) {
  for (int k = 0; k < 2; ++k) {
    hal::ObstacleUpdate u = update_of(boxes, count, 0.1 * k);
    u.world_T_body.translation().x() = 0.4 * k;
    sink.publish(u, 0.1 * k);
  }
}

// A grid of posts 2 m apart from 20 m ahead, more than a 2-D sink keeps.
std::vector<ObstacleBox> more_posts_than_kept() {
  std::vector<ObstacleBox> field;
  for (std::uint32_t i = 0; i < mavlink::MavlinkUdpConfig{}.kept_boxes + 10; ++i) {
    field.push_back(post(i, 20 + 2.0 * (i % 10), -20 + 2.0 * (i / 10)));
  }
  return field;
}

}  // namespace

// ArduPilot keeps a point's body-frame vector as it comes: a scan sent between
// map updates gives it for where the vehicle has flown to since, not for where
// the update saw it from (else an obstacle ahead reads farther than it is).
TEST(MavlinkSink, ScansBetweenUpdatesAreForWhereTheVehicleIsNow) {
  Captured out;
  mavlink::MavlinkUdpSink sink(config_for("ardupilot"), out);
  const ObstacleBox ahead[] = {post(5, 20, 0)};  // its near face 19.5 m north
  fly_north_two_updates(sink, ahead, 1);
  ASSERT_FALSE(out.points.empty());
  EXPECT_NEAR(out.points.back().x, 19.1f, 1e-3) << "sent with the update: its own pose";
  sink.tick(0.4);  // 0.3 s on, no newer update: 1.2 m nearer
  EXPECT_EQ(out.points.back().time_boot_ms, 400u);
  EXPECT_NEAR(out.points.back().x, 17.9f, 1e-3);
  EXPECT_NEAR(out.points.back().y, 0.0f, 1e-3);
}

// The same for the sectors of OBSTACLE_DISTANCE (PX4, ArduPilot 2d), which both
// autopilots take as they come: resent for where the vehicle has flown to.
TEST(MavlinkSink, SectorsBetweenUpdatesAreForWhereTheVehicleIsNow) {
  Captured out;
  mavlink::MavlinkUdpSink sink(config_for("px4"), out);
  const ObstacleBox ahead[] = {post(5, 20, 0)};  // its near face 19.5 m north
  fly_north_two_updates(sink, ahead, 1);
  ASSERT_EQ(out.sectors.size(), 2u);
  EXPECT_EQ(out.sectors.back().distances[0], 1910) << "sent with the update: its own pose";
  sink.tick(0.4);  // 0.3 s on, no newer update: 1.2 m nearer
  ASSERT_EQ(out.sectors.size(), 3u);
  EXPECT_NEAR(out.sectors.back().distances[0], 1790, 1);  // floored to the centimetre
  EXPECT_EQ(out.sectors.back().distances[36], 5001) << "behind: still seen free";
  EXPECT_EQ(out.sectors.back().time_usec, 400000u) << "the time it is for";
  EXPECT_EQ(sink.sectors_from_kept(), 1);
}

// With no motion to go by (one update, or one after a jump) the sectors resent
// stand for the update's pose: stamped with the update's time, not a later one.
TEST(MavlinkSink, SectorsNotMovedKeepTheUpdatesTime) {
  Captured out;
  mavlink::MavlinkUdpSink sink(config_for("px4"), out);
  const ObstacleBox ahead[] = {post(5, 20, 0)};
  sink.publish(update_of(ahead, 1, 0.1), 0.1);
  sink.tick(0.4);
  ASSERT_EQ(out.sectors.size(), 2u);
  EXPECT_EQ(out.sectors.back().distances[0], 1950) << "the update's own pose";
  EXPECT_EQ(out.sectors.back().time_usec, 100000u) << "the time its pose is for";
  hal::ObstacleUpdate jumped = update_of(ahead, 1, 0.5);
  jumped.world_T_body.translation().x() = -30.0;  // 75 m/s: a re-anchored track
  sink.publish(jumped, 0.5);
  sink.tick(0.8);
  ASSERT_EQ(out.sectors.size(), 4u);
  EXPECT_EQ(out.sectors.back().distances[0], 4950);
  EXPECT_EQ(out.sectors.back().time_usec, 500000u);
  EXPECT_EQ(sink.sectors_from_kept(), 0);
}

// More obstacles within reach than the sink keeps: the update's sectors
// re-expressed for where the vehicle is, never reading an obstacle farther.
TEST(MavlinkSink, SectorsOfTooManyObstaclesAreReExpressedNeverFarther) {
  Captured out;
  mavlink::MavlinkUdpSink sink(config_for("px4"), out);
  const std::vector<ObstacleBox> field = more_posts_than_kept();
  fly_north_two_updates(sink, field.data(), field.size());
  sink.tick(0.4);
  ASSERT_EQ(out.sectors.size(), 3u);
  EXPECT_EQ(sink.sectors_re_expressed(), 1);
  const std::uint16_t* then = out.sectors[1].distances;
  const std::uint16_t* now = out.sectors[2].distances;
  EXPECT_NEAR(now[0], then[0] - 120, 3) << "1.2 m nearer ahead";
  for (int s = 0; s < 72; ++s) {
    if (then[s] <= 5000) {
      EXPECT_LE(now[s], then[s]) << s;
    }
  }
}

// Between updates the sectors are computed on the output thread: without a
// heap allocation, from kept obstacles or (too many) re-expressed.
TEST(MavlinkSink, SectorsBetweenUpdatesAllocateNothing) {
  struct Counting final : mavlink::DatagramOut {
    int sent = 0;
    bool send(const std::uint8_t*, std::size_t, double) override { return ++sent > 0; }
  } out;
  mavlink::MavlinkUdpSink sink(config_for("px4"), out);
  const std::vector<ObstacleBox> field = more_posts_than_kept();
  os::AllocationScope scope;
  for (int k = 0; k < 20; ++k) {
    const double t = 0.3 * k;
    hal::ObstacleUpdate u = update_of(field.data(), k % 2 == 0 ? 2 : field.size(), t);
    u.world_T_body.translation().x() = 1.2 * k;
    sink.publish(u, t);
    sink.tick(t + 0.1);
    sink.tick(t + 0.2);
  }
  EXPECT_EQ(scope.counted().allocations, 0);
  // The first update has no motion to go by: its two resends are its own sectors.
  EXPECT_EQ(sink.sectors_from_kept(), 18);
  EXPECT_EQ(sink.sectors_re_expressed(), 20);
  EXPECT_GE(out.sent, 20 * 3);  // and heartbeats
}

// Nothing in range: one zero vector with the unknown id, so ArduPilot clears its
// boundary on the new time and keeps the sensor healthy.
TEST(MavlinkSink, AnEmptyScanIsOneZeroVectorWithTheUnknownId) {
  Captured out;
  mavlink::MavlinkUdpSink sink(config_for("ardupilot"), out);
  sink.publish(update_of(nullptr, 0, 1.0), 1.0);
  ASSERT_EQ(out.points.size(), 1u);
  EXPECT_EQ(out.points[0].id, mavlink::kUnknownObstacleId);
  EXPECT_EQ(out.points[0].x, 0.0f);
  EXPECT_EQ(out.points[0].y, 0.0f);
  EXPECT_EQ(out.points[0].z, 0.0f);
  EXPECT_EQ(out.points[0].time_boot_ms, 1000u);
}

TEST(MavlinkSink, Px4AndArduPilot2dGetObstacleDistanceAlone) {
  const ObstacleBox posts[] = {post(5, 20, 0)};
  for (const char* messages : {"", "2d"}) {
    Captured out;
    mavlink::MavlinkUdpSink sink(config_for(*messages ? "ardupilot" : "px4", messages), out);
    sink.publish(update_of(posts, 1, 1.0), 1.0);
    sink.tick(1.15);
    EXPECT_EQ(out.count(330), 2) << messages;
    EXPECT_EQ(out.count(11037), 0) << messages;
  }
}
