// CAN codecs: signals, DBC files vs tables, SBG and zonemap INS profiles
// (hand-built frames, round trips, every bad-input rule), obstacle boxes, candump.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "hal/can/can_pose_source.hpp"
#include "hal/can/can_signals.hpp"
#include "hal/can/candump.hpp"
#include "hal/can/dbc.hpp"
#include "hal/can/ins_can.hpp"
#include "hal/can/obstacle_can.hpp"
#include "zonemap/common/geodetic.hpp"

using namespace zonemap;
using namespace zonemap::can;

namespace {

// Independent of can_signals: integers into bytes by hand.
void put_le(CanFrame* f, int offset, std::int64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) f->data[offset + i] = static_cast<std::uint8_t>(v >> (8 * i));
}
void put_be(CanFrame* f, int offset, std::int64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) {
    f->data[offset + i] = static_cast<std::uint8_t>(v >> (8 * (bytes - 1 - i)));
  }
}

CanFrame frame(std::uint32_t id, std::uint8_t dlc, double t) {
  CanFrame f;
  f.id = id;
  f.dlc = dlc;
  f.time_s = t;
  return f;
}

// One SBG solution built byte by byte as the INS would send it.
std::vector<CanFrame> sbg_by_hand(bool little, std::uint32_t time_us, std::uint32_t status,
                                  std::int64_t q[4], std::int64_t lat, std::int64_t lon,
                                  std::int64_t alt_mm, std::int64_t undulation, double t) {
  auto put = little ? put_le : put_be;
  std::vector<CanFrame> out;
  CanFrame info = frame(0x130, 8, t);
  put(&info, 0, time_us, 4);
  put(&info, 4, status, 4);
  CanFrame quat = frame(0x131, 8, t + 0.001);
  for (int i = 0; i < 4; ++i) put(&quat, 2 * i, q[i], 2);
  CanFrame pos = frame(0x134, 8, t + 0.002);
  put(&pos, 0, lat, 4);
  put(&pos, 4, lon, 4);
  CanFrame alt = frame(0x135, 6, t + 0.003);
  put(&alt, 0, alt_mm, 4);
  put(&alt, 4, undulation, 2);
  return {info, quat, pos, alt};
}

constexpr std::uint32_t kAllValid = kSbgAttitudeValid | kSbgHeadingValid | kSbgPositionValid | 4;

}  // namespace

TEST(CanSignals, IntelAndMotorolaByteOrderKnownValues) {
  CanFrame f = frame(1, 8, 0.0);
  f.data = {0x12, 0x34, 0x56, 0x78, 0x9A, 0xBC, 0xDE, 0xF0};
  EXPECT_EQ(get_raw(f, {"a", 0, 16, true, false, 1.0, 0.0, ""}), 0x3412);
  EXPECT_EQ(get_raw(f, {"a", 7, 16, false, false, 1.0, 0.0, ""}), 0x1234);  // Motorola, MSB = bit 7
  EXPECT_EQ(get_raw(f, {"a", 39, 32, false, false, 1.0, 0.0, ""}), 0x9ABCDEF0);
  EXPECT_EQ(get_raw(f, {"a", 32, 32, true, true, 1.0, 0.0, ""}),
            static_cast<std::int32_t>(0xF0DEBC9A));
  EXPECT_EQ(get_raw(f, {"a", 4, 4, true, false, 1.0, 0.0, ""}), 0x1);  // high nibble of byte 0
  EXPECT_EQ(get_raw(f, {"a", 63, 1, true, false, 1.0, 0.0, ""}), 1);
}

TEST(CanSignals, SetThenGetRoundTripsEveryLayout) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 5000; ++trial) {
    SignalSpec s;
    s.little_endian = rng() % 2 == 0;
    s.is_signed = rng() % 2 == 0;
    s.length = 1 + static_cast<int>(rng() % 32);
    if (s.little_endian) {
      s.start_bit = static_cast<int>(rng() % static_cast<unsigned>(65 - s.length));
    } else {
      // Motorola: the most significant bit's position; the field must fit.
      const int msb_byte = static_cast<int>(rng() % 8);
      s.start_bit = msb_byte * 8 + static_cast<int>(rng() % 8);
      const int bits_left = (7 - msb_byte) * 8 + (s.start_bit % 8) + 1;
      if (bits_left < s.length) continue;
    }
    CanFrame f = frame(1, 8, 0.0);
    for (auto& b : f.data) b = static_cast<std::uint8_t>(rng());
    const CanFrame before = f;
    const std::int64_t span = std::int64_t{1} << s.length;
    std::int64_t value = static_cast<std::int64_t>(rng() % static_cast<std::uint64_t>(span));
    if (s.is_signed) value -= span / 2;
    set_raw(&f, s, value);
    ASSERT_EQ(get_raw(f, s), value) << "start " << s.start_bit << " len " << s.length;
    // Bits outside the signal are untouched: writing back the old value restores all.
    set_raw(&f, s, get_raw(before, s));
    ASSERT_EQ(f.data, before.data);
  }
}

