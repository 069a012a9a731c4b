// The autopilot's EKF as the INS: TIMESYNC onto our clock, attitude and position
// paired into solutions through the INS gate, one bad message costing only itself,
// and the messages asked for over a real loopback socket.
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <vector>

#include "hal/mavlink/mavlink_inbound.hpp"
#include "hal/mavlink/mavlink_pose_source.hpp"
#include "hal/mavlink/obstacle_distance_mavlink.hpp"
#include "hal/os/allocation_counter.hpp"

using namespace zonemap;

namespace {

struct Poses final : hal::PoseSink {
  std::vector<PoseSample> got;
  void push(const PoseSample& p) override { got.push_back(p); }
};

// Frames as the autopilot (system 1, component 1) sends them.
std::size_t frame(std::uint32_t id, std::uint8_t crc_extra, const std::uint8_t* payload,
                  std::size_t size, std::uint8_t* buf, std::uint8_t system = 1) {
  return mavlink::encode_frame(id, crc_extra, payload, size, {system, 1}, 0, buf);
}
std::size_t attitude(std::uint32_t boot_ms, Eigen::Quaternionf q, std::uint8_t* buf) {
  std::uint8_t p[48] = {};
  const float wxyz[4] = {q.w(), q.x(), q.y(), q.z()};
  std::memcpy(p, &boot_ms, 4);
  std::memcpy(p + 4, wxyz, 16);
  return frame(mavlink::kAttitudeQuaternionId, 246, p, sizeof p, buf);
}
std::size_t position(std::uint32_t boot_ms, float n, float e, float d, std::uint8_t* buf,
                     std::uint8_t system = 1) {
  std::uint8_t p[28] = {};
  const float ned[3] = {n, e, d};
  std::memcpy(p, &boot_ms, 4);
  std::memcpy(p + 4, ned, 12);
  return frame(mavlink::kLocalPositionNedId, 185, p, sizeof p, buf, system);
}
// The autopilot's answer to our TIMESYNC sent at ts1 (s): its clock reads tc1 (s).
std::size_t timesync_answer(double ts1_s, double tc1_s, std::uint8_t* buf) {
  const mavlink::Timesync t{static_cast<std::int64_t>(std::llround(tc1_s * 1e9)),
                            static_cast<std::int64_t>(std::llround(ts1_s * 1e9))};
  return mavlink::encode_timesync(t, 1, 1, 0, buf);
}

mavlink::MavlinkPoseSource source_with_identity_mount() {
  return mavlink::MavlinkPoseSource({}, InsGateConfig{}, Eigen::Isometry3d::Identity(), 0.0);
}

}  // namespace

TEST(ClockSync, TakesTheRoundTripsMidpointAndAdoptsAStepOnlyWhenItPersists) {
  mavlink::ClockSync clock;
  EXPECT_FALSE(clock.add(10.0, 510.0, 10.2, 0.05));  // 200 ms round trip: says nothing
  EXPECT_FALSE(clock.synced());
  EXPECT_TRUE(clock.add(10.0, 510.005, 10.01, 0.05));
  EXPECT_NEAR(clock.offset_s(), 500.0, 1e-9);
  EXPECT_FALSE(clock.add(11.0, 531.005, 11.01, 0.05));  // one odd answer: ignored
  EXPECT_NEAR(clock.offset_s(), 500.0, 1e-9);
  EXPECT_TRUE(clock.add(12.0, 512.007, 12.01, 0.05));  // jitter: smoothed
  EXPECT_NEAR(clock.offset_s(), 500.0002, 1e-6);
  for (int i = 0; i < 3; ++i) clock.add(13.0 + i, 33.005 + i, 13.01 + i, 0.05);  // rebooted
  EXPECT_NEAR(clock.offset_s(), 20.0, 1e-6);
  EXPECT_EQ(clock.steps(), 1);
}

