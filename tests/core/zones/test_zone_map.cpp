// Zones (paper §III-D): the environment follows the camera, at most 8 zones hold
// a grid, buffers come from the pool reserved at start-up.
#include <gtest/gtest.h>

#include <cstdlib>
#include <set>
#include <tuple>
#include <vector>

#include "core_test_support.hpp"
#include "zonemap/integrator/local_grid.hpp"
#include "zonemap/zones/zone_map.hpp"

namespace zonemap {
namespace {

using testing::small_centred_config;

struct RecordingObserver : ZoneObserver {
  std::vector<ZoneKey> allocated;
  std::vector<ZoneKey> discarded;
  void on_zone_allocated(ZoneView& zone) override { allocated.push_back(zone.key); }
  void on_zone_discarding(const ZoneView& zone) override { discarded.push_back(zone.key); }
};

TEST(ZoneMap, EnvironmentIsCentredOnTheCameraCell) {
  ZoneMap zones(small_centred_config());
  const CellIndex origin = zones.environment_origin({23, -7, 1});
  EXPECT_EQ(origin, (CellIndex{18, -12, -1}));
}

TEST(ZoneMap, EnvironmentBelowTheCameraReachesDown) {
  MapConfig config = small_centred_config();
  config.placement = MapConfig::Placement::kBelow;
  config.zone_cells = {10, 10, 20};
  config.above_camera_m = 2.0;  // two cells above the camera's cell
  ZoneMap zones(config);
  // z up: the camera's cell is the third from the top (z = 8 of -9..10).
  EXPECT_EQ(zones.environment_origin({23, -7, 8}, true), (CellIndex{18, -12, -9}));
  // NED (z down): the same, mirrored: the environment reaches to larger z.
  EXPECT_EQ(zones.environment_origin({23, -7, -8}, false), (CellIndex{18, -12, -10}));
  config.above_camera_m = 100.0;  // more than the environment: the camera at its bottom
  EXPECT_EQ(ZoneMap(config).environment_origin({0, 0, 8}, true).z, 8);
}

TEST(ZoneMap, KeysUseFloorDivisionForNegativeCells) {
  ZoneMap zones(small_centred_config());
  EXPECT_EQ(zones.key_of({-1, 0, 0}), (ZoneKey{-1, 0, 0}));
  EXPECT_EQ(zones.key_of({-10, 9, -4}), (ZoneKey{-1, 0, -1}));
  EXPECT_EQ(zones.key_of({-11, 10, 3}), (ZoneKey{-2, 1, 0}));
}

TEST(ZoneMap, StraightFlightAcrossBoundariesAllocatesAndDiscards) {
  ZoneMap zones(small_centred_config());
  RecordingObserver observer;
  zones.add_observer(&observer);
  std::set<const FusedCell*> buffers;
  // Fly along +x from cell 2 to cell 47 at y = 5, z = 2 (zone centre in y and z).
  for (int x = 2; x <= 47; ++x) {
    const CellIndex camera{x, 5, 2};
    const CellIndex origin = zones.environment_origin(camera);
    zones.move_environment(origin);
    EXPECT_LE(zones.live_zone_count(), kZonesHeld);
    // Exactly the zones the environment overlaps hold a grid.
    std::set<std::tuple<int, int, int>> live;
    zones.for_each_live_zone([&](ZoneView& z) {
      live.insert({z.key.i, z.key.j, z.key.k});
      buffers.insert(z.cells);
    });
    std::set<std::tuple<int, int, int>> expected;
    const ZoneKey lo = zones.key_of(origin);
    const ZoneKey hi = zones.key_of({origin.x + 9, origin.y + 9, origin.z + 3});
    for (int i = lo.i; i <= hi.i; ++i)
      for (int j = lo.j; j <= hi.j; ++j)
        for (int k = lo.k; k <= hi.k; ++k) expected.insert({i, j, k});
    EXPECT_EQ(live, expected) << "camera x=" << x;
  }
  // Environment x range [x-5, x+4] runs from [-3, 6] to [42, 51]: zone columns
  // -1..5 are each allocated once; all but the last two (4, 5) are discarded.
  // The y range [0, 9] is one zone row and the z range [0, 3] one zone layer.
  EXPECT_EQ(zones.zones_allocated(), 7);
  EXPECT_EQ(zones.zones_discarded(), 5);
  ASSERT_EQ(observer.allocated.size(), 7u);
  ASSERT_EQ(observer.discarded.size(), 5u);
  EXPECT_EQ(observer.discarded.front(), (ZoneKey{-1, 0, 0}));
  EXPECT_EQ(observer.allocated.back(), (ZoneKey{5, 0, 0}));
  EXPECT_LE(buffers.size(), static_cast<std::size_t>(kZonesHeld)) << "buffers come from the pool";
}

TEST(ZoneMap, DiagonalMoveHoldsEightZonesAtMost) {
  ZoneMap zones(small_centred_config());
  int max_live = 0;
  for (int s = 0; s < 60; ++s) {
    zones.move_environment(zones.environment_origin({s, s, s / 3}));
    max_live = std::max(max_live, zones.live_zone_count());
    ASSERT_LE(zones.live_zone_count(), kZonesHeld);
  }
  EXPECT_EQ(max_live, 8) << "off-boundary positions overlap 2x2x2 zones";
}

TEST(ZoneMap, ZonesLeftBehindTogetherGoOneAMoveAndOneComingBackIsWhole) {
  // The environment across 2x2x2 zones moves half a zone along x: the four zones
  // of column i = 0 are left behind at once. Their extraction (the observers)
  // is spread, one a move, oldest first; those not yet discarded when the
  // environment comes back still hold what was fused into them.
  ZoneMap zones(small_centred_config());
  RecordingObserver observer;
  zones.add_observer(&observer);
  zones.move_environment(zones.environment_origin({10, 10, 4}));
  ASSERT_EQ(zones.live_zone_count(), 8);
  std::vector<ZoneKey> column;
  zones.for_each_live_zone([&](ZoneView& z) {
    if (z.key.i == 0) {
      z.cells[z.index(1, 1, 1)] = 7 * kCellScale;  // something fused there
      column.push_back(z.key);
    }
  });
  ASSERT_EQ(column.size(), 4u);
  zones.move_environment(zones.environment_origin({15, 10, 4}));
  EXPECT_EQ(observer.discarded.size(), 1u) << "one of the four at once";
  EXPECT_EQ(zones.left_behind_count(), 3);
  zones.move_environment(zones.environment_origin({15, 10, 4}));
  EXPECT_EQ(observer.discarded.size(), 2u);
  EXPECT_EQ(zones.left_behind_count(), 2);
  // Back: the two still held are the environment's again, as they were.
  zones.move_environment(zones.environment_origin({10, 10, 4}));
  EXPECT_EQ(zones.left_behind_count(), 0);
  EXPECT_EQ(observer.allocated.size(), 8u + 2u) << "only the two discarded come back empty";
  int kept = 0, cleared = 0;
  for (const ZoneKey& key : column) {
    ZoneView view;
    ASSERT_TRUE(zones.live_view(key, &view));
    const FusedCell v = view.cells[view.index(1, 1, 1)];
    kept += v == 7 * kCellScale ? 1 : 0;
    cleared += v == 0 ? 1 : 0;
  }
  EXPECT_EQ(kept, 2);
  EXPECT_EQ(cleared, 2);
  EXPECT_EQ(zones.zones_discarded(), 2);
}

TEST(ZoneMap, ReturningZoneStartsUnknown) {
  ZoneMap zones(small_centred_config());
  LocalGrid local(small_centred_config().zone_cells);
  CellIndex origin = zones.environment_origin({5, 5, 2});
  zones.move_environment(origin);
  local.reset(origin);
  local.extend_touched(5, 5, 2, 5, 5, 2);
  local.write_max(5, 5, 2, kCellScale);  // world cell (5, 5, 2)
  local.finish(0);
  zones.fuse(local);
  FusedCell v = 0;
  ASSERT_TRUE(zones.value_at({5, 5, 2}, &v));
  EXPECT_EQ(v, kCellScale);
  zones.move_environment(zones.environment_origin({45, 5, 2}));
  EXPECT_FALSE(zones.value_at({5, 5, 2}, &v)) << "the grid of a zone left behind is discarded";
  zones.move_environment(zones.environment_origin({5, 5, 2}));
  ASSERT_TRUE(zones.value_at({5, 5, 2}, &v));
  EXPECT_EQ(v, 0) << "a re-allocated zone starts unknown (features re-integrate later)";
}

}  // namespace
}  // namespace zonemap