TEST(CanSignals, PhysicalValuesSaturateAndSaySo) {
  CanFrame f = frame(1, 8, 0.0);
  const SignalSpec s{"x", 0, 16, true, true, 0.1, 0.0, "m"};
  EXPECT_TRUE(set_physical(&f, s, -12.34));
  EXPECT_NEAR(get_physical(f, s), -12.3, 1e-9);
  EXPECT_FALSE(set_physical(&f, s, 1e6));
  EXPECT_NEAR(get_physical(f, s), 3276.7, 1e-9);
  EXPECT_FALSE(set_physical(&f, s, std::nan("")));
}

TEST(CanDbc, FilesInConfigMatchTheDecoderTables) {
  struct Case {
    const char* file;
    std::span<const MessageSpec> table;
  };
  const Case cases[] = {{"sbg-ecan-le.dbc", sbg_messages(true)},
                        {"sbg-ecan-be.dbc", sbg_messages(false)},
                        {"zonemap-ins.dbc", zonemap_ins_messages()},
                        {"zonemap-obstacles.dbc", obstacle_messages()}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.file);
    std::vector<DbcMessage> dbc;
    std::string error;
    ASSERT_TRUE(read_dbc(std::string(ZONEMAP_SOURCE_DIR) + "/config/can/" + c.file, &dbc, &error))
        << error;
    ASSERT_EQ(dbc.size(), c.table.size());
    for (std::size_t m = 0; m < dbc.size(); ++m) {
      const MessageSpec& t = c.table[m];
      EXPECT_EQ(dbc[m].name, t.name);
      EXPECT_EQ(dbc[m].id, t.id);
      EXPECT_EQ(dbc[m].extended, t.extended);
      EXPECT_EQ(dbc[m].dlc, t.dlc);
      ASSERT_EQ(dbc[m].signals.size(), t.signals.size()) << t.name;
      for (std::size_t i = 0; i < t.signals.size(); ++i) {
        const DbcSignal& d = dbc[m].signals[i];
        const SignalSpec& s = t.signals[i];
        SCOPED_TRACE(d.name);
        EXPECT_EQ(d.name, s.name);
        EXPECT_EQ(d.start_bit, s.start_bit);
        EXPECT_EQ(d.length, s.length);
        EXPECT_EQ(d.little_endian, s.little_endian);
        EXPECT_EQ(d.is_signed, s.is_signed);
        EXPECT_NEAR(d.factor, s.factor, std::abs(s.factor) * 1e-9);
        EXPECT_EQ(d.offset, s.offset);
        EXPECT_EQ(d.unit, s.unit);
      }
    }
  }
}

TEST(CanDbc, UnreadableLineIsReportedWithFileAndLine) {
  const std::string path = ::testing::TempDir() + "/bad.dbc";
  {
    std::ofstream out(path);
    out << "VERSION \"\"\nBO_ 304 EKF_INFO: 8 INS\n SG_ TIME_STAMP : 0|32 (1,0) [0|1] \"us\" X\n";
  }
  std::vector<DbcMessage> dbc;
  std::string error;
  EXPECT_FALSE(read_dbc(path, &dbc, &error));
  EXPECT_NE(error.find("bad.dbc:3"), std::string::npos) << error;
}

class SbgByteOrder : public ::testing::TestWithParam<bool> {};

