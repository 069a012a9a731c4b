// LCM messages and transports in one process: decode(encode(x)) for every type,
// fingerprint/length/frame checks, the pose source over memq://, LCM logs, a
// provider that cannot start. (Multicast against lcm-logger/lcm-logplayer runs
// in a private network namespace: test_lcm_netns.cpp.)
#include <gtest/gtest.h>
#include <lcm/eventlog.h>
#include <lcm/lcm.h>

#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "hal/lcm/lcm_codec.hpp"
#include "hal/lcm/lcm_link.hpp"
#include "hal/os/allocation_counter.hpp"

using namespace zonemap;
using namespace zonemap::lcm_link;

namespace {

template <typename Message>
std::vector<std::uint8_t> encode(const Message& m) {
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(m.getEncodedSize()));
  EXPECT_EQ(m.encode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  return bytes;
}

InsSolution solution(double t, Eigen::Vector3d p) {
  InsSolution s;
  s.time_s = t;
  s.position_m = p;
  s.attitude = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()));
  s.attitude_valid = s.position_valid = true;
  s.position_sigma_m = 0.25;
  return s;
}

struct CollectingSink : hal::PoseSink {
  std::vector<PoseSample> poses;
  void push(const PoseSample& p) override { poses.push_back(p); }
};

}  // namespace

TEST(LcmCodec, InsStateRoundTripAndEveryRefusal) {
  const InsSolution in = solution(12.345678, {1.5, -2.25, -30.0});
  const auto bytes = encode(to_message(in, false, 12'345'678));
  InsSolution out;
  ASSERT_EQ(decode_ins_state(bytes.data(), bytes.size(), false, &out), InsDecode::kOk);
  EXPECT_DOUBLE_EQ(out.time_s, 12.345678);
  EXPECT_EQ(out.position_m, in.position_m);
  EXPECT_EQ(out.attitude.coeffs(), in.attitude.coeffs());
  EXPECT_TRUE(out.attitude_valid && out.position_valid);
  EXPECT_FLOAT_EQ(static_cast<float>(out.position_sigma_m), 0.25f);
  // Another type (wrong fingerprint), truncated, empty, wrong world frame.
  const auto other = encode(to_message(ObstacleDistances{}, 0));
  EXPECT_EQ(decode_ins_state(other.data(), other.size(), false, &out), InsDecode::kMalformed);
  EXPECT_EQ(decode_ins_state(bytes.data(), bytes.size() - 1, false, &out), InsDecode::kMalformed);
  EXPECT_EQ(decode_ins_state(bytes.data(), 0, false, &out), InsDecode::kMalformed);
  EXPECT_EQ(decode_ins_state(bytes.data(), bytes.size(), true, &out), InsDecode::kWrongFrame);
}

