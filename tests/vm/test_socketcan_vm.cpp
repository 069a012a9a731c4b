// SocketCAN against the real kernel and real peers (can-utils), run inside the
// test VM (tools/vm-test: Debian's generic kernel, vcan0 and vcan1 up). Statically
// linked; the host's ctest does not run it (the host kernel has no CAN).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "hal/can/can_pose_source.hpp"
#include "hal/can/candump.hpp"
#include "hal/can/ins_can.hpp"
#include "hal/can/obstacle_can.hpp"
#include "hal/can/obstacle_can_sink.hpp"
#include "hal/can/socketcan.hpp"
#include "hal/os/clock.hpp"

extern char** environ;

using namespace zonemap;
using namespace zonemap::can;

namespace {

// Runs a program to completion, stdout to `out_path` when given; returns its exit code.
int run(std::vector<std::string> args, const char* out_path = nullptr) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  if (out_path != nullptr) {
    posix_spawn_file_actions_addopen(&actions, 1, out_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
  }
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  const int err = posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (err != 0) return -1;
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

pid_t start(std::vector<std::string> args, const char* out_path) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, out_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), environ) != 0) pid = -1;
  posix_spawn_file_actions_destroy(&actions);
  return pid;
}

std::string slurp(const char* path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

struct CollectingSink : hal::PoseSink {
  std::vector<PoseSample> poses;
  void push(const PoseSample& p) override { poses.push_back(p); }
};

std::vector<CanFrame> drain(SocketCan& socket) {
  std::vector<CanFrame> frames;
  CanFrame f;
  while (socket.wait_readable(200) && socket.receive(&f) == CanIo::kOk) frames.push_back(f);
  return frames;
}

}  // namespace

TEST(SocketCanVm, FiltersLetOnlyTheProfileIdsThroughWithKernelTimestamps) {
  InsCanConfig profile;
  InsCanDecoder decoder(profile);
  SocketCan rx, tx;
  char error[192];
  ASSERT_TRUE(rx.open("vcan0", decoder.ids(), false, error, sizeof error)) << error;
  ASSERT_TRUE(tx.open("vcan0", {}, false, error, sizeof error)) << error;
  const double before = os::realtime_now_s();
  for (std::uint32_t id : {0x130u, 0x131u, 0x132u, 0x200u, 0x134u, 0x135u, 0x136u}) {
    CanFrame f;
    f.id = id;
    f.dlc = 8;
    f.data[0] = static_cast<std::uint8_t>(id);
    ASSERT_EQ(tx.send(f), CanIo::kOk);
  }
  CanFrame ext;
  ext.id = 0x130;
  ext.extended = true;
  ext.dlc = 1;
  ASSERT_EQ(tx.send(ext), CanIo::kOk);
  const std::vector<CanFrame> got = drain(rx);
  ASSERT_EQ(got.size(), 5u);
  const std::uint32_t expected[] = {0x130, 0x131, 0x134, 0x135, 0x136};
  for (std::size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].id, expected[i]);
    EXPECT_FALSE(got[i].extended);
    EXPECT_EQ(got[i].data[0], static_cast<std::uint8_t>(expected[i]));
    EXPECT_GE(got[i].time_s, before - 1e-3);
    EXPECT_LE(got[i].time_s, os::realtime_now_s());
    if (i > 0) {
      EXPECT_GE(got[i].time_s, got[i - 1].time_s);
    }
  }
}