TEST_P(SbgByteOrder, HandBuiltFramesDecodeToTheRightNedPose) {
  const bool little = GetParam();
  InsCanConfig config;
  config.little_endian = little;
  config.has_origin = true;
  config.origin = {48.0, 11.0, 500.0};  // ellipsoid height
  config.time_source = InsTimeSource::kIns;
  InsCanDecoder decoder(config);
  // Yaw 90 deg (heading east): q = (cos 45, 0, 0, sin 45).
  std::int64_t q[4] = {23170, 0, 0, 23170};
  // 0.0009 deg north, 0.0012 deg east, 30 m higher (MSL 495 + undulation 35 = 530).
  const auto frames =
      sbg_by_hand(little, 2'500'000, kAllValid, q, 480009000, 110012000, 495000, 35 * 200, 10.0);
  InsSolution s;
  int solutions = 0;
  for (const CanFrame& f : frames) solutions += decoder.feed(f, &s) ? 1 : 0;
  ASSERT_EQ(solutions, 1);
  EXPECT_DOUBLE_EQ(s.time_s, 2.5);
  EXPECT_TRUE(s.attitude_valid);
  EXPECT_TRUE(s.position_valid);
  // Expected from the ellipsoid's radii of curvature at 48 deg (independent of the
  // ECEF path the decoder takes).
  const double a = 6378137.0, f = 1.0 / 298.257223563, e2 = f * (2 - f);
  const double lat = 48.0 * M_PI / 180.0;
  const double w = std::sqrt(1 - e2 * std::sin(lat) * std::sin(lat));
  const double meridian = a * (1 - e2) / (w * w * w), normal = a / w;
  EXPECT_NEAR(s.position_m.x(), (meridian + 500) * 0.0009 * M_PI / 180.0, 0.02);
  EXPECT_NEAR(s.position_m.y(), (normal + 500) * std::cos(lat) * 0.0012 * M_PI / 180.0, 0.02);
  EXPECT_NEAR(s.position_m.z(), -30.0, 0.02);
  // Body x (forward) points east.
  const Eigen::Vector3d forward = s.attitude.normalized() * Eigen::Vector3d::UnitX();
  EXPECT_NEAR(forward.y(), 1.0, 1e-4);
  EXPECT_EQ(decoder.counters().solutions, 1);
}

TEST_P(SbgByteOrder, WrongByteOrderSettingDoesNotGiveTheSamePose) {
  const bool little = GetParam();
  InsCanConfig config;
  config.little_endian = !little;  // misconfigured
  config.has_origin = true;
  config.origin = {48.0, 11.0, 500.0};
  InsCanDecoder decoder(config);
  std::int64_t q[4] = {23170, 0, 0, 23170};
  const auto frames =
      sbg_by_hand(little, 1000, kAllValid, q, 480009000, 110012000, 495000, 7000, 1.0);
  // The same frames read with the right setting give a pose the gate takes ...
  InsCanConfig right = config;
  right.little_endian = little;
  InsCanDecoder good(right);
  InsSolution expected;
  bool got_expected = false;
  for (const CanFrame& f : frames) got_expected |= good.feed(f, &expected);
  ASSERT_TRUE(got_expected);
  InsRejection why{};
  ASSERT_TRUE(InsGate().check(expected, &why)) << to_string(why);
  // ... the wrong one either no solution or one the gate refuses (attitude not unit).
  InsSolution s;
  bool got = false;
  for (const CanFrame& f : frames) got |= decoder.feed(f, &s);
  EXPECT_TRUE(!got || !InsGate().check(s, &why)) << "a misread byte order passed as a pose";
}

TEST_P(SbgByteOrder, EncodeThenDecodeGivesTheSample) {
  InsCanConfig config;
  config.little_endian = GetParam();
  config.time_source = InsTimeSource::kIns;
  InsCanDecoder decoder(config);  // origin = first fix
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Geodetic first{52.1, 4.3, 120.0};
  LocalTangentPlane plane(first);
  for (int i = 0; i < 200; ++i) {
    SbgSample sample;
    sample.time_us = 1000u + static_cast<std::uint32_t>(i) * 10000u;
    sample.attitude = Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng)).normalized();
    const Eigen::Vector3d ned = i == 0
                                    ? Eigen::Vector3d::Zero()
                                    : Eigen::Vector3d(u(rng) * 2000, u(rng) * 2000, u(rng) * 200);
    sample.position = plane.to_geodetic(ned);
    sample.undulation_m = 47.0;
    sample.position_sigma_m = 0.25;
    CanFrame frames[5];
    const int n = encode_sbg(sample, config, 100.0 + i * 0.01, frames);
    InsSolution s;
    int got = 0;
    for (int k = 0; k < n; ++k) got += decoder.feed(frames[k], &s) ? 1 : 0;
    ASSERT_EQ(got, 1);
    EXPECT_NEAR(s.time_s, sample.time_us * 1e-6, 1e-9);
    // 1e-7 deg ~ 1.1 cm; altitude mm.
    EXPECT_LT((s.position_m - ned).norm(), 0.02) << i;
    EXPECT_GT(std::abs(s.attitude.normalized().dot(sample.attitude)), 1.0 - 1e-8);
  }
  // POS_ACC follows its solution: the sigma of one applies to the next.
  EXPECT_EQ(decoder.counters().solutions, 200);
  EXPECT_EQ(decoder.counters().mixed_sets + decoder.counters().incomplete_sets, 0);
}