TEST(LcmCodec, ObstacleMapRoundTripsWithFootprintsWithoutAllocating) {
  std::vector<ObstacleBox> boxes(5);
  std::vector<FootprintRect> rects;
  std::vector<std::uint32_t> offsets, counts;
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    boxes[i].id = static_cast<std::uint32_t>(10 + i);
    boxes[i].kind = i == 4 ? FeatureKind::kGround : FeatureKind::kObstacle;
    boxes[i].min = Eigen::Vector3d(static_cast<double>(i), 2.0, -3.0);
    boxes[i].max = boxes[i].min + Eigen::Vector3d(1, 1, 5);
    boxes[i].cells = static_cast<std::int32_t>(100 + i);
    boxes[i].last_seen_s = 12.25 + static_cast<double>(i);
    boxes[i].prior = i == 2;  // from a prior map, unconfirmed
    offsets.push_back(static_cast<std::uint32_t>(rects.size()));
    counts.push_back(static_cast<std::uint32_t>(i == 3 ? 9 : i));  // box 3: more than 8
    for (std::uint32_t k = 0; k < counts.back(); ++k) {
      rects.push_back({static_cast<float>(i), static_cast<float>(k), static_cast<float>(i) + 0.5f,
                       static_cast<float>(k) + 0.5f});
    }
  }
  ObstacleMapMessage message(16, 8);
  const std::uint8_t* bytes = nullptr;
  std::size_t size = 0;
  {
    os::AllocationScope scope;
    message.fill(1'000'000, Eigen::Vector3d(1, 2, 3), false, boxes.data(), boxes.size(),
                 rects.data(), offsets.data(), counts.data());
    size = message.encode(&bytes);
    EXPECT_EQ(scope.counted().allocations, 0);
    EXPECT_EQ(scope.counted().frees, 0);
  }
  ASSERT_GT(size, 0u);
  zonemap_lcm::obstacle_map_t decoded;
  ASSERT_EQ(decoded.decode(bytes, 0, static_cast<int>(size)), static_cast<int>(size));
  EXPECT_EQ(decoded.generation, 1);
  EXPECT_EQ(decoded.num_boxes, 5);
  EXPECT_EQ(decoded.total_boxes, 5);
  for (int b = 0; b < 5; ++b) {
    const auto& d = decoded.boxes[static_cast<std::size_t>(b)];
    EXPECT_EQ(d.id, 10 + b);
    EXPECT_EQ(d.kind, b == 4 ? 1 : 0);
    EXPECT_EQ(d.min[0], static_cast<double>(b));
    EXPECT_EQ(d.max[2], 2.0);
    EXPECT_EQ(d.cells, 100 + b);
    EXPECT_EQ(d.last_seen_utime, 12'250'000 + 1'000'000 * b);
    EXPECT_EQ(d.prior, b == 2);
    EXPECT_EQ(d.num_footprint, b == 3 ? 0 : b);  // too many rectangles: the box alone
    for (int k = 0; k < d.num_footprint; ++k) {
      EXPECT_EQ(d.footprint[static_cast<std::size_t>(k)][1], static_cast<float>(k));
    }
  }
}

TEST(LcmCodec, ObstacleDistanceRoundTrip) {
  ObstacleDistances d;
  d.min_distance_cm = 50;
  d.max_distance_cm = 5000;
  for (int s = 0; s < kObstacleSectors; ++s) d.distances_cm[s] = static_cast<std::uint16_t>(60 + s);
  const auto bytes = encode(to_message(d, 77));
  zonemap_lcm::obstacle_distance_t m;
  ASSERT_GT(m.decode(bytes.data(), 0, static_cast<int>(bytes.size())), 0);
  EXPECT_EQ(m.utime, 77);
  EXPECT_EQ(m.frame, 12);
  EXPECT_EQ(m.distances_cm[71], 131);
  EXPECT_EQ(m.max_distance_cm, 5000);
}

