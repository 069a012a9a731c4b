// The mapping step shared among worker threads (hal/os/worker_pool): every part
// runs once per job, and a map made with 2 or 3 parts is the one made with one,
// byte for byte, without allocating.
#include <gtest/gtest.h>
#include <sched.h>

#include <atomic>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "hal/config/yaml_config.hpp"
#include "hal/os/allocation_counter.hpp"
#include "hal/os/worker_pool.hpp"
#include "test_support.hpp"
#include "tools/sim/scene.hpp"
#include "zonemap/mapping/mapper.hpp"

namespace zonemap {
namespace {

TEST(WorkerPool, EveryPartRunsOnceInEveryJob) {
  os::WorkerPool pool(os::WorkerOptions{3, 0, {}});
  ASSERT_EQ(pool.parts(), 3);
  EXPECT_TRUE(pool.warnings().empty());
  struct Tally {
    std::atomic<int> runs[3] = {};
    std::atomic<int> wrong_parts{0};
  } tally;
  const WorkSplit::Job job = [](void* c, int part, int parts) {
    Tally& t = *static_cast<Tally*>(c);
    if (parts != 3 || part < 0 || part >= 3) {
      t.wrong_parts.fetch_add(1);
      return;
    }
    t.runs[part].fetch_add(1);
  };
  constexpr int kJobs = 2000;
  for (int j = 0; j < kJobs; ++j) {
    pool.run(job, &tally);
    // run() returns only when every part of this job has returned.
    ASSERT_EQ(tally.runs[1].load() + tally.runs[2].load(), 2 * (j + 1)) << "job " << j;
  }
  EXPECT_EQ(tally.wrong_parts.load(), 0);
  for (int p = 0; p < 3; ++p) EXPECT_EQ(tally.runs[p].load(), kJobs) << "part " << p;
}

TEST(WorkerPool, PinnedWorkersRunAndAnAbsentCpuIsAWarning) {
  // Worker 1 on a CPU this process may use; worker 2 asks for one this machine
  // lacks: refused, said, and it runs unpinned.
  cpu_set_t allowed;
  ASSERT_EQ(sched_getaffinity(0, sizeof allowed, &allowed), 0);
  int usable = 0;
  while (!CPU_ISSET(usable, &allowed)) ++usable;  // some CPU is set
  const int absent = static_cast<int>(std::thread::hardware_concurrency()) + 7;
  os::WorkerPool pool(os::WorkerOptions{3, 0, {usable, absent}});
  ASSERT_EQ(pool.warnings().size(), 1u);
  EXPECT_NE(pool.warnings()[0].find("CPU " + std::to_string(absent)), std::string::npos)
      << pool.warnings()[0];
  std::atomic<int> runs{0};
  const WorkSplit::Job job = [](void* c, int, int) {
    static_cast<std::atomic<int>*>(c)->fetch_add(1);
  };
  for (int j = 0; j < 100; ++j) pool.run(job, &runs);
  EXPECT_EQ(runs.load(), 300);
}

// The zones' cells of a mapper, concatenated in zone order.
std::vector<FusedCell> cells_of(Mapper& mapper) {
  std::vector<FusedCell> cells;
  mapper.zones().for_each_live_zone([&](ZoneView& zone) {
    const std::size_t n = static_cast<std::size_t>(zone.dims[0]) * zone.dims[1] * zone.dims[2];
    cells.insert(cells.end(), zone.cells, zone.cells + n);
  });
  return cells;
}

TEST(WorkerPool, MapWithTwoOrThreePartsIsTheOneMadeWithOne) {
  for (const char* name : {"treeline", "posts-around"}) {
    sim::Scenario scenario;
    std::string error;
    ASSERT_TRUE(sim::make_scenario(name, {640, 1.0}, &scenario, &error));
    MapConfig config;
    ASSERT_TRUE(hal::load_map_config(testing::source_path(scenario.config), &config, &error))
        << error;
    config.integration = MapConfig::Integration::kProjective;
    Mapper one(config, scenario.camera);
    Mapper two(config, scenario.camera);
    Mapper three(config, scenario.camera);
    os::WorkerPool pool2(os::WorkerOptions{2, 0, {}});
    os::WorkerPool pool3(os::WorkerOptions{3, 0, {}});
    two.set_work_split(&pool2);
    three.set_work_split(&pool3);
    std::vector<std::uint16_t> depth(640 * 480);
    std::vector<std::uint8_t> left(640 * 480);
    sim::Rng rng(5);
    const std::size_t step = std::max<std::size_t>(1, scenario.trajectory.size() / 4);
    int frames = 0;
    for (std::size_t k = 0; k < scenario.trajectory.size(); k += step, ++frames) {
      const auto& pose = scenario.trajectory[k].world_T_camera;
      sim::render(scenario.scene, scenario.camera, pose, sim::RenderOptions{}, rng, depth.data(),
                  left.data());
      const DepthFrameView frame{depth.data(), left.data(), 640, 480};
      const FrameReport a = one.integrate(frame, pose);
      os::AllocationScope scope;
      const FrameReport b = two.integrate(frame, pose);
      const FrameReport c = three.integrate(frame, pose);
      EXPECT_EQ(scope.counted().allocations, 0) << name << " frame " << k;
      ASSERT_EQ(a.status, FrameStatus::kMapped);
      EXPECT_EQ(b.cells_visited, a.cells_visited);
      EXPECT_EQ(c.cells_exact, a.cells_exact);
      EXPECT_EQ(c.rays_exact, a.rays_exact);
      for (const FrameReport* r : {&b, &c}) {  // the depths classified in bands of rows
        EXPECT_EQ(r->rays_hit, a.rays_hit);
        EXPECT_EQ(r->rays_free, a.rays_free);
        EXPECT_EQ(r->pixels_missing, a.pixels_missing);
        EXPECT_EQ(r->pixels_sky, a.pixels_sky);
        EXPECT_EQ(r->pixels_too_near, a.pixels_too_near);
      }
      ASSERT_EQ(std::memcmp(one.local_grid().data(), two.local_grid().data(),
                            one.local_grid().cell_count()),
                0)
          << name << " frame " << k << ": the local grid differs with two parts";
      ASSERT_EQ(std::memcmp(one.local_grid().data(), three.local_grid().data(),
                            one.local_grid().cell_count()),
                0)
          << name << " frame " << k << ": the local grid differs with three parts";
    }
    const std::vector<FusedCell> cells = cells_of(one);
    EXPECT_GT(std::count_if(cells.begin(), cells.end(), [](FusedCell v) { return v > 0; }), 100)
        << name;
    EXPECT_EQ(cells, cells_of(two)) << name;
    EXPECT_EQ(cells, cells_of(three)) << name;
    std::printf("[ workers ] %s: %d frames, %zu zone cells, identical with 1, 2 and 3 parts\n",
                name, frames, cells.size());
  }
}

}  // namespace
}  // namespace zonemap
