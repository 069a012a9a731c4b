// The core's proofs of "no heap allocation after start-up", through the
// counting allocator (hal/os), which the core's own test binary does not link:
// the mapping step, feature extraction with re-integration and merging, the
// shared-map inbox and the planner queries. The counter itself is checked first.
#include <gtest/gtest.h>

#include <array>
#include <cstdlib>
#include <vector>

#include "core/features/feature_test_zone.hpp"
#include "core/outputs/query_world.hpp"
#include "hal/os/allocation_counter.hpp"
#include "test_support.hpp"
#include "tools/sim/scene.hpp"
#include "zonemap/features/feature_map.hpp"
#include "zonemap/features/shared_map_inbox.hpp"
#include "zonemap/mapping/mapper.hpp"
#include "zonemap/outputs/queries.hpp"

namespace zonemap {
namespace {

using testing::feature_config;
using testing::small_centred_config;
using testing::TestZone;
using testing::World;

TEST(Mapper, CountingReallyCountsAllocations) {
  // Guards the proof above: allocations in a counted scope are seen, C++ and C.
  os::AllocationScope scope;
  auto* p = new std::vector<int>(100);
  delete p;
  EXPECT_GE(scope.counted().allocations, 2);
  EXPECT_GE(scope.counted().frees, 2);
  [[maybe_unused]] const os::AllocationCounts before = scope.counted();
  void* volatile c = std::malloc(64);
  std::free(c);
#if !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
  EXPECT_EQ(scope.counted().allocations, before.allocations + 1) << "malloc is counted";
  EXPECT_EQ(scope.counted().frees, before.frees + 1);
#endif
}

TEST(Mapper, NoHeapAllocationAfterInit) {
  MapConfig config = small_centred_config();
  config.zone_cells = {40, 40, 16};
  config.cell_size_m = 0.5;
  config.d_min_m = 1.0;
  config.d_max_m = 15.0;
  config.blur_keep_near_m = 8.0;  // its cube reserved at start too
  CameraModel camera;
  camera.width = 64;
  camera.height = 48;
  camera.fx = camera.fy = 60.0;
  camera.cx = 31.5;
  camera.cy = 23.5;
  camera.baseline_m = 0.3;
  camera.match_sigma_px = 0.25;
  camera.depth_scale = 1000.0;
  sim::Scene scene;
  scene.boxes.push_back({"box", {6, -2, 0}, {8, 2, 3}});
  std::vector<std::uint16_t> depth(64 * 48);
  std::vector<std::uint8_t> left(64 * 48);
  sim::Rng rng(7);

  Mapper mapper(config, camera);  // all memory reserved here
  DepthFrameView view{depth.data(), left.data(), camera.width, camera.height};
  std::int64_t allocated_zones_before = 0;
  os::AllocationCounts total;
  for (int frame = 0; frame < 40; ++frame) {
    // Fly 1 m per frame so that zone boundaries are crossed several times.
    const Eigen::Isometry3d pose = sim::look_pose({frame * 1.0 - 20.0, 0.3 * frame, 2.0}, 0.0, 0.2);
    sim::render(scene, camera, pose, sim::RenderOptions{}, rng, depth.data(), left.data());
    os::AllocationScope scope;
    const FrameReport report = mapper.integrate(view, pose);
    const os::AllocationCounts c = scope.counted();
    total.allocations += c.allocations;
    total.frees += c.frees;
    ASSERT_EQ(report.status, FrameStatus::kMapped);
    if (frame == 0) allocated_zones_before = mapper.zones().zones_allocated();
  }
  EXPECT_GT(mapper.zones().zones_allocated(), allocated_zones_before) << "boundaries were crossed";
  EXPECT_EQ(total.allocations, 0);
  EXPECT_EQ(total.frees, 0);
}

TEST(FeatureStore, ExtractionAndReintegrationDoNotAllocate) {
  const std::array<int, 3> dims = {30, 30, 12};
  FeatureMap map(feature_config(dims, true), true);
  TestZone zone(dims, {0, 0, 0});
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 30; ++x) zone.set(x, y, 2);
  for (int z = 3; z <= 9; ++z) zone.set(15, 12, z);
  os::AllocationScope scope;
  for (int i = 0; i < 3; ++i) map.extract(zone.view);
  TestZone* again = &zone;
  map.on_zone_allocated(again->view);
  std::array<ObstacleBox, 8> boxes;
  map.merged(boxes.data(), boxes.size(), true);
  EXPECT_EQ(scope.counted().allocations, 0);
}

TEST(Queries, DoNotAllocateAndAreBounded) {
  World w;
  MapQueries q(w.features, w.zones, w.config.cell_size_m, 1, 1000);
  os::AllocationScope scope;
  std::uint32_t ids[8];
  (void)q.is_free({0, 0, 0}, {30, 5, 2});
  (void)q.first_hit({0, 0, 0}, {1, 0.1, 0}, 40.0);
  (void)q.obstacles_in({20, 0, 0}, {30, 8, 4}, ids, 8);
  EXPECT_EQ(scope.counted().allocations, 0);
  // A segment longer than the walking bound is reported blocked, never free.
  EXPECT_FALSE(q.is_free({-1000, 0.3, 0.3}, {-1000 + 900, 0.3, 0.3}));
  EXPECT_FALSE(q.first_hit({0, 0, 0}, {0, 0, 0}, 10.0).hit) << "no direction: no hit";
}

TEST(SharedMap, TheInboxHandsOverWithoutAllocating) {
  // Every operation once the inbox is built: filled, a full one refused, emptied
  // (their order and counts: tests/core/features/test_shared_maps.cpp).
  SharedMapInbox inbox(8);
  os::AllocationScope scope;
  while (SharedMapUpdate* t = inbox.take_free()) inbox.post(t);
  while (SharedMapUpdate* u = inbox.next()) inbox.release(u);
  EXPECT_EQ(scope.counted().allocations, 0);
}

}  // namespace
}  // namespace zonemap
