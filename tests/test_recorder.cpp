// The flight recorder's parts: JSON text, the MCAP file layout, and the promise
// that producers never allocate, never wait and account for every item.
#include <gtest/gtest.h>

#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "hal/os/allocation_counter.hpp"
#include "hal/record/flight_recorder.hpp"
#include "hal/record/foxglove_json.hpp"
#include "hal/record/mcap_writer.hpp"
#include "replay_support.hpp"
#include "test_support.hpp"
#include "tools/replay/replay_run.hpp"

namespace zonemap {
namespace {

using record::JsonWriter;

std::uint64_t u64_at(const std::string& bytes, std::size_t at) {
  std::uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | static_cast<std::uint8_t>(bytes[at + i]);
  return v;
}

TEST(JsonWriter, PutsCommasBetweenValuesAndKeysOnly) {
  std::string out;
  JsonWriter j(&out);
  j.begin_object().key("a").integer(1).key("b").begin_array();
  j.boolean(true).string("x\"y").begin_object().end_object().end_array();
  j.key("t").time(1.5).end_object();
  EXPECT_EQ(out, R"({"a":1,"b":[true,"x\"y",{}],"t":{"sec":1,"nsec":500000000}})");
}

TEST(JsonWriter, Base64IsRfc4648) {
  const char* cases[][2] = {{"", ""},
                            {"f", "Zg=="},
                            {"fo", "Zm8="},
                            {"foo", "Zm9v"},
                            {"foob", "Zm9vYg=="},
                            {"fooba", "Zm9vYmE="},
                            {"foobar", "Zm9vYmFy"}};
  for (const auto& c : cases) {
    std::string out;
    JsonWriter(&out).base64(c[0], std::strlen(c[0]));
    EXPECT_EQ(out, std::string("\"") + c[1] + "\"") << c[0];
  }
}

TEST(JsonWriter, NegativeOrNonFiniteTimesAreZero) {
  EXPECT_EQ(record::time_ns(-1.0), 0u);
  EXPECT_EQ(record::time_ns(NAN), 0u);
  EXPECT_EQ(record::time_ns(2.25), 2250000000u);
}

// Magic at both ends, the footer pointing at the summary (which starts with the
// schemas) right after Data End, and a message's bytes stored verbatim when
// chunks are not compressed.
TEST(McapWriter, FooterPointsAtTheSummaryAfterDataEnd) {
  testing::TempDir dir;
  const std::string path = dir / "t.mcap";
  record::McapWriter w;
  std::string error;
  record::McapOptions options;
  options.zstd = false;
  ASSERT_TRUE(w.open(path, options, &error)) << error;
  const std::uint16_t ch = w.add_channel(w.add_schema("s", "jsonschema", "{}"), "/t", "json");
  for (int i = 0; i < 3; ++i) w.write(ch, 1000u * i, 1000u * i, R"({"hello":"mcap"})");
  ASSERT_TRUE(w.close(&error)) << error;
  EXPECT_EQ(w.counts().messages, 3u);

  const std::string bytes = testing::read_text(path);
  const std::string magic("\x89MCAP0\r\n", 8);
  ASSERT_GT(bytes.size(), 64u);
  EXPECT_EQ(bytes.substr(0, 8), magic);
  EXPECT_EQ(bytes.substr(bytes.size() - 8), magic);
  const std::size_t footer = bytes.size() - 8 - (1 + 8 + 20);
  EXPECT_EQ(bytes[footer], 0x02);
  const std::uint64_t summary = u64_at(bytes, footer + 9);
  const std::uint64_t offsets = u64_at(bytes, footer + 17);
  ASSERT_LT(summary, offsets);
  EXPECT_EQ(bytes[summary], 0x03);       // a Schema record opens the summary
  EXPECT_EQ(bytes[summary - 13], 0x0F);  // Data End just before it
  EXPECT_EQ(bytes[offsets], 0x0E);       // Summary Offset records after it
  EXPECT_NE(bytes.find(R"({"hello":"mcap"})"), std::string::npos);
}

hal::ObstacleUpdate one_box_update(const ObstacleBox* box, double t) {
  hal::ObstacleUpdate u;
  u.time_s = t;
  u.boxes = box;
  u.count = 1;
  return u;
}