INSTANTIATE_TEST_SUITE_P(Both, SbgByteOrder, ::testing::Values(true, false),
                         [](const auto& p) { return p.param ? "Intel" : "Motorola"; });

TEST(SbgDecoder, EveryBadInputIsCountedAndNeverAPose) {
  InsCanConfig config;
  config.has_origin = true;
  config.origin = {48.0, 11.0, 500.0};
  InsCanDecoder decoder(config);
  std::int64_t q[4] = {32767, 0, 0, 0};
  auto good = sbg_by_hand(true, 1000, kAllValid, q, 480000000, 110000000, 480000, 4000, 1.0);
  InsSolution s;
  // Wrong DLC on the quaternion frame: that solution cannot complete.
  auto short_quat = good;
  short_quat[1].dlc = 6;
  for (const CanFrame& f : short_quat) EXPECT_FALSE(decoder.feed(f, &s));
  EXPECT_EQ(decoder.counters().bad_dlc, 1);
  // The next INFO finds the last set incomplete.
  for (const CanFrame& f : good) decoder.feed(f, &s);
  EXPECT_EQ(decoder.counters().incomplete_sets, 1);
  EXPECT_EQ(decoder.counters().solutions, 1);
  // Parts without their INFO.
  EXPECT_FALSE(decoder.feed(good[2], &s));
  EXPECT_EQ(decoder.counters().orphan_parts, 1);
  // A part twice (two solutions interleaved).
  std::vector<CanFrame> twice = {good[0], good[1], good[1], good[2], good[3]};
  for (const CanFrame& f : twice) EXPECT_FALSE(decoder.feed(f, &s));
  EXPECT_EQ(decoder.counters().mixed_sets, 1);
  // Parts too far apart in time.
  auto slow = good;
  for (int i = 1; i < 4; ++i) slow[i].time_s += 0.2;
  for (const CanFrame& f : slow) EXPECT_FALSE(decoder.feed(f, &s));
  EXPECT_EQ(decoder.counters().mixed_sets, 2);
  // RTR and extended-ID frames with the profile's IDs.
  CanFrame rtr = good[1];
  rtr.remote = true;
  CanFrame ext = good[1];
  ext.extended = true;
  decoder.feed(rtr, &s);
  decoder.feed(ext, &s);
  EXPECT_EQ(decoder.counters().bad_frame_type, 2);
  // Someone else's frame.
  decoder.feed(frame(0x7FF, 8, 2.0), &s);
  EXPECT_EQ(decoder.counters().ignored_id, 1);
  // Invalid flags: the solution comes out marked, and the gate refuses it.
  auto invalid = sbg_by_hand(true, 2000, 1, q, 480000000, 110000000, 480000, 4000, 3.0);
  bool got = false;
  for (const CanFrame& f : invalid) got |= decoder.feed(f, &s);
  ASSERT_TRUE(got);
  InsGate gate;
  InsRejection why{};
  EXPECT_FALSE(gate.check(s, &why));
  EXPECT_EQ(why, InsRejection::kFlagsInvalid);
}

