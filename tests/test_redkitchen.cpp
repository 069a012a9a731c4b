// Real depth frames (Kinect v1, 7-Scenes redkitchen 0-59) from ../shared/data,
// when present: real sensor noise, holes and pose error.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <unordered_set>

#include "hal/codec/png_io.hpp"
#include "replay_support.hpp"
#include "test_support.hpp"
#include "tools/replay/replay_run.hpp"

namespace zonemap {
namespace {

const std::string kSequence = std::string(ZONEMAP_SHARED_DATA_DIR) + "/redkitchen-0000-0059";

std::uint64_t cell_key(const CellIndex& c) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(c.x) & 0x1FFFFF) << 42) |
         (static_cast<std::uint64_t>(static_cast<std::uint32_t>(c.y) & 0x1FFFFF) << 21) |
         (static_cast<std::uint64_t>(static_cast<std::uint32_t>(c.z) & 0x1FFFFF));
}

TEST(RedKitchen, RealFramesMapWithoutRejectsAndOccupiedCellsLieOnMeasurements) {
  if (!std::filesystem::exists(kSequence + "/depth.txt")) {
    GTEST_SKIP() << "real test data absent: " << kSequence
                 << " (../shared/data is not part of the repository)";
  }
  tools::ReplayRun run;
  tools::ReplayOptions options =
      testing::quiet_replay(kSequence, testing::source_path("config/indoor-kinect.yaml"));
  std::string error;
  ASSERT_TRUE(run.open(options, &error)) << error;
  run.run();
  const hal::RunStats& s = run.stats();
  EXPECT_EQ(s.frames_in, 60);
  EXPECT_EQ(s.frames_mapped, 60);
  EXPECT_EQ(s.frames_rejected, 0);
  EXPECT_EQ(s.frames_skipped_no_pose, 0);
  EXPECT_EQ(s.poses_rejected, 0);
  EXPECT_EQ(s.heap_allocations_after_init, 0);

  // Every depth measurement of every frame, re-projected into world cells.
  Mapper& mapper = run.mapper();
  const CameraModel& camera = run.sequence().camera();
  std::unordered_set<std::uint64_t> measured;
  hal::CameraFrame frame = run.sequence().make_frame();
  for (std::size_t i = 0; i < run.sequence().frame_count(); ++i) {
    ASSERT_TRUE(run.sequence().read(i, &frame, &error)) << error;
    Eigen::Isometry3d pose;
    ASSERT_NE(run.sequence().poses().lookup(frame.time_s, &pose), PoseLookup::kNoPose);
    for (int v = 0; v < camera.height; ++v)
      for (int u = 0; u < camera.width; ++u) {
        const std::uint16_t raw = frame.depth[static_cast<std::size_t>(v) * camera.width + u];
        if (raw == 0) continue;
        const double d = raw / camera.depth_scale;
        const Eigen::Vector3d p(d * (u - camera.cx) / camera.fx, d * (v - camera.cy) / camera.fy,
                                d);
        measured.insert(cell_key(mapper.cell_of(pose * p)));
      }
  }
  std::int64_t occupied = 0;
  std::int64_t near_measurement = 0;
  mapper.zones().for_each_live_zone([&](ZoneView& zone) {
    for (int z = 0; z < zone.dims[2]; ++z)
      for (int y = 0; y < zone.dims[1]; ++y)
        for (int x = 0; x < zone.dims[0]; ++x) {
          if (zone.cells[zone.index(x, y, z)] <= mapper.occupied_threshold()) continue;
          ++occupied;
          const CellIndex c{zone.origin.x + x, zone.origin.y + y, zone.origin.z + z};
          bool found = false;
          for (int dz = -2; dz <= 2 && !found; ++dz)
            for (int dy = -2; dy <= 2 && !found; ++dy)
              for (int dx = -2; dx <= 2 && !found; ++dx)
                found = measured.count(cell_key({c.x + dx, c.y + dy, c.z + dz})) > 0;
          if (found) ++near_measurement;
        }
  });
  const double fraction = static_cast<double>(near_measurement) / static_cast<double>(occupied);
  std::printf(
      "[ redkitchen ] %lld occupied cells, %.2f%% within 2 cells of a measurement; frame ms "
      "p50 %.1f\n",
      static_cast<long long>(occupied), 100.0 * fraction, s.frame_ms_p50);
  EXPECT_GT(occupied, 10000);
  EXPECT_GE(fraction, 0.90);
}

}  // namespace
}  // namespace zonemap
