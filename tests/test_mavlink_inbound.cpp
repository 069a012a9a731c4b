// What the autopilot sends back: MAVLink 1 and 2 frames checked and read
// (AutopilotMonitor's heartbeats and proximity health), bad frames counted.
#include <gtest/gtest.h>

#include <cstring>
#include <string>

#include "hal/mavlink/autopilot_monitor.hpp"
#include "hal/mavlink/mavlink_inbound.hpp"
#include "hal/mavlink/obstacle_distance_mavlink.hpp"
#include "test_support.hpp"

using namespace zonemap;

namespace {

constexpr std::uint8_t kArduPilot = 3;  // MAV_AUTOPILOT_ARDUPILOTMEGA
constexpr std::uint8_t kQuadrotor = 2;  // MAV_TYPE_QUADROTOR

std::size_t heartbeat(std::uint8_t system, std::uint8_t component, std::uint8_t type,
                      std::uint8_t autopilot, std::uint8_t* buf) {
  std::uint8_t payload[mavlink::kHeartbeatPayload] = {};
  payload[4] = type;
  payload[5] = autopilot;
  payload[8] = 3;
  return mavlink::encode_frame(mavlink::kHeartbeatId, mavlink::kHeartbeatCrcExtra, payload,
                               sizeof payload, {system, component}, 0, buf);
}

std::size_t sys_status(std::uint32_t present, std::uint32_t enabled, std::uint32_t health,
                       std::uint8_t* buf) {
  std::uint8_t payload[43] = {};
  std::memcpy(payload, &present, 4);
  std::memcpy(payload + 4, &enabled, 4);
  std::memcpy(payload + 8, &health, 4);
  payload[30] = 100;  // battery_remaining: a byte after the sensor words
  return mavlink::encode_frame(mavlink::kSysStatusId, 124, payload, sizeof payload, {1, 1}, 0, buf);
}

// A MAVLink 1 heartbeat, framed by hand from the public framing rules.
std::size_t heartbeat_v1(std::uint8_t* buf) {
  const std::uint8_t header[] = {0xFE, 9, 7, 1, 1, 0};
  std::memcpy(buf, header, sizeof header);
  std::uint8_t payload[9] = {0, 0, 0, 0, kQuadrotor, kArduPilot, 0, 4, 3};
  std::memcpy(buf + 6, payload, 9);
  std::uint16_t crc = mavlink::crc_x25(buf + 1, 5 + 9);
  crc = mavlink::crc_x25(&mavlink::kHeartbeatCrcExtra, 1, crc);
  buf[15] = static_cast<std::uint8_t>(crc);
  buf[16] = static_cast<std::uint8_t>(crc >> 8);
  return 17;
}

}  // namespace

TEST(MavlinkInbound, ReadsVersion1And2FramesAndSkipsOthersByLength) {
  std::uint8_t datagram[256];
  std::size_t size = heartbeat(1, 1, kQuadrotor, kArduPilot, datagram);
  // A message zonemap does not read, then a MAVLink 1 heartbeat, in one datagram.
  std::uint8_t other[4] = {1, 2, 3, 4};
  size += mavlink::encode_frame(30, 39, other, sizeof other, {1, 1}, 0, datagram + size);
  size += heartbeat_v1(datagram + size);
  mavlink::InboundFrame frame;
  std::size_t used = 0;
  const std::uint8_t* at = datagram;
  ASSERT_EQ(mavlink::read_frame(at, size, &frame, &used), mavlink::FrameStatus::kKnown);
  EXPECT_EQ(mavlink::heartbeat_of(frame).autopilot, kArduPilot);
  at += used;
  ASSERT_EQ(mavlink::read_frame(at, datagram + size - at, &frame, &used),
            mavlink::FrameStatus::kOther);
  at += used;
  ASSERT_EQ(mavlink::read_frame(at, datagram + size - at, &frame, &used),
            mavlink::FrameStatus::kKnown);
  EXPECT_EQ(frame.message_id, mavlink::kHeartbeatId);
  EXPECT_EQ(mavlink::heartbeat_of(frame).type, kQuadrotor);
  EXPECT_EQ(at + used, datagram + size);
}