TEST(SbgDecoder, FirstFixOriginWaitsForAValidPositionAndClockWrapsAreUnwrapped) {
  InsCanConfig config;
  config.time_source = InsTimeSource::kIns;
  InsCanDecoder decoder(config);
  std::int64_t q[4] = {32767, 0, 0, 0};
  InsSolution s;
  auto no_fix =
      sbg_by_hand(true, 0xFFFF0000u, kSbgAttitudeValid | kSbgHeadingValid, q, 0, 0, 0, 0, 1.0);
  bool got = false;
  for (const CanFrame& f : no_fix) got |= decoder.feed(f, &s);
  EXPECT_FALSE(got);
  EXPECT_EQ(decoder.counters().waiting_for_origin, 1);
  auto fix = sbg_by_hand(true, 0xFFFFF000u, kAllValid, q, 480000000, 110000000, 480000, 0, 1.1);
  for (const CanFrame& f : fix) got |= decoder.feed(f, &s);
  ASSERT_TRUE(got);
  EXPECT_LT(s.position_m.norm(), 1e-6);  // the origin itself
  const double before = s.time_s;
  auto after_wrap =
      sbg_by_hand(true, 0x00001000u, kAllValid, q, 480000000, 110000000, 480000, 0, 1.2);
  got = false;
  for (const CanFrame& f : after_wrap) got |= decoder.feed(f, &s);
  ASSERT_TRUE(got);
  EXPECT_NEAR(s.time_s - before, 0x2000 * 1e-6, 1e-9);
}

TEST(ZonemapInsProfile, EncodeThenDecodeAndSequenceMismatch) {
  InsCanConfig config;
  config.profile = InsCanProfile::kZonemapIns;
  config.time_source = InsTimeSource::kIns;
  InsCanDecoder decoder(config);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < 300; ++i) {
    ZonemapInsSample sample;
    sample.sequence = static_cast<std::uint8_t>(i);
    sample.time_us = 1'000'000'000'000ull + static_cast<std::uint64_t>(i) * 5000u;
    sample.ned_m = {u(rng) * 100000, u(rng) * 100000, u(rng) * 3000};
    sample.attitude = Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng)).normalized();
    sample.position_sigma_m = 0.37;
    CanFrame frames[4];
    const int n = encode_zonemap_ins(sample, config, 5.0 + i * 0.005, frames);
    InsSolution s;
    int got = 0;
    for (int k = 0; k < n; ++k) got += decoder.feed(frames[k], &s) ? 1 : 0;
    ASSERT_EQ(got, 1);
    EXPECT_NEAR(s.time_s, static_cast<double>(sample.time_us) * 1e-6, 1e-6);
    EXPECT_LT((s.position_m - sample.ned_m).cwiseAbs().maxCoeff(), 0.00051);
    EXPECT_NEAR(s.position_sigma_m, 0.37, 1e-9);
    // 14-bit components: the rotation within 3e-4 rad (1.5 cm at 50 m) everywhere.
    EXPECT_LT(s.attitude.normalized().angularDistance(sample.attitude), 3e-4);
    EXPECT_NEAR(s.attitude.norm(), 1.0, 3e-4);
  }
  // Frames of two solutions mixed: another sequence byte.
  ZonemapInsSample a, b;
  a.sequence = 1;
  b.sequence = 2;
  CanFrame fa[4], fb[4];
  encode_zonemap_ins(a, config, 10.0, fa);
  encode_zonemap_ins(b, config, 10.0, fb);
  InsSolution s;
  EXPECT_FALSE(decoder.feed(fa[0], &s));
  EXPECT_FALSE(decoder.feed(fa[1], &s));
  EXPECT_FALSE(decoder.feed(fb[2], &s));
  EXPECT_EQ(decoder.counters().mixed_sets, 1);
}