TEST(MavlinkPoseSource, PairsAttitudeAndPositionOntoOurClockInTheNedFrame) {
  auto source = source_with_identity_mount();
  Poses poses;
  std::uint8_t buf[128];
  const Eigen::Quaternionf yaw90(
      Eigen::AngleAxisf(static_cast<float>(M_PI / 2), Eigen::Vector3f::UnitZ()));
  // Before the clocks are synced a solution's time would be a guess: none goes.
  source.on_datagram(buf, attitude(1000, yaw90, buf), poses, 5.0);
  source.on_datagram(buf, position(1000, 1, 2, -3, buf), poses, 5.0);
  EXPECT_TRUE(poses.got.empty());
  EXPECT_EQ(source.counters().incomplete, 1);
  // The autopilot's clock reads 1.000 s when ours reads 5.0 s (round trip 10 ms).
  source.on_datagram(buf, timesync_answer(4.995, 1.0, buf), poses, 5.005);
  ASSERT_TRUE(source.clock().synced());
  source.on_datagram(buf, attitude(1200, yaw90, buf), poses, 5.2);
  source.on_datagram(buf, position(1210, 10, 20, -30, buf), poses, 5.21);
  ASSERT_EQ(poses.got.size(), 1u);
  EXPECT_NEAR(poses.got[0].time_s, 5.21, 1e-6);
  EXPECT_TRUE(poses.got[0].position.isApprox(Eigen::Vector3d(10, 20, -30)));
  EXPECT_TRUE(poses.got[0].attitude.isApprox(yaw90.cast<double>(), 1e-6));
  // An attitude 100 ms older than the position makes no solution.
  source.on_datagram(buf, position(1310, 10, 20, -30, buf), poses, 5.31);
  EXPECT_EQ(poses.got.size(), 1u);
  EXPECT_EQ(source.counters().incomplete, 2);
}

TEST(MavlinkPoseSource, ABadValueAnotherSystemAndACorruptFrameCostOnlyThemselves) {
  auto source = source_with_identity_mount();
  Poses poses;
  std::uint8_t buf[128];
  const Eigen::Quaternionf level = Eigen::Quaternionf::Identity();
  source.on_datagram(buf, timesync_answer(0.995, 100.0, buf), poses, 1.005);
  poses.got.reserve(16);      // the test's sink: so that only the source's work is counted
  os::AllocationScope scope;  // the INS thread's work allocates nothing, rejections included
  for (int i = 0; i < 10; ++i) {
    const auto ms = static_cast<std::uint32_t>(100000 + 20 * i);
    source.on_datagram(buf, attitude(ms, level, buf), poses, 1.0 + 0.02 * i);
    const float north = i == 4 ? NAN : 0.1f * static_cast<float>(i);
    std::size_t n = position(ms, north, 0, -10, buf);
    if (i == 6) buf[12] ^= 0x10;                       // corrupt on the wire
    if (i == 8) n = position(ms, 50, 0, -10, buf, 2);  // another vehicle's
    source.on_datagram(buf, n, poses, 1.0 + 0.02 * i);
  }
  EXPECT_EQ(scope.counted().allocations, 0);
  EXPECT_EQ(poses.got.size(), 7u);  // 10 - NaN - corrupt - other vehicle
  const hal::PoseSourceCounters c = source.counters();
  EXPECT_EQ(c.malformed, 1);
  EXPECT_EQ(c.gate.rejected_total(), 1);
  EXPECT_EQ(c.poses_out, 7);
  for (const PoseSample& p : poses.got) EXPECT_LT(p.position.x(), 1.0);
}

TEST(MavlinkPoseSource, AsksTheAutopilotOverUdpForTimeAndTheMessagesItLacks) {
  mavlink::MavlinkPoseConfig config;
  config.listen = "127.0.0.1:0";
  mavlink::MavlinkPoseSource source(config, InsGateConfig{}, Eigen::Isometry3d::Identity(), 0.0);
  std::string error;
  ASSERT_TRUE(source.open(&error)) << error;
  const int autopilot = ::socket(AF_INET, SOCK_DGRAM, 0);
  ASSERT_GE(autopilot, 0);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  to.sin_port = htons(static_cast<std::uint16_t>(source.bound_port()));
  std::uint8_t buf[128];
  const std::size_t n = position(1, 0, 0, 0, buf);
  ASSERT_EQ(::sendto(autopilot, buf, n, 0, reinterpret_cast<sockaddr*>(&to), sizeof to),
            static_cast<ssize_t>(n));
  Poses poses;
  source.poll(poses, 1000);  // the datagram is there: poll returns at once
  // The source now knows its peer and asks it: TIMESYNC, and both messages at
  // its rate (the position came, but maybe slower than asked).
  std::vector<std::uint32_t> asked;
  for (int i = 0; i < 3; ++i) {
    std::uint8_t reply[128];
    const ssize_t got = ::recv(autopilot, reply, sizeof reply, MSG_DONTWAIT);
    if (got <= 0) break;
    asked.push_back(reply[7] | reply[8] << 8 | reply[9] << 16);
    if (asked.back() == 76) {  // COMMAND_LONG: SET_MESSAGE_INTERVAL
      float param1 = 0;
      std::memcpy(&param1, reply + 10, 4);
      EXPECT_TRUE(param1 == 31.0f || param1 == 32.0f);
    }
  }
  ::close(autopilot);
  EXPECT_EQ(asked, (std::vector<std::uint32_t>{mavlink::kTimesyncId, 76, 76}));
}
