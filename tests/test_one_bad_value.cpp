// One bad value costs only itself: a stray timestamp, pose or image inside an
// otherwise good flight is refused and counted, and the rest of the flight maps as
// the clean run does. The time watermark and the INS gate on their own first, then
// every kind of bad value, one at a time, in a replayed flight.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>

#include <lcm/eventlog.h>

#include "hal/can/candump.hpp"
#include "hal/can/ins_can.hpp"
#include "hal/codec/png_io.hpp"
#include "hal/lcm/lcm_codec.hpp"
#include "hal/output/run_outputs.hpp"
#include "replay_support.hpp"
#include "test_support.hpp"
#include "tools/replay/replay_run.hpp"
#include "zonemap/common/time_watermark.hpp"
#include "zonemap/pose/ins_gate.hpp"
#include "zonemap/pose/pose_buffer.hpp"

namespace zonemap {
namespace {

using testing::valid_at;

TEST(InsGate, OneSolutionWithAGarbageTimeCostsOnlyItself) {
  for (const double bad : {99999.0, -1.0, 0.5, double(NAN)}) {
    InsGate gate;
    int refused = 0;
    for (int i = 0; i < 200; ++i) {  // 100 Hz, 10 m/s
      const double t = i == 100 ? bad : 0.01 * i;
      refused += gate.check(valid_at(t, {0.1 * i, 0, 0}), nullptr) ? 0 : 1;
    }
    EXPECT_EQ(refused, 1) << "bad time " << bad;
  }
  // A clock that really stepped is adopted after three solutions, and counted.
  InsGate gate;
  for (int i = 0; i < 100; ++i)
    ASSERT_TRUE(gate.check(valid_at(0.01 * i, {0.1 * i, 0, 0}), nullptr));
  int refused = 0;
  for (int i = 0; i < 100; ++i) {
    refused += gate.check(valid_at(500.0 + 0.01 * i, {10 + 0.1 * i, 0, 0}), nullptr) ? 0 : 1;
  }
  EXPECT_EQ(refused, 2);
  EXPECT_EQ(gate.counters().clock_steps, 1);
  EXPECT_EQ(gate.counters().rejected[static_cast<int>(InsRejection::kTimeOutlier)], 2);
}

TEST(PoseBuffer, AfterAClockStepTheNewestClocksSamplesAreKept) {
  PoseBuffer<16> buffer;
  for (int i = 0; i < 8; ++i)
    buffer.push({10.0 + 0.1 * i, Eigen::Vector3d(i, 0, 0), Eigen::Quaterniond::Identity()});
  for (int i = 0; i < 4; ++i)
    buffer.push({1.0 + 0.1 * i, Eigen::Vector3d(100 + i, 0, 0), Eigen::Quaterniond::Identity()});
  PoseTrack track(0.5, 0.02);
  track.reserve(16);
  EXPECT_DOUBLE_EQ(buffer.snapshot(&track), 1.3);
  ASSERT_EQ(track.size(), 4u);
  Eigen::Isometry3d pose;
  ASSERT_NE(track.lookup(1.15, &pose), PoseLookup::kNoPose);
  EXPECT_NEAR(pose.translation().x(), 101.5, 1e-9);
}

// ---- one bad value in a replayed flight

using testing::read_text;
using testing::write_text;

// Replaces line `n` (0-based, comments included) of a text file.
void edit_line(const std::string& path, int n,
               const std::function<std::string(const std::string&)>& fn) {
  std::istringstream in(read_text(path));
  std::ostringstream out;
  std::string line;
  for (int i = 0; std::getline(in, line); ++i) out << (i == n ? fn(line) : line) << "\n";
  write_text(path, out.str());
}
std::vector<std::string> fields(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> f;
  for (std::string x; in >> x;) f.push_back(x);
  return f;
}
std::string joined(const std::vector<std::string>& f) {
  std::string s;
  for (const auto& x : f) s += (s.empty() ? "" : " ") + x;
  return s;
}

struct RunResult {
  hal::RunStats stats;
  std::vector<ObstacleBox> boxes;
  std::string json;
};

// The run with one bad item found the clean run's objects: the same boxes, each
// edge within a cell (a frame fewer may move an edge by a cell).
void expect_boxes_within_a_cell(const RunResult& got, const RunResult& clean) {
  ASSERT_EQ(got.boxes.size(), clean.boxes.size()) << got.json;
  const double cell = clean.stats.cell_size_m;
  for (std::size_t i = 0; i < got.boxes.size(); ++i) {
    EXPECT_LE((got.boxes[i].min - clean.boxes[i].min).cwiseAbs().maxCoeff(), cell + 1e-9) << i;
    EXPECT_LE((got.boxes[i].max - clean.boxes[i].max).cwiseAbs().maxCoeff(), cell + 1e-9) << i;
  }
}

RunResult replay(const std::string& sequence, const std::string& config) {
  tools::ReplayRun run;
  tools::ReplayOptions options = testing::quiet_replay(sequence, config);
  std::string error;
  EXPECT_TRUE(run.open(options, &error)) << error;
  run.run();
  RunResult r;
  r.stats = run.stats();
  r.boxes = run.boxes(true);
  testing::TempDir out;
  EXPECT_TRUE(run.write_outputs(out.path(), &error)) << error;
  r.json = read_text(out / "stats.json");
  return r;
}

struct BadValue {
  const char* name;
  std::function<void(const std::string& seq)> inject;
  int frames_lost;      // at most
  const char* counted;  // the stats.json key that counts it
};

void PrintTo(const BadValue& bad, std::ostream* out) {
  *out << bad.name;
}

class OneBadValue : public ::testing::TestWithParam<BadValue> {};

// Frame 12 of 24 (line 13 of depth.txt / groundtruth.txt: line 0 is a comment).
constexpr int kLine = 13;

// Sets field `field` of the kLine-th pose line to what `value` makes of the old one.
std::function<void(const std::string&)> edit_pose_field(
    int field, std::function<std::string(const std::string&)> value) {
  return [field, value](const std::string& s) {
    edit_line(s + "/groundtruth.txt", kLine, [&](const std::string& l) {
      auto f = fields(l);
      f[static_cast<std::size_t>(field)] = value(f[static_cast<std::size_t>(field)]);
      return joined(f);
    });
  };
}
std::function<void(const std::string&)> set_pose_field(int field, const std::string& value) {
  return edit_pose_field(field, [value](const std::string&) { return value; });
}
constexpr int kFrames = 24;

const BadValue kBadValues[] = {
    {"FrameStampFarInTheFuture",
     [](const std::string& s) {
       edit_line(s + "/depth.txt", kLine,
                 [](const std::string& l) { return "999999999 " + fields(l)[1]; });
     },
     1, "frames_time_future"},
    {"FrameStampFromThePast",
     [](const std::string& s) {
       edit_line(s + "/depth.txt", kLine,
                 [](const std::string& l) { return "0.5 " + fields(l)[1]; });
     },
     1, "frames_time_past"},
    {"FrameStampRepeated",
     [](const std::string& s) {
       const auto prev = fields([&] {
         std::istringstream in(read_text(s + "/depth.txt"));
         std::string line;
         for (int i = 0; i < kLine && std::getline(in, line); ++i) {
         }
         return line;
       }());
       edit_line(s + "/depth.txt", kLine,
                 [&](const std::string& l) { return prev[0] + " " + fields(l)[1]; });
     },
     1, "frames_time_repeated"},
    {"FrameStampNan",
     [](const std::string& s) {
       edit_line(s + "/depth.txt", kLine,
                 [](const std::string& l) { return "nan " + fields(l)[1]; });
     },
     1, "frames_time_not_finite"},
    {"PoseStampFarInTheFuture", set_pose_field(0, "99999.0"), 1, "poses_time_future"},
    {"PoseStampFromThePast", set_pose_field(0, "0.3"), 1, "poses_time_past"},
    {"PoseNan", set_pose_field(2, "nan"), 1, "poses_not_finite"},
    {"PoseQuaternionNotUnit", set_pose_field(7, "1.5"), 1, "poses_quaternion"},
    {"PoseOneKilometreAway",
     edit_pose_field(1, [](const std::string& x) { return std::to_string(std::stod(x) + 1000.0); }),
     1, "poses_jump"},
    {"CorruptPng",
     [](const std::string& s) { write_text(s + "/depth/000012.png", "\x89PNG\r\n\x1a\n garbage"); },
     1, "frames_rejected_bad_image"},
    {"TruncatedPng",
     [](const std::string& s) {
       const std::string png = read_text(s + "/depth/000012.png");
       write_text(s + "/depth/000012.png", png.substr(0, png.size() / 2));
     },
     1, "frames_rejected_bad_image"},
    {"WrongSizeFrame",
     [](const std::string& s) {
       // A valid 16-bit PNG at half the size.
       std::vector<std::uint16_t> depth(320 * 240, 20000);
       std::string error;
       ASSERT_TRUE(hal::write_png_gray16(s + "/depth/000012.png", 320, 240, depth.data(), &error));
     },
     1, "frames_rejected_bad_image"},
};

// The value stats.json gives `key` (top level or in "rejections").
std::int64_t counter(const std::string& json, const std::string& key) {
  const auto at = json.find("\"" + key + "\": ");
  if (at == std::string::npos) return -1;
  return std::stoll(json.substr(at + key.size() + 4));
}

TEST_P(OneBadValue, CostsAtMostTheFramesItTouchesAndTheRestMapsAsTheCleanRun) {
  const BadValue& bad = GetParam();
  testing::TempDir dir;
  const std::string clean_seq = dir / "clean", bad_seq = dir / "bad";
  const std::string config =
      testing::write_test_scenario("posts-through", clean_seq, 4.0, 4, kFrames);
  ASSERT_FALSE(config.empty());
  std::filesystem::copy(clean_seq, bad_seq, std::filesystem::copy_options::recursive);
  bad.inject(bad_seq);
  const RunResult clean = replay(clean_seq, config);
  const RunResult got = replay(bad_seq, config);
  ASSERT_EQ(clean.stats.frames_mapped, kFrames);
  EXPECT_GE(got.stats.frames_mapped, kFrames - bad.frames_lost) << got.json;
  EXPECT_EQ(got.stats.frames_in,
            got.stats.frames_mapped + got.stats.frames_rejected + got.stats.frames_skipped_no_pose);
  EXPECT_EQ(counter(got.json, bad.counted), 1) << bad.counted << "\n" << got.json;
  EXPECT_EQ(got.stats.zones_allocated, clean.stats.zones_allocated)
      << "mapped where the vehicle never was";
  expect_boxes_within_a_cell(got, clean);
  if (::testing::Test::HasFatalFailure()) return;
  if (got.stats.frames_mapped == clean.stats.frames_mapped) {  // nothing lost: the clean map
    for (std::size_t i = 0; i < got.boxes.size(); ++i)
      EXPECT_EQ(got.boxes[i].cells, clean.boxes[i].cells) << i;
  }
}

std::string bad_value_name(const ::testing::TestParamInfo<BadValue>& param) {
  return param.param.name;
}
INSTANTIATE_TEST_SUITE_P(Replay, OneBadValue, ::testing::ValuesIn(kBadValues), bad_value_name);

// ---- one bad INS message in a flight replayed from its INS log (ins.lcmlog)

// One INS log event: the bytes of an ins_state_t (a test may damage them) at `utime`.
struct InsEvent {
  std::int64_t utime = 0;
  std::vector<std::uint8_t> bytes;
};

// The flight's body poses (camera on the default mount) as an INS logs them, at
// four times the frame rate (interpolated), so that one refused solution costs no
// frame: the mapper interpolates across it.
std::vector<InsEvent> ins_events(const replay::ReplaySequence& sequence) {
  const Eigen::Isometry3d camera_T_body = sequence.camera().body_T_camera.inverse();
  const auto& samples = sequence.poses().samples();
  std::vector<InsEvent> events;
  const double t0 = samples.front().time_s, t1 = samples.back().time_s;
  const double step = (samples[1].time_s - samples[0].time_s) / 4.0;
  for (double t = t0; t <= t1 + 1e-9; t += step) {
    Eigen::Isometry3d world_T_camera;
    if (sequence.poses().lookup(t, &world_T_camera) == PoseLookup::kNoPose) continue;
    const Eigen::Isometry3d world_T_body = world_T_camera * camera_T_body;
    InsSolution s;
    s.time_s = t;
    s.position_m = world_T_body.translation();
    s.attitude = Eigen::Quaterniond(world_T_body.linear()).normalized();
    s.attitude_valid = s.position_valid = true;
    s.position_sigma_m = 0.1;
    InsEvent e;
    e.utime = static_cast<std::int64_t>(std::llround(t * 1e6));
    const auto m = lcm_link::to_message(s, true, e.utime);
    e.bytes.resize(static_cast<std::size_t>(m.getEncodedSize()));
    m.encode(e.bytes.data(), 0, static_cast<int>(e.bytes.size()));
    events.push_back(std::move(e));
  }
  return events;
}

void write_lcm_log(const std::vector<InsEvent>& events, const std::string& path,
                   std::size_t garbage_after = SIZE_MAX) {
  lcm_eventlog_t* log = lcm_eventlog_create(path.c_str(), "w");
  ASSERT_NE(log, nullptr);
  for (std::size_t i = 0; i < events.size(); ++i) {
    lcm_eventlog_event_t e{};
    e.timestamp = events[i].utime;
    e.channellen = 9;
    e.channel = const_cast<char*>("INS_STATE");
    e.datalen = static_cast<std::int32_t>(events[i].bytes.size());
    e.data = const_cast<std::uint8_t*>(events[i].bytes.data());
    ASSERT_EQ(lcm_eventlog_write_event(log, &e), 0);
    if (i == garbage_after) {
      const char junk[] = "\x12\x34 a damaged stretch of the log \xed\xa8";
      std::fwrite(junk, 1, sizeof junk, log->f);
    }
  }
  lcm_eventlog_destroy(log);
}

// Re-encodes event i with its solution changed by `change`.
void change_solution(std::vector<InsEvent>* events, std::size_t i,
                     const std::function<void(InsSolution*, std::int64_t*)>& change) {
  zonemap_lcm::ins_state_t m;
  ASSERT_GT(m.decode((*events)[i].bytes.data(), 0, static_cast<int>((*events)[i].bytes.size())), 0);
  InsSolution s;
  s.time_s = static_cast<double>(m.utime) * 1e-6;
  s.position_m = Eigen::Vector3d(m.position[0], m.position[1], m.position[2]);
  s.attitude =
      Eigen::Quaterniond(m.orientation[0], m.orientation[1], m.orientation[2], m.orientation[3]);
  s.attitude_valid = s.position_valid = true;
  s.position_sigma_m = m.position_sigma_m;
  std::int64_t utime = m.utime;
  change(&s, &utime);
  const auto changed = lcm_link::to_message(s, true, utime);
  (*events)[i].bytes.assign(static_cast<std::size_t>(changed.getEncodedSize()), 0);
  changed.encode((*events)[i].bytes.data(), 0, static_cast<int>((*events)[i].bytes.size()));
}

struct BadInsMessage {
  const char* name;
  std::function<void(std::vector<InsEvent>*, std::size_t* garbage_after)> inject;
};
void PrintTo(const BadInsMessage& bad, std::ostream* out) {
  *out << bad.name;
}

constexpr std::size_t kBadEvent = 45;  // of ~93 (24 frames, four solutions a frame)

const BadInsMessage kBadInsMessages[] = {
    {"TimeFarInTheFuture",
     [](std::vector<InsEvent>* e, std::size_t*) {
       change_solution(e, kBadEvent,
                       [](InsSolution*, std::int64_t* utime) { *utime = 999999999000000; });
     }},
    {"TimeFromThePast",
     [](std::vector<InsEvent>* e, std::size_t*) {
       change_solution(e, kBadEvent, [](InsSolution*, std::int64_t* utime) { *utime = 100000; });
     }},
    {"PositionNan",
     [](std::vector<InsEvent>* e, std::size_t*) {
       change_solution(e, kBadEvent,
                       [](InsSolution* s, std::int64_t*) { s->position_m.y() = NAN; });
     }},
    {"OneKilometreAway",
     [](std::vector<InsEvent>* e, std::size_t*) {
       change_solution(e, kBadEvent,
                       [](InsSolution* s, std::int64_t*) { s->position_m.x() += 1000.0; });
     }},
    {"WrongFingerprint",
     [](std::vector<InsEvent>* e, std::size_t*) { (*e)[kBadEvent].bytes[0] ^= 0x5A; }},
    {"TruncatedMessage",
     [](std::vector<InsEvent>* e, std::size_t*) { (*e)[kBadEvent].bytes.resize(20); }},
    {"DamagedLogBytes", [](std::vector<InsEvent>*, std::size_t* garbage) { *garbage = kBadEvent; }},
};

class OneBadInsMessage : public ::testing::TestWithParam<BadInsMessage> {};

TEST_P(OneBadInsMessage, IsRefusedAloneAndTheFlightMapsAsTheCleanOne) {
  testing::TempDir dir;
  const std::string clean_seq = dir / "clean", bad_seq = dir / "bad";
  const std::string config =
      testing::write_test_scenario("posts-through", clean_seq, 4.0, 4, kFrames);
  ASSERT_FALSE(config.empty());
  replay::ReplaySequence truth;
  std::string error;
  MapConfig interpolate_between_frames;
  interpolate_between_frames.pose_max_gap_s = 1.0;
  ASSERT_TRUE(truth.open(clean_seq, "", interpolate_between_frames, &error)) << error;
  std::vector<InsEvent> events = ins_events(truth);
  ASSERT_GT(events.size(), kBadEvent + 10);
  // Both flights take their poses from the INS log, not from groundtruth.txt.
  std::filesystem::remove(clean_seq + "/groundtruth.txt");
  std::filesystem::copy(clean_seq, bad_seq, std::filesystem::copy_options::recursive);
  write_lcm_log(events, clean_seq + "/ins.lcmlog");
  std::size_t garbage_after = SIZE_MAX;
  GetParam().inject(&events, &garbage_after);
  write_lcm_log(events, bad_seq + "/ins.lcmlog", garbage_after);
  const RunResult clean = replay(clean_seq, config);
  const RunResult got = replay(bad_seq, config);
  ASSERT_EQ(clean.stats.frames_mapped, kFrames) << clean.json;
  EXPECT_EQ(got.stats.frames_mapped, kFrames) << "one INS message cost a frame\n" << got.json;
  EXPECT_GE(got.stats.poses_rejected, 1) << "the bad message was not counted\n" << got.json;
  EXPECT_LE(got.stats.poses_rejected, 1) << "more than the bad message was refused\n" << got.json;
  EXPECT_EQ(got.stats.zones_allocated, clean.stats.zones_allocated);
  expect_boxes_within_a_cell(got, clean);
}

std::string bad_ins_name(const ::testing::TestParamInfo<BadInsMessage>& param) {
  return param.param.name;
}
INSTANTIATE_TEST_SUITE_P(InsLog, OneBadInsMessage, ::testing::ValuesIn(kBadInsMessages),
                         bad_ins_name);

// ---- one bad CAN frame in a flight replayed from its INS candump (ins.candump)

// The same flight in a NED world (z down: the zonemap INS profile speaks NED),
// as the INS puts it on the bus: four frames a solution, one candump line each.
std::vector<std::string> candump_lines(const std::vector<InsEvent>& events) {
  const Eigen::Matrix3d zup_to_ned = Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal();
  can::InsCanConfig profile;
  profile.profile = can::InsCanProfile::kZonemapIns;
  std::vector<std::string> lines;
  std::uint8_t sequence = 0;
  for (const InsEvent& e : events) {
    zonemap_lcm::ins_state_t m{};
    EXPECT_GT(m.decode(e.bytes.data(), 0, static_cast<int>(e.bytes.size())), 0);
    const Eigen::Quaterniond zup(m.orientation[0], m.orientation[1], m.orientation[2],
                                 m.orientation[3]);
    can::ZonemapInsSample sample;
    sample.sequence = sequence++;
    sample.time_us = static_cast<std::uint64_t>(e.utime);
    sample.ned_m = zup_to_ned * Eigen::Vector3d(m.position[0], m.position[1], m.position[2]);
    sample.attitude = Eigen::Quaterniond(zup_to_ned * zup.toRotationMatrix()).normalized();
    can::CanFrame frames[8];
    const int n =
        can::encode_zonemap_ins(sample, profile, static_cast<double>(e.utime) * 1e-6, frames);
    for (int i = 0; i < n; ++i) {
      char buf[96];
      const std::size_t len = can::format_candump_line(frames[i], "can0", buf, sizeof buf);
      lines.emplace_back(buf, len);
    }
  }
  return lines;
}

void write_lines(const std::vector<std::string>& lines, const std::string& path) {
  std::ofstream out(path);
  for (const std::string& line : lines) out << line << "\n";
}

struct BadCanLine {
  const char* name;
  std::function<void(std::vector<std::string>*)> inject;
  std::int64_t counted;  // refusals it may cause: the record(s) of the one solution it broke
};
void PrintTo(const BadCanLine& bad, std::ostream* out) {
  *out << bad.name;
}

constexpr std::size_t kBadLine = 4 * kBadEvent + 1;  // the middle of one solution

const BadCanLine kBadCanLines[] = {
    {"DamagedLine",
     [](std::vector<std::string>* l) { (*l)[kBadLine] = "(17.5 can0 30#zz damaged"; }, 2},
    {"TruncatedLine",
     [](std::vector<std::string>* l) { (*l)[kBadLine].resize((*l)[kBadLine].size() / 2); }, 2},
    {"UnknownIdFrame",
     [](std::vector<std::string>* l) {
       const std::string time = (*l)[kBadLine].substr(0, (*l)[kBadLine].find(')') + 1);
       l->insert(l->begin() + static_cast<std::ptrdiff_t>(kBadLine),
                 time + " can0 123#0011223344556677");
     },
     0},  // not the INS's: ignored (the decoder counts it), no solution lost
    {"SequenceCounterFlipped",
     [](std::vector<std::string>* l) {
       std::string& line = (*l)[kBadLine];
       char& high = line[line.find('#') + 1];  // SEQUENCE: data byte 0, high nibble
       high = high == '8' ? '0' : '8';
     },
     3},  // a mixed set, and the two later parts of that solution come as orphans
    {"WrongLength",
     [](std::vector<std::string>* l) {
       std::string& line = (*l)[kBadLine];
       line.resize(line.size() - 4);  // two data bytes short: a DLC the profile refuses
     },
     2},
};

class OneBadCanFrame : public ::testing::TestWithParam<BadCanLine> {};

TEST_P(OneBadCanFrame, CostsAtMostItsSolutionAndTheFlightMapsAsTheCleanOne) {
  testing::TempDir dir;
  const std::string clean_seq = dir / "clean", bad_seq = dir / "bad";
  const std::string config =
      testing::write_test_scenario("posts-through", clean_seq, 4.0, 4, kFrames);
  ASSERT_FALSE(config.empty());
  replay::ReplaySequence truth;
  std::string error;
  MapConfig interpolate_between_frames;
  interpolate_between_frames.pose_max_gap_s = 1.0;
  ASSERT_TRUE(truth.open(clean_seq, "", interpolate_between_frames, &error)) << error;
  std::vector<std::string> lines = candump_lines(ins_events(truth));
  ASSERT_GT(lines.size(), kBadLine + 40);
  std::filesystem::remove(clean_seq + "/groundtruth.txt");
  {
    std::ofstream camera(clean_seq + "/camera.yaml", std::ios::app);
    camera << "world_z_up: false\n";  // the INS's NED world
  }
  std::filesystem::copy(clean_seq, bad_seq, std::filesystem::copy_options::recursive);
  write_lines(lines, clean_seq + "/ins.candump");
  GetParam().inject(&lines);
  write_lines(lines, bad_seq + "/ins.candump");
  const RunResult clean = replay(clean_seq, config);
  const RunResult got = replay(bad_seq, config);
  ASSERT_EQ(clean.stats.frames_mapped, kFrames) << clean.json;
  ASSERT_FALSE(clean.boxes.empty());
  EXPECT_EQ(got.stats.frames_mapped, kFrames) << "one CAN frame cost a frame\n" << got.json;
  // At most the bad line and the one solution it left incomplete, each counted by kind.
  EXPECT_LE(got.stats.poses_rejected, GetParam().counted) << got.json;
  std::int64_t by_kind = 0;
  for (const auto& [kind, count] : got.stats.rejections)
    by_kind +=
        kind.rfind("poses_", 0) == 0 && kind != "poses_reanchors" && kind != "poses_clock_steps"
            ? count
            : 0;
  EXPECT_EQ(by_kind, got.stats.poses_rejected) << "a refusal without its kind\n" << got.json;
  EXPECT_EQ(got.stats.zones_allocated, clean.stats.zones_allocated);
  expect_boxes_within_a_cell(got, clean);
}

std::string bad_can_name(const ::testing::TestParamInfo<BadCanLine>& param) {
  return param.param.name;
}
INSTANTIATE_TEST_SUITE_P(InsCandump, OneBadCanFrame, ::testing::ValuesIn(kBadCanLines),
                         bad_can_name);

}  // namespace
}  // namespace zonemap
