// The onboard daemon end to end: its configuration (strict, --check-config), a
// generated flight with poses from an LCM log through every stage to boxes.csv
// (the same boxes as the single-threaded replay) and to MAVLink
// OBSTACLE_DISTANCE over loopback UDP, and a clean stop on SIGTERM.
#include <arpa/inet.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <lcm/eventlog.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "hal/config/prior_map.hpp"
#include "hal/ins_log/ins_logs.hpp"
#include "hal/lcm/lcm_codec.hpp"
#include "hal/mavlink/obstacle_distance_mavlink.hpp"
#include "hal/os/realtime.hpp"
#include "hal/output/run_outputs.hpp"
#include "onboard/vehicle_config.hpp"
#include "replay_support.hpp"
#include "test_support.hpp"
#include "tools/replay/replay_run.hpp"

extern char** environ;

using namespace zonemap;

namespace {

std::string slurp(const std::string& path) {
  return zonemap::testing::read_text(path);
}

// The sequence's camera poses as an INS would log them: the body's pose, the
// camera on the sequence's mount (camera.yaml names none: looking along the nose).
void write_ins_log(const replay::ReplaySequence& sequence, const std::string& path) {
  lcm_eventlog_t* log = lcm_eventlog_create(path.c_str(), "w");
  ASSERT_NE(log, nullptr);
  const Eigen::Isometry3d camera_T_body = sequence.camera().body_T_camera.inverse();
  for (const PoseSample& p : sequence.poses().samples()) {
    Eigen::Isometry3d world_T_camera = Eigen::Isometry3d::Identity();
    world_T_camera.linear() = p.attitude.toRotationMatrix();
    world_T_camera.translation() = p.position;
    const Eigen::Isometry3d world_T_body = world_T_camera * camera_T_body;
    InsSolution s;
    s.time_s = p.time_s;
    s.position_m = world_T_body.translation();
    s.attitude = Eigen::Quaterniond(world_T_body.linear()).normalized();
    s.attitude_valid = s.position_valid = true;
    s.position_sigma_m = 0.1;
    const auto utime = static_cast<std::int64_t>(std::llround(p.time_s * 1e6));
    const auto m = lcm_link::to_message(s, true, utime);
    std::vector<std::uint8_t> bytes(static_cast<std::size_t>(m.getEncodedSize()));
    m.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
    lcm_eventlog_event_t e{};
    e.timestamp = utime;
    e.channellen = 9;
    e.channel = const_cast<char*>("INS_STATE");
    e.datalen = static_cast<std::int32_t>(bytes.size());
    e.data = bytes.data();
    ASSERT_EQ(lcm_eventlog_write_event(log, &e), 0);
  }
  lcm_eventlog_destroy(log);
}

// A UDP socket on loopback standing in for the autopilot's MAVLink router.
struct UdpReceiver {
  int fd = -1;
  int port = 0;
  UdpReceiver() {
    fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
    socklen_t len = sizeof a;
    getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
    port = ntohs(a.sin_port);
  }
  ~UdpReceiver() { close(fd); }
  // Next datagram within timeout_ms, or empty.
  std::vector<std::uint8_t> receive(int timeout_ms) {
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, timeout_ms) <= 0) return {};
    std::vector<std::uint8_t> buf(512);
    const ssize_t n = recv(fd, buf.data(), buf.size(), 0);
    buf.resize(n > 0 ? static_cast<std::size_t>(n) : 0);
    return buf;
  }
};

pid_t spawn_daemon(const std::vector<std::string>& args, const std::string& stderr_path) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 2, stderr_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                   0644);
  // A cross build's daemon runs through the same emulator as the tests.
  std::vector<std::string> all;
  if (std::string(ZONEMAP_EMULATOR).size() > 0) all.push_back(ZONEMAP_EMULATOR);
  all.push_back(ZONEMAP_DAEMON_PATH);
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  return pid;
}

int wait_exit(pid_t pid) {
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -100 - WTERMSIG(status);
}

