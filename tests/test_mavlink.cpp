// MAVLink framing as the autopilots read it: CRC check value, CRC_EXTRA from the
// message definitions, OBSTACLE_DISTANCE, HEARTBEAT and OBSTACLE_DISTANCE_3D frames.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "hal/mavlink/obstacle_distance_mavlink.hpp"
#include "zonemap/obstacle_distance.hpp"

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