TEST(LcmPoseSource, MemqDeliversValidPosesAndCountsTheRest) {
  LcmPoseSource source("memq://", "INS_STATE", false, {}, Eigen::Isometry3d::Identity(), 0.0);
  CollectingSink sink;
  lcm_t* lcm = source.provider(0.0);
  ASSERT_NE(lcm, nullptr);
  for (int i = 0; i < 20; ++i) {
    const auto bytes = encode(
        to_message(solution(1.0 + 0.01 * i, {0.1 * i, 0, -20}), false, 1'000'000 + 10'000 * i));
    lcm_publish(lcm, "INS_STATE", bytes.data(), static_cast<unsigned>(bytes.size()));
  }
  const auto good = encode(to_message(solution(5.0, {0, 0, -20}), false, 5'000'000));
  lcm_publish(lcm, "INS_STATE", good.data(), static_cast<unsigned>(good.size() - 3));  // truncated
  const auto other = encode(to_message(ObstacleDistances{}, 0));
  lcm_publish(lcm, "INS_STATE", other.data(), static_cast<unsigned>(other.size()));  // wrong type
  InsSolution invalid = solution(6.0, {0, 0, -20});
  invalid.attitude_valid = false;
  const auto bad_flags = encode(to_message(invalid, false, 6'000'000));
  lcm_publish(lcm, "INS_STATE", bad_flags.data(), static_cast<unsigned>(bad_flags.size()));
  lcm_publish(lcm, "OTHER", good.data(), static_cast<unsigned>(good.size()));  // not subscribed
  while (source.poll(sink, 0) != hal::PollResult::kIdle) {
  }
  ASSERT_EQ(sink.poses.size(), 20u);
  EXPECT_NEAR(sink.poses[19].position.x(), 1.9, 1e-12);
  const hal::PoseSourceCounters c = source.counters();
  EXPECT_EQ(c.messages, 23);
  EXPECT_EQ(c.malformed, 2);
  EXPECT_EQ(c.gate.rejected[static_cast<int>(InsRejection::kFlagsInvalid)], 1);
  EXPECT_EQ(c.poses_out, 20);
}

TEST(LcmPoseSource, ProviderThatCannotStartIsRetriedWithBackoffNeverACrash) {
  LcmPoseSource source("nonsense://nowhere", "INS_STATE", false, {}, Eigen::Isometry3d::Identity(),
                       0.0);
  CollectingSink sink;
  EXPECT_EQ(source.poll(sink, 0), hal::PollResult::kIdle);
  EXPECT_EQ(source.poll(sink, 0), hal::PollResult::kIdle);  // within the backoff: no retry
  EXPECT_EQ(source.counters().link_errors, 1);
  LcmPublisher publisher("nonsense://nowhere");
  EXPECT_FALSE(publisher.publish("X", "a", 1, 0.0));
  EXPECT_EQ(publisher.provider_down(), 1);
}

TEST(LcmLogPoseSource, ReadsALogSkippingOtherChannelsAndBadMessages) {
  const std::string path = ::testing::TempDir() + "/ins.lcmlog";
  {
    lcm_eventlog_t* log = lcm_eventlog_create(path.c_str(), "w");
    ASSERT_NE(log, nullptr);
    auto write = [&](const char* channel, const std::vector<std::uint8_t>& bytes, std::size_t n,
                     std::int64_t t) {
      lcm_eventlog_event_t e{};
      e.timestamp = t;
      e.channellen = static_cast<std::int32_t>(std::strlen(channel));
      e.datalen = static_cast<std::int32_t>(n);
      e.channel = const_cast<char*>(channel);
      e.data = const_cast<std::uint8_t*>(bytes.data());
      ASSERT_EQ(lcm_eventlog_write_event(log, &e), 0);
    };
    for (int i = 0; i < 30; ++i) {
      const auto bytes = encode(
          to_message(solution(2.0 + 0.02 * i, {0, 0.5 * i, -10}), false, 2'000'000 + 20'000 * i));
      write("INS_STATE", bytes, bytes.size(), 2'000'000 + 20'000 * i);
      write("CAMERA", bytes, bytes.size(), 2'000'000 + 20'000 * i);
      if (i == 10) write("INS_STATE", bytes, bytes.size() - 8, 2'000'000 + 20'000 * i);
    }
    lcm_eventlog_destroy(log);
  }
  LcmLogPoseSource source("INS_STATE", false, {}, Eigen::Isometry3d::Identity(), 0.0);
  std::string error;
  ASSERT_TRUE(source.open(path, &error)) << error;
  CollectingSink sink;
  while (source.poll(sink, 0) != hal::PollResult::kEnd) {
  }
  EXPECT_EQ(sink.poses.size(), 30u);
  EXPECT_EQ(source.counters().malformed, 1);
  EXPECT_NEAR(sink.poses[29].position.y(), 14.5, 1e-12);
  LcmLogPoseSource missing("INS_STATE", false, {}, Eigen::Isometry3d::Identity(), 0.0);
  EXPECT_FALSE(missing.open("/nonexistent/ins.lcmlog", &error));
}

TEST(LcmCodec, HealthRoundTrip) {
  zonemap_lcm::health_t m;
  m.utime = 5;
  m.frames_mapped = 1234;
  m.end_to_end_ms_p999 = 42.5f;
  m.num_counters = 2;
  m.counter_names = {"ins_rejected_jump", "can_out_tx_queue_full"};
  m.counter_values = {3, 7};
  const auto bytes = encode(m);
  zonemap_lcm::health_t d;
  ASSERT_EQ(d.decode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  EXPECT_EQ(d.frames_mapped, 1234);
  EXPECT_FLOAT_EQ(d.end_to_end_ms_p999, 42.5f);
  ASSERT_EQ(d.num_counters, 2);
  EXPECT_EQ(d.counter_names[1], "can_out_tx_queue_full");
  EXPECT_EQ(d.counter_values[1], 7);
  EXPECT_LT(d.decode(bytes.data(), 0, static_cast<int>(bytes.size()) - 1), 0);  // truncated
}