struct Flight {
  zonemap::testing::TempDir dir;
  std::string config;  // mapping config
  std::string sequence;
};

void make_flight(Flight* f, double rate_hz, std::size_t frames) {
  f->sequence = f->dir / "seq";
  f->config =
      zonemap::testing::write_test_scenario("posts-through", f->sequence, rate_hz, 4, frames);
  ASSERT_FALSE(f->config.empty());
  replay::ReplaySequence sequence;
  MapConfig map;
  std::string error;
  ASSERT_TRUE(sequence.open(f->sequence, "", map, &error)) << error;
  write_ins_log(sequence, f->dir / "ins.lcmlog");
}

std::string vehicle_yaml(const Flight& f, int mavlink_port, double replay_rate_hz) {
  std::ostringstream y;
  y << "mapping: " << f.config << "\n"
    << "frames: {source: replay, sequence: " << f.sequence << ", rate_hz: " << replay_rate_hz
    << "}\n"
    << "poses: {source: lcm_log, log: " << (f.dir / "ins.lcmlog") << ", lcm_channel: INS_STATE}\n"
    << "outputs:\n"
    << "  directory: " << (f.dir / "out") << "\n"
    << "  health_period_s: 0.5\n"
    << "  mavlink: {autopilot: px4, host: 127.0.0.1, port: " << mavlink_port << ", rate_hz: 50}\n";
  return y.str();
}

}  // namespace

// The executables refuse to start on a CPU without the instruction sets the build
// assumes (ZONEMAP_X86_LEVEL); the machine that builds and tests them has them.
TEST(Daemon, CpuRunsWhatTheBuildWasCompiledFor) {
  std::string missing;
  EXPECT_TRUE(zonemap::os::cpu_runs_this_build(&missing)) << missing;
  EXPECT_TRUE(missing.empty());
}

TEST(VehicleConfig, StrictWithFileAndLineAndRelativePaths) {
  zonemap::testing::TempDir dir;
  const std::string path = dir / "vehicle.yaml";
  std::ofstream(path) << "mapping: flight.yaml\nprior: maps/prior.csv\n"
                         "frames: {source: replay, sequence: seq}\n"
                         "poses: {source: can, can_profile: sbg-ecan, byte_order: big,\n"
                         "        ids: {info: 0x230}, origin: [48.1, 11.5, 520.0]}\n";
  onboard::VehicleConfig c;
  std::string error;
  ASSERT_TRUE(onboard::load_vehicle_config(path, &c, &error)) << error;
  EXPECT_EQ(c.mapping_path, dir / "flight.yaml");
  EXPECT_EQ(c.prior_path, dir / "maps/prior.csv");
  EXPECT_EQ(c.sequence_dir, dir / "seq");
  EXPECT_FALSE(c.can_profile.little_endian);
  EXPECT_EQ(c.can_profile.id_info, 0x230u);
  EXPECT_TRUE(c.can_profile.has_origin);
  // The INS frame's origin is the world's: said in the maps this vehicle shares.
  EXPECT_TRUE(c.lcm.has_world_origin);
  EXPECT_EQ(c.lcm.world_origin.latitude_deg, 48.1);
  const std::pair<const char*, const char*> bad[] = {
      {"mapping: m.yaml\nframes: {source: replay, sequence: s}\nposes: {source: gps}\n",
       "vehicle.yaml:3: poses.source must be one of"},
      {"mapping: m.yaml\nframes: {source: replay, sequence: s, speed: 2}\n",
       "vehicle.yaml:2: unknown key 'speed'"},
      {"frames: {source: replay, sequence: s}\n", "'mapping:'"},
      {"mapping: m.yaml\nframes: {source: replay}\n", "needs frames.sequence"},
      {"mapping: m.yaml\nframes: {source: replay, sequence: s}\n"
       "poses: {source: can, ids: {info: 0x40000000}}\n",
       "vehicle.yaml:3: bad value for 'info'"},
      {"mapping: m.yaml\nframes: {source: replay, sequence: s}\noutputs: {mavlink: {port: x}}\n",
       "vehicle.yaml:3: bad value for 'port'"},
      {"mapping: m.yaml\nframes: {source: replay, sequence: s}\noutputs: {mavlink: {port: 1}}\n",
       "outputs.mavlink.autopilot must be ardupilot"},
      {"mapping: m.yaml\nframes: {source: replay, sequence: s}\n"
       "outputs: {mavlink: {autopilot: px4, messages: 3d}}\n",
       "PX4 reads no OBSTACLE_DISTANCE_3D"},
      {"mapping: m.yaml\nframes: {source: replay, sequence: s}\n"
       "shared_maps: {channels: [OBSTACLE_MAP_HELI2]}\n",
       "shared_maps needs this vehicle's 'vehicle:' name and 'world_origin:'"},
      {"mapping: m.yaml\nframes: {source: replay, sequence: s}\nvehicle: h1\n"
       "world_origin: [48.1, 11.5, 520]\nshared_maps: {channels: []}\n",
       "shared_maps.channels must name 1 to 255"},
      {"mapping: m.yaml\nframes: {source: replay, sequence: s}\nworld_origin: [95, 11.5, 0]\n",
       "vehicle.yaml:3: world_origin is not a WGS84 position"},
      {"mapping: m.yaml\nframes: {source: replay, sequence: s}\nworld_origin: [48, 11]\n",
       "vehicle.yaml:3: world_origin must be [latitude, longitude, height]"},
      {"mapping: m.yaml\nframes: {source: replay, sequence: s}\nworld_origin: [48, 11, 0]\n"
       "poses: {source: can, origin: [48.1, 11.5, 520.0]}\n",
       "poses.origin and world_origin differ"}};
  for (const auto& [text, expected] : bad) {
    std::ofstream(path) << text;
    EXPECT_FALSE(onboard::load_vehicle_config(path, &c, &error)) << text;
    EXPECT_NE(error.find(expected), std::string::npos) << error;
  }
}

