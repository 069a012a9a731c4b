// The sky filter through a whole replay with the shipped flight-2 configuration:
// no cell of a white object is freed in the map (the filter itself, pixel by
// pixel: tests/core/depth/test_sky_filter.cpp).
#include <gtest/gtest.h>

#include <cstdio>

#include "replay_support.hpp"
#include "test_support.hpp"
#include "tools/replay/replay_run.hpp"
#include "tools/sim/scenarios.hpp"
#include "tools/sim/scene.hpp"

namespace zonemap {
namespace {

TEST(SkyFilter, NoCellOfAWhiteWallIsFreedInTheMap) {
  // The shipped flight-2 configuration over the white scenes: every cell whose
  // centre lies inside a white object is unknown or occupied, never free.
  for (const char* name : {"white-wall", "white-wall-beside", "white-tower", "white-van"}) {
    testing::TempDir dir;
    const std::string config = testing::write_test_scenario(name, dir / "seq", 5.0, 1);
    ASSERT_FALSE(config.empty()) << name;
    sim::Scenario scenario;
    std::string error;
    ASSERT_TRUE(sim::make_scenario(name, {640, 5.0, 1}, &scenario, &error));
    tools::ReplayRun run;
    ASSERT_TRUE(run.open(testing::quiet_replay(dir / "seq", config), &error)) << error;
    run.run();
    EXPECT_EQ(run.stats().heap_allocations_after_init, 0) << name;
    EXPECT_GT(run.stats().pixels_sky_refused, 0) << name;
    Mapper& mapper = run.mapper();
    std::int64_t inside = 0, freed = 0;
    mapper.zones().for_each_live_zone([&](ZoneView& zone) {
      for (int z = 0; z < zone.dims[2]; ++z)
        for (int y = 0; y < zone.dims[1]; ++y)
          for (int x = 0; x < zone.dims[0]; ++x) {
            const Eigen::Vector3d c =
                mapper.cell_center({zone.origin.x + x, zone.origin.y + y, zone.origin.z + z});
            for (const sim::Box& b : scenario.scene.boxes) {
              if (!b.white ||
                  !((c.array() > b.min.array()).all() && (c.array() < b.max.array()).all())) {
                continue;
              }
              ++inside;
              freed += zone.cells[zone.index(x, y, z)] < mapper.free_threshold() ? 1 : 0;
            }
          }
    });
    std::printf(
        "[ %s ] sky %lld px, refused %lld px; cells inside the white object %lld, free %lld\n",
        name, static_cast<long long>(run.stats().pixels_sky),
        static_cast<long long>(run.stats().pixels_sky_refused), static_cast<long long>(inside),
        static_cast<long long>(freed));
    EXPECT_EQ(freed, 0) << name;
  }
}

}  // namespace
}  // namespace zonemap