TEST(ObstacleCan, ABoxNotSeenForOverASecondCarriesItsAgeWithinTheSameBudget) {
  std::vector<ObstacleBox> boxes(6);
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    boxes[i].id = static_cast<std::uint32_t>(1 + i);
    boxes[i].min = Eigen::Vector3d(10.0 * static_cast<double>(i), 0.0, 0.0);
    boxes[i].max = boxes[i].min + Eigen::Vector3d(1, 1, 3);
    boxes[i].last_seen_s = 100.0 - (i % 2 == 0 ? 0.5 : 42.37);  // odd ones: out of view 42 s
  }
  ObstacleCanConfig config;
  config.rate_hz = 10.0;
  config.max_frames_per_s = 10.0 * (2 + 2 * 6 + 3);  // the six boxes and three ages
  ObstacleCanEncoder encoder(config);
  std::vector<std::uint32_t> order(boxes.size());
  std::vector<CanFrame> frames(encoder.frames_per_update());
  std::size_t n = encoder.encode(boxes.data(), boxes.size(), Eigen::Vector3d::Zero(), true, 100.0,
                                 order.data(), frames.data());
  ASSERT_EQ(n, 2u + 12u + 3u);
  EXPECT_EQ(encoder.counters().ages_sent, 3);
  ObstacleCanDecoder decoder;
  bool complete = false;
  for (std::size_t i = 0; i < n; ++i) complete = decoder.feed(frames[i]);
  ASSERT_TRUE(complete);
  ASSERT_EQ(decoder.boxes().size(), 6u);
  for (const DecodedObstacleBox& d : decoder.boxes()) {
    EXPECT_NEAR(d.age_s, d.id % 2 == 0 ? 42.3 : 0.0, 1e-9) << d.id;  // floored to 0.1 s
  }
  // One frame fewer in the budget: the farthest box no longer fits, and says so.
  config.max_frames_per_s -= 10.0;
  ObstacleCanEncoder tight(config);
  n = tight.encode(boxes.data(), boxes.size(), Eigen::Vector3d::Zero(), true, 100.0, order.data(),
                   frames.data());
  ObstacleCanDecoder second;
  complete = false;
  for (std::size_t i = 0; i < n; ++i) complete = second.feed(frames[i]);
  ASSERT_TRUE(complete);
  EXPECT_EQ(second.boxes().size(), 5u);
  EXPECT_TRUE(second.flags() & kObstacleUpdateTruncated);
  EXPECT_EQ(tight.counters().boxes_over_budget, 1);
  // An age frame for another box than the one just completed breaks the update.
  ObstacleCanDecoder strict;
  const CanFrame stray = frames[5];  // BEGIN, box 1 (MIN, MAX), box 2 (MIN, MAX, AGE)
  ASSERT_EQ(stray.id, 0x324u);
  for (std::size_t i = 0; i < 4; ++i) strict.feed(frames[i]);  // ... box 2's MIN only
  strict.feed(stray);                                          // its age before its BOX_MAX
  EXPECT_EQ(strict.broken_updates(), 1);
}

TEST(ObstacleCan, APriorBoxSaysSoFromTheFirstUpdateOn) {
  // Two boxes seen 0.2 s ago: one from a prior map no view has confirmed, one the
  // flight measured. Only the prior one gets a BOX_AGE frame, with PRIOR set.
  std::vector<ObstacleBox> boxes(2);
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    boxes[i].id = static_cast<std::uint32_t>(7 + i);
    boxes[i].min = Eigen::Vector3d(5.0 + 10.0 * static_cast<double>(i), 0.0, 0.0);
    boxes[i].max = boxes[i].min + Eigen::Vector3d(1, 1, 3);
    boxes[i].last_seen_s = 99.8;
  }
  boxes[0].prior = true;
  ObstacleCanConfig config;
  config.rate_hz = 10.0;
  ObstacleCanEncoder encoder(config);
  std::vector<std::uint32_t> order(boxes.size());
  std::vector<CanFrame> frames(encoder.frames_per_update());
  const std::size_t n = encoder.encode(boxes.data(), boxes.size(), Eigen::Vector3d::Zero(), true,
                                       100.0, order.data(), frames.data());
  ASSERT_EQ(n, 2u + 4u + 1u);
  EXPECT_EQ(encoder.counters().ages_sent, 1);
  ObstacleCanDecoder decoder;
  bool complete = false;
  for (std::size_t i = 0; i < n; ++i) complete = decoder.feed(frames[i]);
  ASSERT_TRUE(complete);
  ASSERT_EQ(decoder.boxes().size(), 2u);
  for (const DecodedObstacleBox& d : decoder.boxes()) {
    EXPECT_EQ(d.prior, d.id == 7) << d.id;
    // The prior box's frame carries its true age (0.1 s steps); the other sends none.
    EXPECT_NEAR(d.age_s, d.id == 7 ? 0.2 : 0.0, 0.1 + 1e-9) << d.id << ": seen 0.2 s ago";
  }
  // The bit where the layout says (config/can/zonemap-obstacles.dbc: PRIOR 32|1).
  const CanFrame& age = frames[3];
  ASSERT_EQ(age.id, 0x324u);
  EXPECT_EQ(age.data[4] & 1u, 1u);
}