TEST(SocketCanVm, PoseSourceDecodesSbgFramesFromTheBus) {
  InsCanConfig profile;
  profile.time_source = InsTimeSource::kIns;
  profile.has_origin = true;
  profile.origin = {47.0, 8.0, 400.0};
  SocketCanPoseSource source("vcan0", profile, {}, Eigen::Isometry3d::Identity(), 0.0);
  CollectingSink sink;
  source.poll(sink, 0);  // opens the socket before the INS starts talking
  SocketCan tx;
  char error[192];
  ASSERT_TRUE(tx.open("vcan0", {}, false, error, sizeof error)) << error;
  LocalTangentPlane plane(profile.origin);
  for (int i = 0; i < 50; ++i) {
    SbgSample s;
    s.time_us = static_cast<std::uint32_t>(1'000'000 + i * 20'000);
    s.position = plane.to_geodetic(Eigen::Vector3d(0.4 * i, 0.1 * i, -30.0));
    CanFrame frames[5];
    const int n = encode_sbg(s, profile, 0.0, frames);
    for (int k = 0; k < n; ++k) ASSERT_EQ(tx.send(frames[k]), CanIo::kOk);
  }
  while (source.poll(sink, 200) != hal::PollResult::kIdle) {
  }
  ASSERT_EQ(sink.poses.size(), 50u);
  for (int i = 0; i < 50; ++i) {
    EXPECT_NEAR(sink.poses[i].time_s, 1.0 + i * 0.02, 1e-9);
    EXPECT_LT((sink.poses[i].position - Eigen::Vector3d(0.4 * i, 0.1 * i, -30.0)).norm(), 0.03);
  }
  EXPECT_EQ(source.counters().malformed, 0);
}

TEST(SocketCanVm, CansendIsReceivedAndCandumpLogsOurObstacleUpdate) {
  SocketCan rx;
  char error[192];
  ASSERT_TRUE(rx.open("vcan1", {}, false, error, sizeof error)) << error;
  ASSERT_EQ(run({"cansend", "vcan1", "123#DEADBEEF"}), 0);
  const std::vector<CanFrame> got = drain(rx);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].id, 0x123u);
  EXPECT_EQ(got[0].dlc, 4);
  EXPECT_EQ(got[0].data[3], 0xEF);

  // candump -L logs what we send; a probe frame shows when it is listening.
  const char* log = "/tmp/obstacles.candump";
  const pid_t candump = start({"candump", "-L", "vcan1"}, log);
  ASSERT_GT(candump, 0);
  SocketCan tx;
  ASSERT_TRUE(tx.open("vcan1", {}, false, error, sizeof error)) << error;
  CanFrame probe;
  probe.id = 0x7AA;
  probe.dlc = 1;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (slurp(log).find("7AA#") == std::string::npos) {
    ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "candump never logged the probe";
    ASSERT_EQ(tx.send(probe), CanIo::kOk);
    rx.wait_readable(50);  // paces the probes on the bus itself
    CanFrame dummy;
    while (rx.receive(&dummy) == CanIo::kOk) {
    }
  }
  std::vector<ObstacleBox> boxes(12);
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    boxes[i].id = static_cast<std::uint32_t>(i + 1);
    boxes[i].min = Eigen::Vector3d(10.0 * static_cast<double>(i), 5.0, -20.0);
    boxes[i].max = boxes[i].min + Eigen::Vector3d(1.5, 2.5, 20.0);
  }
  // The daemon's CAN output itself, on its own socket.
  CanObstacleSink sink("vcan1", ObstacleCanConfig{}, boxes.size());
  hal::ObstacleUpdate update;
  update.boxes = boxes.data();
  update.count = boxes.size();
  sink.publish(update, 0.0);
  EXPECT_EQ(sink.updates_cut_short(), 0) << sink.link_counters().tx_link_down;
  EXPECT_EQ(sink.link_counters().tx_frames, 2 + 2 * static_cast<std::int64_t>(boxes.size()));
  probe.id = 0x7AB;
  while (slurp(log).find("7AB#") == std::string::npos) {
    ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "candump never logged the update";
    ASSERT_EQ(tx.send(probe), CanIo::kOk);
    rx.wait_readable(50);
    CanFrame dummy;
    while (rx.receive(&dummy) == CanIo::kOk) {
    }
  }
  kill(candump, SIGTERM);
  waitpid(candump, nullptr, 0);
  std::ifstream in(log);
  std::string line;
  ObstacleCanDecoder decoder;
  int updates = 0;
  while (std::getline(in, line)) {
    CanFrame f;
    const char* why = nullptr;
    ASSERT_NE(parse_candump_line(line, &f, nullptr, &why), CandumpLine::kMalformed) << line;
    if (decoder.feed(f)) ++updates;
  }
  ASSERT_EQ(updates, 1);
  ASSERT_EQ(decoder.boxes().size(), boxes.size());
  for (const DecodedObstacleBox& d : decoder.boxes()) {
    const ObstacleBox& b = boxes[d.id - 1];
    EXPECT_LT((d.min - b.min).cwiseAbs().maxCoeff(), 0.1 + 1e-9);
    EXPECT_LT((d.max - b.max).cwiseAbs().maxCoeff(), 0.1 + 1e-9);
  }
}