TEST(Daemon, ReplayWithLcmLogPosesGivesTheReplaysBoxesAndMavlinkOut) {
  Flight f;
  make_flight(&f, 4.0, 40);
  UdpReceiver autopilot;
  const std::string path = f.dir / "vehicle.yaml";
  std::ofstream(path) << vehicle_yaml(f, autopilot.port, 0.0);
  // --check-config: everything opened and reserved, nothing run.
  EXPECT_EQ(wait_exit(spawn_daemon({"--config", path, "--check-config"}, f.dir / "check.log")), 0);
  EXPECT_NE(slurp(f.dir / "check.log").find("configuration OK"), std::string::npos);
  EXPECT_EQ(wait_exit(spawn_daemon({"--config", path}, f.dir / "run.log")), 0)
      << slurp(f.dir / "run.log");

  // The single-threaded replay of the same flight (poses from groundtruth.txt).
  tools::ReplayRun replay;
  tools::ReplayOptions options = zonemap::testing::quiet_replay(f.sequence, f.config);
  std::string error;
  ASSERT_TRUE(replay.open(options, &error)) << error;
  replay.run();
  const std::vector<ObstacleBox> expected = replay.boxes(true);
  ASSERT_TRUE(
      hal::write_boxes_csv(f.dir / "replay-boxes.csv", expected.data(), expected.size(), &error));
  EXPECT_EQ(slurp(f.dir / "out/boxes.csv"), slurp(f.dir / "replay-boxes.csv"));
  const std::string stats = slurp(f.dir / "out/stats.json");
  EXPECT_NE(stats.find("\"frames_mapped\": 40"), std::string::npos) << stats;
  EXPECT_NE(stats.find("\"heap_allocations_after_init\": 0,"), std::string::npos) << stats;
  EXPECT_NE(stats.find("\"ins_poses_out\": 40"), std::string::npos) << stats;

  // OBSTACLE_DISTANCE frames reached the "autopilot", valid, with the posts ahead.
  int frames = 0, with_obstacle = 0, heartbeats = 0;
  for (auto d = autopilot.receive(100); !d.empty(); d = autopilot.receive(100)) {
    ASSERT_GE(d.size(), 12u);
    const int id = d[7] | d[8] << 8 | d[9] << 16;
    if (id == 0) ++heartbeats;
    if (id != static_cast<int>(mavlink::kObstacleDistanceId)) continue;
    mavlink::DecodedObstacleDistance m;
    ASSERT_TRUE(mavlink::decode_obstacle_distance(d.data(), d.size(), &m));
    ++frames;
    for (std::uint16_t cm : m.distances) {
      if (cm <= m.max_distance) {
        ++with_obstacle;
        break;
      }
    }
  }
  EXPECT_GE(frames, 5);
  EXPECT_GE(with_obstacle, 1);
  EXPECT_GE(heartbeats, 1);
}