TEST(ObstacleCan, EncodeThenDecodeHoldsEveryBoxNearestFirstWithinBudget) {
  std::vector<ObstacleBox> boxes;
  for (int i = 0; i < 40; ++i) {
    ObstacleBox b;
    b.id = static_cast<std::uint32_t>(100 + i);
    b.kind = i % 10 == 9 ? FeatureKind::kGround : FeatureKind::kObstacle;
    b.min = {2000.0 + 10.0 * i, -1500.0 + 3.3 * i, -20.0};
    b.max = b.min + Eigen::Vector3d(1.23, 4.56, 7.89);
    b.last_seen_s = 1.0;  // seen in this update: no BOX_AGE frames
    boxes.push_back(b);
  }
  const Eigen::Vector3d vehicle(2130.0, -1460.0, -30.0);
  ObstacleCanConfig config;
  config.rate_hz = 10.0;
  config.max_frames_per_s = 10.0 * (2 + 2 * 20);  // room for 20 boxes of 36 obstacles
  ObstacleCanEncoder encoder(config);
  std::vector<std::uint32_t> order(boxes.size());
  std::vector<CanFrame> frames(encoder.frames_per_update());
  const std::size_t n =
      encoder.encode(boxes.data(), boxes.size(), vehicle, false, 1.0, order.data(), frames.data());
  ASSERT_EQ(n, 42u);
  ObstacleCanDecoder decoder;
  bool complete = false;
  for (std::size_t i = 0; i < n; ++i) complete = decoder.feed(frames[i]);
  ASSERT_TRUE(complete);
  EXPECT_EQ(decoder.boxes().size(), 20u);
  EXPECT_EQ(decoder.total_in_map(), 36);
  EXPECT_TRUE(decoder.flags() & kObstacleUpdateTruncated);
  EXPECT_TRUE(decoder.flags() & kObstacleWorldZDown);  // encoded with world_z_up false
  EXPECT_EQ(encoder.counters().boxes_over_budget, 16);
  // Sent boxes hold the originals (rounded outwards, < 0.1 m) and are the nearest.
  double farthest_sent = 0.0;
  for (const DecodedObstacleBox& d : decoder.boxes()) {
    const ObstacleBox& b = boxes[d.id - 100];
    EXPECT_FALSE(d.ground);
    EXPECT_TRUE((d.min.array() <= b.min.array() + 1e-9).all());
    EXPECT_TRUE((d.max.array() >= b.max.array() - 1e-9).all());
    EXPECT_LT((d.min - b.min).cwiseAbs().maxCoeff(), 0.1 + 1e-9);
    EXPECT_LT((d.max - b.max).cwiseAbs().maxCoeff(), 0.1 + 1e-9);
    farthest_sent =
        std::max(farthest_sent, (vehicle.cwiseMax(b.min).cwiseMin(b.max) - vehicle).norm());
  }
  for (const ObstacleBox& b : boxes) {
    if (b.kind != FeatureKind::kObstacle) continue;
    bool sent = false;
    for (const DecodedObstacleBox& d : decoder.boxes()) sent |= d.id == b.id;
    if (!sent) {
      EXPECT_GE((vehicle.cwiseMax(b.min).cwiseMin(b.max) - vehicle).norm(), farthest_sent - 1e-9);
    }
  }
  // A lost frame breaks the update: the receiver does not take it as complete.
  ObstacleCanDecoder lossy;
  bool any = false;
  for (std::size_t i = 0; i < n; ++i) {
    if (i != 7) any |= lossy.feed(frames[i]);
  }
  EXPECT_FALSE(any);
  EXPECT_EQ(lossy.broken_updates(), 1);
}

