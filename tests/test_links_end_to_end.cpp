// One obstacle's position end to end on the CAN link: a generated posts flight
// mapped, its boxes through the CAN encoder, the frames decoded with nothing but
// the layout in config/can/zonemap-obstacles.dbc (read by the DBC reader, bits
// pulled out here), each post of the flight's ground truth inside a decoded box,
// and the frame the boxes are in said by the update itself.
#include <gtest/gtest.h>
#include <lcm/eventlog.h>

#include <cmath>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "hal/can/candump.hpp"
#include "hal/can/dbc.hpp"
#include "hal/can/obstacle_can.hpp"
#include "replay_support.hpp"
#include "test_support.hpp"
#include "tools/eval/evaluate.hpp"
#include "tools/replay/replay_run.hpp"
#include "zonemap_lcm/obstacle_map_t.hpp"

namespace zonemap {
namespace {

// A DBC signal's physical value from a classic CAN frame (little-endian Intel
// layout, as every signal of our layouts is).
double physical(const can::CanFrame& f, const can::DbcSignal& s) {
  std::uint64_t payload = 0;
  for (int i = 0; i < 8; ++i) payload |= static_cast<std::uint64_t>(f.data[i]) << (8 * i);
  std::uint64_t raw = (payload >> s.start_bit) & ((s.length == 64 ? 0 : (1ull << s.length)) - 1);
  std::int64_t value = static_cast<std::int64_t>(raw);
  if (s.is_signed && (raw >> (s.length - 1)) != 0)
    value -= static_cast<std::int64_t>(1ull << s.length);
  return static_cast<double>(value) * s.factor + s.offset;
}

struct DbcBox {
  Eigen::Vector3d min = Eigen::Vector3d::Zero(), max = Eigen::Vector3d::Zero();
  bool ground = false;
};

// Decodes one update with the DBC's signals: BEGIN (anchor), BOX_MIN/BOX_MAX, END.
std::vector<DbcBox> decode_with_dbc(const std::vector<can::CanFrame>& frames,
                                    const std::vector<can::DbcMessage>& dbc, double* flags) {
  std::map<std::uint32_t, std::map<std::string, const can::DbcSignal*>> by_id;
  for (const can::DbcMessage& m : dbc)
    for (const can::DbcSignal& s : m.signals) by_id[m.id][s.name] = &s;
  const auto base = [&](const char* name) {
    for (const can::DbcMessage& m : dbc)
      if (m.name == name) return m.id;
    return 0u;
  };
  const std::uint32_t begin = base("ZM_OBST_BEGIN"), box_min = base("ZM_OBST_BOX_MIN"),
                      box_max = base("ZM_OBST_BOX_MAX"), end = base("ZM_OBST_END");
  std::vector<DbcBox> boxes;
  double ax = 0, ay = 0;
  for (const can::CanFrame& f : frames) {
    auto& sig = by_id[f.id];
    if (f.id == begin) {
      ax = physical(f, *sig["ANCHOR_X"]);
      ay = physical(f, *sig["ANCHOR_Y"]);
    } else if (f.id == box_min) {
      DbcBox b;
      b.min = {physical(f, *sig["MIN_X"]) + ax, physical(f, *sig["MIN_Y"]) + ay,
               physical(f, *sig["MIN_Z"])};
      b.ground = physical(f, *sig["GROUND"]) != 0;
      boxes.push_back(b);
    } else if (f.id == box_max) {
      boxes.back().max = {physical(f, *sig["MAX_X"]) + ax, physical(f, *sig["MAX_Y"]) + ay,
                          physical(f, *sig["MAX_Z"])};
    } else if (f.id == end) {
      *flags = physical(f, *sig["FLAGS"]);
    }
  }
  return boxes;
}

// Whether the middle of every object of the flight lies in a decoded obstacle box.
void expect_each_object_inside(const std::string& sequence, const std::vector<DbcBox>& decoded,
                               const char* link) {
  std::vector<tools::TruthObject> objects;
  std::string error;
  ASSERT_TRUE(tools::load_objects_yaml(sequence + "/objects.yaml", &objects, &error)) << error;
  ASSERT_FALSE(objects.empty());
  for (const tools::TruthObject& post : objects) {
    const Eigen::Vector3d middle(post.centre.x(), post.centre.y(),
                                 0.5 * (post.min.z() + post.max.z()));
    bool inside = false;
    for (const DbcBox& b : decoded) {
      inside |= !b.ground && (middle.array() >= b.min.array() - 0.1).all() &&
                (middle.array() <= b.max.array() + 0.1).all();
    }
    EXPECT_TRUE(inside) << post.name << " at " << middle.transpose()
                        << " is in no box received over " << link;
  }
}

TEST(CanEndToEnd, EachPostOfAFlightIsInsideABoxDecodedFromTheDbcLayout) {
  testing::TempDir dir;
  const std::string sequence = dir / "seq";
  const std::string config = testing::write_test_scenario("posts-through", sequence, 4.0, 4);
  ASSERT_FALSE(config.empty());
  tools::ReplayRun run;
  tools::ReplayOptions options = testing::quiet_replay(sequence, config);
  std::string error;
  ASSERT_TRUE(run.open(options, &error)) << error;
  run.run();
  const std::vector<ObstacleBox> boxes = run.boxes(false);
  ASSERT_FALSE(boxes.empty());

  can::ObstacleCanConfig can_config;
  can::ObstacleCanEncoder encoder(can_config);
  std::vector<std::uint32_t> order(boxes.size());
  std::vector<can::CanFrame> frames(encoder.frames_per_update());
  const Eigen::Vector3d vehicle = run.trajectory().back();
  frames.resize(encoder.encode(boxes.data(), boxes.size(), vehicle,
                               run.sequence().camera().world_z_up, 1.0, order.data(),
                               frames.data()));
  std::vector<can::DbcMessage> dbc;
  ASSERT_TRUE(can::read_dbc(testing::source_path("config/can/zonemap-obstacles.dbc"), &dbc, &error))
      << error;
  double flags = -1;
  const std::vector<DbcBox> decoded = decode_with_dbc(frames, dbc, &flags);
  ASSERT_EQ(decoded.size(), boxes.size());
  // The generated world is z up: FLAGS bit 2 (z down) clear, said in the update.
  EXPECT_EQ(static_cast<int>(flags) & can::kObstacleWorldZDown, 0);

  expect_each_object_inside(sequence, decoded, "CAN");
}

// zonemap-replay --links: the candump log read line by line and its last update
// decoded with the DBC's layout; the LCM event log read by LCM's own reader and its
// last obstacle map decoded by lcm-gen's code; both with every post in a box.
TEST(LinkCapture, TheReplaysCandumpAndLcmLogCarryEveryPost) {
  testing::TempDir dir;
  const std::string sequence = dir / "seq";
  const std::string config = testing::write_test_scenario("posts-through", sequence, 4.0, 4);
  ASSERT_FALSE(config.empty());
  tools::ReplayRun run;
  tools::ReplayOptions options = testing::quiet_replay(sequence, config);
  options.links_dir = dir / "links";
  std::string error;
  ASSERT_TRUE(run.open(options, &error)) << error;
  run.run();
  const std::size_t boxes = run.boxes(false).size();
  ASSERT_GT(boxes, 0u);

  std::vector<can::DbcMessage> dbc;
  ASSERT_TRUE(can::read_dbc(testing::source_path("config/can/zonemap-obstacles.dbc"), &dbc, &error))
      << error;
  std::ifstream candump(dir / "links/obstacles.candump");
  std::vector<can::CanFrame> update, last_update;
  int updates = 0;
  double last_time = -1.0;
  for (std::string line; std::getline(candump, line);) {
    can::CanFrame frame;
    const char* why = nullptr;
    ASSERT_EQ(can::parse_candump_line(line, &frame, nullptr, &why), can::CandumpLine::kFrame)
        << line;
    EXPECT_GE(frame.time_s, last_time) << "frames out of time order";
    last_time = frame.time_s;
    update.push_back(frame);
    if (frame.id == can::ObstacleCanConfig{}.base_id + 3) {  // END
      ++updates;
      last_update.swap(update);
      update.clear();
    }
  }
  EXPECT_TRUE(update.empty()) << "an update without its END";
  EXPECT_GE(updates, 5);
  double flags = -1;
  const std::vector<DbcBox> decoded = decode_with_dbc(last_update, dbc, &flags);
  EXPECT_EQ(decoded.size(), boxes);
  expect_each_object_inside(sequence, decoded, "CAN (candump log)");

  lcm_eventlog_t* log = lcm_eventlog_create((dir / "links/obstacles.lcmlog").c_str(), "r");
  ASSERT_NE(log, nullptr);
  zonemap_lcm::obstacle_map_t map;
  int maps = 0, distances = 0;
  while (lcm_eventlog_event_t* event = lcm_eventlog_read_next_event(log)) {
    const std::string channel(event->channel, static_cast<std::size_t>(event->channellen));
    if (channel == "OBSTACLE_MAP") {
      ASSERT_EQ(map.decode(event->data, 0, event->datalen), event->datalen);
      EXPECT_EQ(map.utime, event->timestamp) << "an event stamped with another time";
      ++maps;
    }
    distances += channel == "OBSTACLE_DIST" ? 1 : 0;
    lcm_eventlog_free_event(event);
  }
  lcm_eventlog_destroy(log);
  EXPECT_GE(maps, 5);
  EXPECT_EQ(distances, maps);
  ASSERT_EQ(static_cast<std::size_t>(map.num_boxes), boxes);
  std::vector<DbcBox> from_lcm;
  for (const zonemap_lcm::obstacle_box_t& b : map.boxes) {
    DbcBox box;
    box.min = {b.min[0], b.min[1], b.min[2]};
    box.max = {b.max[0], b.max[1], b.max[2]};
    box.ground = b.kind == zonemap_lcm::obstacle_box_t::KIND_GROUND;
    from_lcm.push_back(box);
  }
  expect_each_object_inside(sequence, from_lcm, "LCM (event log)");
}

TEST(CanEndToEnd, AnNedWorldIsSaidInTheUpdate) {
  ObstacleBox box;
  box.id = 1;
  box.min = Eigen::Vector3d(10, 0, -5);
  box.max = Eigen::Vector3d(11, 1, 0);
  can::ObstacleCanEncoder encoder(can::ObstacleCanConfig{});
  std::uint32_t order = 0;
  std::vector<can::CanFrame> frames(encoder.frames_per_update());
  const std::size_t n =
      encoder.encode(&box, 1, Eigen::Vector3d::Zero(), false, 0.0, &order, frames.data());
  can::ObstacleCanDecoder decoder;
  bool complete = false;
  for (std::size_t i = 0; i < n; ++i) complete = decoder.feed(frames[i]);
  ASSERT_TRUE(complete);
  EXPECT_NE(decoder.flags() & can::kObstacleWorldZDown, 0);
}

}  // namespace
}  // namespace zonemap