TEST(Daemon, SigtermEndsTheRunCleanlyWithOutputs) {
  Flight f;
  make_flight(&f, 4.0, 40);
  UdpReceiver autopilot;
  const std::string path = f.dir / "vehicle.yaml";
  std::ofstream(path) << vehicle_yaml(f, autopilot.port, 4.0);  // paced: 10 s of flight
  const pid_t pid = spawn_daemon({"--config", path}, f.dir / "run.log");
  ASSERT_GT(pid, 0);
  // The first MAVLink frame shows it is mapping; then the signal.
  ASSERT_FALSE(autopilot.receive(30000).empty()) << slurp(f.dir / "run.log");
  kill(pid, SIGTERM);
  EXPECT_EQ(wait_exit(pid), 0) << slurp(f.dir / "run.log");
  const std::string stats = slurp(f.dir / "out/stats.json");
  EXPECT_NE(stats.find("\"stopped_by_signal\": 1"), std::string::npos) << stats;
  EXPECT_EQ(stats.find("\"frames_in\": 40,"), std::string::npos) << "stopped early: " << stats;
  EXPECT_FALSE(slurp(f.dir / "out/boxes.csv").empty());
}

// Whether the next OBSTACLE_DISTANCE within timeout_ms holds an obstacle in range;
// false also when none came.
bool next_obstacle_distance_holds_one(UdpReceiver& autopilot, int timeout_ms) {
  for (auto d = autopilot.receive(timeout_ms); !d.empty(); d = autopilot.receive(timeout_ms)) {
    const int id = d.size() >= 12 ? (d[7] | d[8] << 8 | d[9] << 16) : -1;
    if (id != static_cast<int>(mavlink::kObstacleDistanceId)) continue;
    mavlink::DecodedObstacleDistance m;
    if (!mavlink::decode_obstacle_distance(d.data(), d.size(), &m)) return false;
    for (std::uint16_t cm : m.distances) {
      if (cm <= m.max_distance) return true;
    }
    return false;
  }
  return false;
}

int obstacle_rows(const std::string& boxes_csv) {
  hal::PriorMap map;
  std::string error;
  return hal::load_prior_map(boxes_csv, true, &map, &error) ? static_cast<int>(map.boxes.size())
                                                            : -1;
}

// The flight with the camera looking back along it, never at the posts ahead.
std::string looking_back(const Flight& f) {
  return zonemap::testing::copy_looking_back(f.sequence, f.dir / "seq-back");
}