TEST(Candump, ParsesEveryFrameKindAndRoundTrips) {
  CanFrame f;
  std::string_view iface;
  const char* why = nullptr;
  ASSERT_EQ(parse_candump_line("(1436509052.249713) can0 123#DEADBEEF", &f, &iface, &why),
            CandumpLine::kFrame);
  EXPECT_EQ(f.id, 0x123u);
  EXPECT_FALSE(f.extended);
  EXPECT_EQ(f.dlc, 4);
  EXPECT_EQ(f.data[0], 0xDE);
  EXPECT_EQ(iface, "can0");
  EXPECT_NEAR(f.time_s, 1436509052.249713, 1e-6);
  ASSERT_EQ(parse_candump_line("(0.000001) vcan0 1F334455#", &f, nullptr, &why),
            CandumpLine::kFrame);
  EXPECT_TRUE(f.extended);
  EXPECT_EQ(f.id, 0x1F334455u);
  EXPECT_EQ(f.dlc, 0);
  ASSERT_EQ(parse_candump_line("(1.000000000) can1 7FF#R", &f, nullptr, &why), CandumpLine::kFrame);
  EXPECT_TRUE(f.remote);
  ASSERT_EQ(parse_candump_line("(1.000000) can1 123##1112233", &f, nullptr, &why),
            CandumpLine::kFrame);
  EXPECT_TRUE(f.fd);
  EXPECT_EQ(parse_candump_line("# a comment", &f, nullptr, &why), CandumpLine::kNotAFrame);
  EXPECT_EQ(parse_candump_line("", &f, nullptr, &why), CandumpLine::kNotAFrame);
  const char* bad[] = {"(1.2345) can0 123#00",
                       "(1.234567) can0 12#00",
                       "(1.234567) can0 123#0",
                       "(1.234567) can0 123#GG",
                       "(1.234567) can0 123#001122334455667788",
                       "(1.234567) can0 800#00",
                       "(1.234567)can0 123#00",
                       "(1.234567) can0",
                       "(x.234567) can0 123#00",
                       "(1.234567) can0 123#Rjunk"};
  for (const char* line : bad) {
    EXPECT_EQ(parse_candump_line(line, &f, nullptr, &why), CandumpLine::kMalformed) << line;
  }
  std::mt19937 rng(11);
  for (int i = 0; i < 500; ++i) {
    CanFrame in;
    in.extended = rng() % 2 == 0;
    in.id = in.extended ? rng() & 0x1FFFFFFF : rng() & 0x7FF;
    in.dlc = static_cast<std::uint8_t>(rng() % 9);
    for (int b = 0; b < in.dlc; ++b) in.data[b] = static_cast<std::uint8_t>(rng());
    in.time_s = 1.7e9 + static_cast<double>(rng() % 1000000) * 1e-6;
    char buf[80];
    const std::size_t len = format_candump_line(in, "vcan0", buf, sizeof buf);
    ASSERT_GT(len, 0u);
    CanFrame out;
    ASSERT_EQ(parse_candump_line(std::string_view(buf, len), &out, nullptr, &why),
              CandumpLine::kFrame)
        << buf;
    EXPECT_EQ(out.id, in.id);
    EXPECT_EQ(out.extended, in.extended);
    EXPECT_EQ(out.dlc, in.dlc);
    EXPECT_TRUE(std::equal(in.data.begin(), in.data.begin() + in.dlc, out.data.begin()));
    EXPECT_NEAR(out.time_s, in.time_s, 1.5e-6);
  }
}

TEST(CandumpPoseSource, ReadsALogThroughTheProfileAndTheGateCountingBadLines) {
  const std::string path = ::testing::TempDir() + "/ins.candump";
  InsCanConfig profile;
  profile.has_origin = true;
  profile.origin = {48.0, 11.0, 500.0};
  profile.time_source = InsTimeSource::kIns;
  LocalTangentPlane plane(profile.origin);
  {
    std::ofstream out(path);
    out << "# a comment line, skipped\n";
    for (int i = 0; i < 25; ++i) {
      SbgSample s;
      s.time_us = 1'000'000u + static_cast<std::uint32_t>(i) * 20'000u;
      s.position = plane.to_geodetic(Eigen::Vector3d(0.5 * i, 0.0, -40.0));
      CanFrame frames[5];
      const int n = encode_sbg(s, profile, 1.7e9 + i * 0.02, frames);
      for (int k = 0; k < n; ++k) {
        char line[96];
        out << std::string(line, format_candump_line(frames[k], "can0", line, sizeof line)) << "\n";
      }
      if (i == 7) out << "(1700000000.12) can0 130#00\n";  // malformed: 2 fractional digits
    }
  }
  CandumpPoseSource source(profile, {}, Eigen::Isometry3d::Identity(), 0.0);
  std::string error;
  ASSERT_TRUE(source.open(path, &error)) << error;
  struct Sink : hal::PoseSink {
    std::vector<PoseSample> poses;
    void push(const PoseSample& p) override { poses.push_back(p); }
  } sink;
  while (source.poll(sink, 0) != hal::PollResult::kEnd) {
  }
  ASSERT_EQ(sink.poses.size(), 25u);
  EXPECT_LT((sink.poses[24].position - Eigen::Vector3d(12.0, 0.0, -40.0)).norm(), 0.03);
  EXPECT_EQ(source.counters().malformed, 1);
  CandumpPoseSource missing(profile, {}, Eigen::Isometry3d::Identity(), 0.0);
  EXPECT_FALSE(missing.open("/nonexistent.candump", &error));
}