// Producers copy into reserved slots: no allocation whatever they push, and
// every item is either recorded or counted as dropped.
TEST(FlightRecorder, ProducersNeverAllocateAndAccountForEveryItem) {
  testing::TempDir dir;
  record::RecorderConfig config;
  config.path = dir / "run.mcap";
  config.max_boxes = 8;
  config.max_rects = 8;
  config.depth_width = 64;
  config.depth_height = 48;
  record::FlightRecorder recorder;
  std::string error;
  ASSERT_TRUE(recorder.open(config, &error)) << error;
  const std::vector<std::uint16_t> depth(64 * 48, 1000);
  ObstacleBox box;
  box.id = 7;
  box.max = Eigen::Vector3d(1, 1, 1);
  constexpr int kItems = 2000;
  int accepted_poses = 0, accepted_boxes = 0;
  os::AllocationCounts counted;
  {
    os::AllocationScope scope;
    for (int i = 0; i < kItems; ++i) {
      const double t = 0.01 * i;
      accepted_poses += recorder.record_pose(t, Eigen::Isometry3d::Identity());
      accepted_boxes += recorder.record_boxes(one_box_update(&box, t));
      recorder.record_depth(t, depth.data());
      hal::HealthSnapshot h;
      h.time_s = t;
      recorder.record_health(h);
    }
    counted = scope.counted();
  }
  EXPECT_EQ(counted.allocations, 0);
  recorder.record_final_boxes(one_box_update(&box, 100.0));
  ASSERT_TRUE(recorder.close(&error)) << error;
  const record::RecorderCounts c = recorder.counts();
  EXPECT_EQ(c.poses, accepted_poses);
  EXPECT_EQ(c.boxes_updates, accepted_boxes + 1);  // the final one always
  EXPECT_EQ(c.poses + c.boxes_updates - 1 + c.depth_images + c.health + c.dropped, 4 * kItems);
  EXPECT_GT(c.bytes, 0);
}

TEST(FlightRecorder, RefusesAndCountsItemsWhenNotOpen) {
  record::FlightRecorder recorder;
  EXPECT_FALSE(recorder.record_pose(0.0, Eigen::Isometry3d::Identity()));
  hal::HealthSnapshot h;
  EXPECT_FALSE(recorder.record_health(h));
  EXPECT_EQ(recorder.counts().dropped, 2);
}

TEST(FlightRecorder, SaysWhyItCannotCreateTheFile) {
  record::RecorderConfig config;
  config.path = "/nonexistent-dir/run.mcap";
  record::FlightRecorder recorder;
  std::string error;
  EXPECT_FALSE(recorder.open(config, &error));
  EXPECT_NE(error.find("/nonexistent-dir/run.mcap"), std::string::npos) << error;
}

// A replay records while it maps, single-threaded and through the threaded
// runtime (where poses and depth come from the mapping thread, boxes from the
// output thread: the TSan build runs this), and says what it recorded.
void expect_replay_records(bool pipelined) {
  testing::TempDir dir;
  const std::string sequence = dir / "seq";
  const std::string config =
      testing::write_test_scenario("posts-around", sequence, 4.0, testing::kRuntimePixelStep, 60);
  tools::ReplayOptions options = testing::quiet_replay(sequence, config);
  options.record_path = dir / "run.mcap";
  options.record_depth_every = 2;
  tools::ReplayRun run;
  std::string error;
  ASSERT_TRUE(run.open(options, &error)) << error;
  if (pipelined) {
    run.run_pipelined(runtime::PipelineOptions{});
  } else {
    run.run();
  }
  std::map<std::string, std::int64_t> recorded(run.stats().recording.begin(),
                                               run.stats().recording.end());
  const std::int64_t mapped = run.stats().frames_mapped;
  ASSERT_GT(mapped, 20);
  EXPECT_EQ(recorded["poses"] + recorded["dropped"] >= mapped, true);
  EXPECT_GT(recorded["poses"], 0);
  EXPECT_GT(recorded["depth_images"], 0);
  EXPECT_GE(recorded["boxes_updates"], 1);  // the final scene at least
  EXPECT_GE(recorded["occupied_clouds"], 1);
  EXPECT_GT(recorded["bytes"], 1000);
  EXPECT_EQ(run.stats().heap_allocations_after_init, 0);
  const std::string bytes = testing::read_text(dir / "run.mcap");
  EXPECT_EQ(bytes.substr(bytes.size() - 8), std::string("\x89MCAP0\r\n", 8));
}

TEST(ReplayRecording, SingleThreadedRunRecordsWhatItMaps) {
  expect_replay_records(false);
}
TEST(ReplayRecording, ThreadedRunRecordsWhatItMaps) {
  expect_replay_records(true);
}

}  // namespace
}  // namespace zonemap