// The map outlives the flight: saved every half second while flying, it is whole
// after a kill -9, and the next start that takes it as its prior sends the posts
// to the autopilot from its first message and keeps them to its end, though its
// camera looks the other way the whole flight.
TEST(Daemon, AMapSavedInFlightSurvivesKill9AndIsTheNextStartsPrior) {
  Flight f;
  make_flight(&f, 4.0, 40);
  UdpReceiver autopilot;
  const std::string path = f.dir / "vehicle.yaml";
  std::ofstream(path) << vehicle_yaml(f, autopilot.port, 4.0) << "  save_map_every_s: 0.5\n";
  const pid_t pid = spawn_daemon({"--config", path}, f.dir / "run.log");
  ASSERT_GT(pid, 0);
  // Flying until a save holds both posts (each datagram paces the look).
  const std::string saved = f.dir / "out/boxes.csv";
  for (int i = 0; i < 400 && obstacle_rows(saved) < 2 && !autopilot.receive(1000).empty(); ++i) {
  }
  ASSERT_GE(obstacle_rows(saved), 2) << slurp(f.dir / "run.log");
  kill(pid, SIGKILL);
  EXPECT_EQ(wait_exit(pid), -100 - SIGKILL);
  EXPECT_GE(obstacle_rows(saved), 2) << "the saved map is whole after kill -9";

  UdpReceiver second;
  const std::string again = f.dir / "vehicle-again.yaml";
  std::ofstream(again) << "mapping: " << f.config << "\nprior: " << saved << "\n"
                       << "frames: {source: replay, sequence: " << looking_back(f)
                       << ", rate_hz: 4}\nposes: {source: sequence}\noutputs:\n  directory: "
                       << (f.dir / "out-again") << "\n  mavlink: {autopilot: px4, host: 127.0.0.1, "
                       << "port: " << second.port << ", rate_hz: 50}\n";
  const pid_t restarted = spawn_daemon({"--config", again}, f.dir / "again.log");
  ASSERT_GT(restarted, 0);
  EXPECT_TRUE(next_obstacle_distance_holds_one(second, 30000)) << slurp(f.dir / "again.log");
  EXPECT_EQ(wait_exit(restarted), 0) << slurp(f.dir / "again.log");
  hal::PriorMap end;
  std::string error;
  ASSERT_TRUE(hal::load_prior_map(f.dir / "out-again/boxes.csv", true, &end, &error)) << error;
  EXPECT_EQ(end.boxes.size(), 2u) << slurp(f.dir / "out-again/boxes.csv");
  const std::string csv = slurp(f.dir / "out-again/boxes.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 1 + 2 + end.ground_rows_skipped);
  EXPECT_NE(csv.find(",1\n"), std::string::npos) << "still prior: never seen: " << csv;
}

TEST(ReplaySequence, PosesFromInsLcmlogWhenThereIsNoGroundTruthMapTheSame) {
  Flight f;
  make_flight(&f, 4.0, 24);
  auto boxes_of = [&](const std::string& sequence) {
    tools::ReplayRun run;
    tools::ReplayOptions options = zonemap::testing::quiet_replay(sequence, f.config);
    std::string error;
    EXPECT_TRUE(run.open(options, &error)) << error;
    run.run();
    EXPECT_EQ(run.stats().frames_mapped, 24);
    return run.boxes(true);
  };
  const std::vector<ObstacleBox> with_truth = boxes_of(f.sequence);
  // The same sequence with the INS log instead of groundtruth.txt.
  std::filesystem::rename(f.sequence + "/groundtruth.txt", f.dir / "groundtruth.txt");
  std::filesystem::copy_file(f.dir / "ins.lcmlog", f.sequence + "/ins.lcmlog");
  const std::vector<ObstacleBox> with_ins = boxes_of(f.sequence);
  ASSERT_EQ(with_ins.size(), with_truth.size());
  for (std::size_t i = 0; i < with_ins.size(); ++i) {
    EXPECT_EQ(with_ins[i].min, with_truth[i].min);
    EXPECT_EQ(with_ins[i].max, with_truth[i].max);
    EXPECT_EQ(with_ins[i].cells, with_truth[i].cells);
  }
  // Neither: a clear error.
  std::filesystem::remove(f.sequence + "/ins.lcmlog");
  replay::ReplaySequence sequence;
  std::string error;
  const ins_log::SequenceInsLogs ins_logs;
  EXPECT_FALSE(sequence.open(f.sequence, "", MapConfig{}, &error, &ins_logs));
  EXPECT_NE(error.find("no pose source"), std::string::npos) << error;
}
