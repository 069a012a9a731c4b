// The map saved in flight: the output thread hands boxes over without waiting or
// allocating, the saver's thread writes them whole; a save while one is being
// written is skipped and counted. (Also run under ThreadSanitizer.)
#include <gtest/gtest.h>

#include <fstream>
#include <string>
#include <vector>

#include "hal/config/prior_map.hpp"
#include "hal/os/allocation_counter.hpp"
#include "hal/output/map_saver.hpp"
#include "test_support.hpp"

namespace zonemap {
namespace {

std::vector<ObstacleBox> posts(int n) {
  std::vector<ObstacleBox> boxes(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    boxes[static_cast<std::size_t>(i)].id = static_cast<std::uint32_t>(i + 1);
    boxes[static_cast<std::size_t>(i)].min = Eigen::Vector3d(10.0 * i, 0, 0);
    boxes[static_cast<std::size_t>(i)].max = Eigen::Vector3d(10.0 * i + 1, 1, 5);
  }
  return boxes;
}

TEST(MapSaver, HandsBoxesOverWithoutWaitingAndTheFileIsAlwaysWhole) {
  testing::TempDir dir;
  const std::string path = dir / "boxes.csv";
  hal::MapSaver saver(path, 0.0, 64);  // every update due
  saver.start();
  const std::vector<ObstacleBox> boxes = posts(40);
  std::int64_t allocations = 0;
  for (int i = 0; i < 300; ++i) {
    hal::ObstacleUpdate update;
    update.boxes = boxes.data();
    update.count = static_cast<std::size_t>(1 + i % 40);
    {
      os::AllocationScope scope;
      saver.publish(update, 0.001 * i);
      allocations += scope.counted().allocations;
    }
    // Whenever a save has landed, the file holds one whole update: a prefix of the boxes.
    hal::PriorMap map;
    std::string error;
    if (saver.saves() > 0) {
      ASSERT_TRUE(hal::load_prior_map(path, true, &map, &error)) << error;
      ASSERT_GE(map.boxes.size(), 1u);
      EXPECT_EQ(map.boxes.back().min.x(), 10.0 * static_cast<double>(map.boxes.size() - 1));
    }
  }
  saver.stop();
  EXPECT_EQ(allocations, 0) << "the output thread's side never allocates";
  hal::HealthSnapshot health;
  saver.report(&health);
  const std::int64_t saves = testing::named_value(health, "map_saves");
  const std::int64_t skipped = testing::named_value(health, "map_saves_skipped_busy");
  const std::int64_t failed = testing::named_value(health, "map_saves_failed");
  EXPECT_GT(saves, 0);
  EXPECT_EQ(saves + skipped, 300) << "every due update saved or counted as skipped";
  EXPECT_EQ(failed, 0);
}

TEST(MapSaver, AFileThatCannotBeWrittenIsCountedNotFatal) {
  testing::TempDir dir;
  hal::MapSaver saver(dir / "no/such/dir/boxes.csv", 0.0, 8);
  saver.start();
  const std::vector<ObstacleBox> boxes = posts(2);
  hal::ObstacleUpdate update;
  update.boxes = boxes.data();
  update.count = boxes.size();
  saver.publish(update, 1.0);
  saver.stop();  // the write in progress finishes first
  hal::HealthSnapshot health;
  saver.report(&health);
  EXPECT_EQ(testing::named_value(health, "map_saves_failed"), 1);
  EXPECT_EQ(saver.saves(), 0);
}

}  // namespace
}  // namespace zonemap