TEST(MavlinkInbound, ABadCrcATruncatedFrameAndGarbageAreRejected) {
  std::uint8_t buf[64];
  const std::size_t size = heartbeat(1, 1, kQuadrotor, kArduPilot, buf);
  mavlink::InboundFrame frame;
  std::size_t used = 0;
  EXPECT_EQ(mavlink::read_frame(buf, size - 1, &frame, &used), mavlink::FrameStatus::kTruncated);
  buf[12] ^= 0x40;
  EXPECT_EQ(mavlink::read_frame(buf, size, &frame, &used), mavlink::FrameStatus::kBad);
  EXPECT_EQ(used, 0u);
  const std::uint8_t garbage[] = {0x55, 0xFD, 0x09};
  EXPECT_EQ(mavlink::read_frame(garbage, sizeof garbage, &frame, &used),
            mavlink::FrameStatus::kBad);
  // A payload longer than the message's definition is not read as the message.
  std::uint8_t long_payload[20] = {0, 0, 0, 0, 1, 1, 0, 0, 3, 9, 9, 9};
  const std::size_t n = mavlink::encode_frame(mavlink::kHeartbeatId, mavlink::kHeartbeatCrcExtra,
                                              long_payload, 12, {1, 1}, 0, buf);
  EXPECT_EQ(mavlink::read_frame(buf, n, &frame, &used), mavlink::FrameStatus::kBad);
}

TEST(AutopilotMonitor, CountsTheAutopilotsHeartbeatsAndNoticesSilence) {
  mavlink::AutopilotMonitor monitor(1);
  std::uint8_t buf[64];
  // Ours, a ground station's and another vehicle's heartbeats are not the autopilot's.
  monitor.on_datagram(buf, heartbeat(1, 195, mavlink::kTypeOnboardController, 8, buf), 0.0);
  monitor.on_datagram(buf, heartbeat(255, 190, 6, 8, buf), 0.0);
  monitor.on_datagram(buf, heartbeat(2, 1, kQuadrotor, kArduPilot, buf), 0.0);
  EXPECT_FALSE(monitor.autopilot_present());
  for (int s = 0; s < 5; ++s) {
    monitor.on_datagram(buf, heartbeat(1, 1, kQuadrotor, kArduPilot, buf), s);
    monitor.update(s + 0.5);
  }
  EXPECT_TRUE(monitor.autopilot_present());
  monitor.update(4.0 + mavlink::AutopilotMonitor::kHeartbeatTimeoutS + 0.1);
  EXPECT_FALSE(monitor.autopilot_present());
  hal::HealthSnapshot h;
  monitor.report(&h);
  const auto value = [&h](const char* name) { return zonemap::testing::named_value(h, name); };
  EXPECT_EQ(value("mavlink_autopilot_heartbeats"), 5);
  EXPECT_EQ(value("mavlink_autopilot_lost"), 1);
  EXPECT_EQ(value("mavlink_autopilot_present"), 0);
  EXPECT_EQ(value("mavlink_in_frames"), 8);
  buf[20] ^= 1;  // a corrupted frame costs only itself
  monitor.on_datagram(buf, heartbeat(1, 1, kQuadrotor, kArduPilot, buf) - 1, 9.0);
  h = {};
  monitor.report(&h);
  EXPECT_EQ(value("mavlink_in_rejected"), 1);
  EXPECT_EQ(value("mavlink_autopilot_heartbeats"), 5);
}

TEST(AutopilotMonitor, ReadsWhetherTheAutopilotTakesProximityData) {
  mavlink::AutopilotMonitor monitor(1);
  std::uint8_t buf[64];
  const std::uint32_t p = mavlink::kSysStatusProximity;
  monitor.on_datagram(buf, sys_status(0, 0, 0, buf), 0.0);  // no proximity sensor: not said
  EXPECT_EQ(monitor.proximity_state(), -1);
  monitor.on_datagram(buf, sys_status(p, p, p, buf), 0.1);
  EXPECT_EQ(monitor.proximity_state(), 1);
  monitor.on_datagram(buf, sys_status(p, p, 0, buf), 0.2);  // PreArm: PRX1: No Data
  EXPECT_EQ(monitor.proximity_state(), 0);
  monitor.on_datagram(buf, sys_status(p, p, p, buf), 0.3);
  monitor.on_datagram(buf, sys_status(p, 0, p, buf), 0.4);  // switched off
  EXPECT_EQ(monitor.proximity_state(), 0);
  hal::HealthSnapshot h;
  monitor.report(&h);
  EXPECT_EQ(zonemap::testing::named_value(h, "mavlink_autopilot_proximity_lost"), 2);
}