TEST(SocketCanVm, CanplayerReplaysACandumpLogIntoThePoseSource) {
  InsCanConfig profile;
  profile.profile = InsCanProfile::kZonemapIns;
  profile.time_source = InsTimeSource::kIns;
  const char* log = "/tmp/ins.candump";
  {
    std::ofstream out(log);
    for (int i = 0; i < 20; ++i) {
      ZonemapInsSample s;
      s.sequence = static_cast<std::uint8_t>(i);
      s.time_us = 5'000'000u + static_cast<std::uint64_t>(i) * 10'000u;
      s.ned_m = {1.0 * i, -2.0, -40.0};
      CanFrame frames[4];
      const int n = encode_zonemap_ins(s, profile, 100.0 + i * 0.01, frames);
      for (int k = 0; k < n; ++k) {
        char buf[80];
        const std::size_t len = format_candump_line(frames[k], "can0", buf, sizeof buf);
        out << std::string(buf, len) << "\n";
      }
    }
  }
  SocketCanPoseSource source("vcan0", profile, {}, Eigen::Isometry3d::Identity(), 0.0);
  CollectingSink sink;
  source.poll(sink, 0);
  ASSERT_EQ(run({"canplayer", "-I", log, "vcan0=can0"}), 0);
  while (source.poll(sink, 200) != hal::PollResult::kIdle) {
  }
  ASSERT_EQ(sink.poses.size(), 20u);
  EXPECT_NEAR(sink.poses[19].position.x(), 19.0, 1e-3);
  EXPECT_NEAR(sink.poses[19].time_s, 5.19, 1e-9);
}

TEST(SocketCanVm, LinkDownIsCountedAndReopenedWithBackoff) {
  CanLink link("vcan1", {}, false, 0.1, 1.0);
  CanFrame f;
  f.id = 0x55;
  f.dlc = 2;
  double now = 0.0;
  ASSERT_EQ(link.send(f, now), CanIo::kOk) << link.last_error();
  ASSERT_EQ(run({"ip", "link", "set", "vcan1", "down"}), 0);
  EXPECT_EQ(link.send(f, now), CanIo::kDown);
  EXPECT_EQ(link.counters().link_down_events, 1);
  EXPECT_EQ(link.send(f, now + 0.05), CanIo::kDown);  // backing off: no attempt yet
  EXPECT_EQ(link.counters().reopen_attempts, 1);
  ASSERT_EQ(run({"ip", "link", "set", "vcan1", "up"}), 0);
  now += 0.2;
  EXPECT_EQ(link.send(f, now), CanIo::kOk) << link.last_error();
  EXPECT_EQ(link.counters().reopens, 1);
  // The interface removed and created again.
  ASSERT_EQ(run({"ip", "link", "del", "vcan1"}), 0);
  now += 1.0;
  EXPECT_EQ(link.send(f, now), CanIo::kDown);
  now += 2.0;
  EXPECT_EQ(link.send(f, now), CanIo::kDown);  // reopen fails: no such device
  ASSERT_EQ(run({"ip", "link", "add", "dev", "vcan1", "type", "vcan"}), 0);
  ASSERT_EQ(run({"ip", "link", "set", "vcan1", "up"}), 0);
  now += 5.0;
  EXPECT_EQ(link.send(f, now), CanIo::kOk) << link.last_error();
  EXPECT_GE(link.counters().tx_link_down, 4);
  EXPECT_EQ(link.counters().tx_frames, 3);
}
