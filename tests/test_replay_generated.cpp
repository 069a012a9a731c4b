// End to end: a generated paper flight through the replay HAL and the mapper.
// The map must agree with the scene's ground truth.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>

#include "hal/codec/png_io.hpp"
#include "hal/config/yaml_config.hpp"
#include "hal/output/run_outputs.hpp"
#include "replay_support.hpp"
#include "test_support.hpp"
#include "tools/replay/replay_run.hpp"

namespace zonemap {
namespace {

using testing::TempDir;

// True when the axis-aligned box [lo, hi] meets the scene's solid (ground half-space,
// boxes, cylinders).
bool box_meets_solid(const sim::Scene& scene, const Eigen::Vector3d& lo,
                     const Eigen::Vector3d& hi) {
  if (scene.has_ground && lo.z() <= scene.ground_z) return true;
  for (const sim::Box& b : scene.boxes) {
    if ((lo.array() <= b.max.array()).all() && (hi.array() >= b.min.array()).all()) return true;
  }
  for (const sim::Cylinder& c : scene.cylinders) {
    if (hi.z() < c.z_min || lo.z() > c.z_max) continue;
    const double nx = std::clamp(c.center.x(), lo.x(), hi.x());
    const double ny = std::clamp(c.center.y(), lo.y(), hi.y());
    if (std::hypot(nx - c.center.x(), ny - c.center.y()) <= c.radius) return true;
  }
  return false;
}

// True when the point lies inside the solid by at least `margin`.
bool deep_inside_solid(const sim::Scene& scene, const Eigen::Vector3d& p, double margin) {
  if (scene.has_ground && p.z() < scene.ground_z - margin) return true;
  for (const sim::Box& b : scene.boxes) {
    if (((p.array() - b.min.array()) > margin).all() &&
        ((b.max.array() - p.array()) > margin).all())
      return true;
  }
  for (const sim::Cylinder& c : scene.cylinders) {
    if (p.z() > c.z_min + margin && p.z() < c.z_max - margin &&
        std::hypot(p.x() - c.center.x(), p.y() - c.center.y()) < c.radius - margin)
      return true;
  }
  return false;
}

struct MapCheck {
  std::int64_t occupied = 0;
  std::int64_t occupied_near_solid = 0;  // within one cell
  std::int64_t occupied_within_tolerance = 0;
  std::int64_t free = 0;
  std::int64_t free_inside_solid = 0;
};

MapCheck check_against_scene(Mapper& mapper, const sim::Scene& scene, double tolerance_m) {
  MapCheck check;
  const double s = mapper.config().cell_size_m;
  mapper.zones().for_each_live_zone([&](ZoneView& zone) {
    for (int z = 0; z < zone.dims[2]; ++z)
      for (int y = 0; y < zone.dims[1]; ++y)
        for (int x = 0; x < zone.dims[0]; ++x) {
          const FusedCell v = zone.cells[zone.index(x, y, z)];
          const Eigen::Vector3d c =
              mapper.cell_center({zone.origin.x + x, zone.origin.y + y, zone.origin.z + z});
          if (v > mapper.occupied_threshold()) {
            ++check.occupied;
            // "Within one cell": the cell grown by one cell on every side meets the solid.
            const Eigen::Vector3d half = Eigen::Vector3d::Constant(1.5 * s);
            if (box_meets_solid(scene, c - half, c + half)) ++check.occupied_near_solid;
            const Eigen::Vector3d grown = Eigen::Vector3d::Constant(0.5 * s + tolerance_m);
            if (box_meets_solid(scene, c - grown, c + grown)) ++check.occupied_within_tolerance;
          } else if (v < mapper.free_threshold()) {
            ++check.free;
            if (deep_inside_solid(scene, c, 0.5 * s)) ++check.free_inside_solid;
          }
        }
  });
  return check;
}

// At least 95% of the occupied cells must lie within `tolerance_m` (one cell for
// most flights) of the solid. Returns the run for scenario-specific checks.
std::unique_ptr<tools::ReplayRun> replay_and_check(const std::string& scenario_name, double rate,
                                                   double tolerance_m, bool expect_sky) {
  TempDir dir;
  const std::string sequence = dir / "seq";
  const std::string config = testing::write_test_scenario(scenario_name, sequence, rate, 4);
  EXPECT_FALSE(config.empty());
  sim::Scenario scenario;
  std::string error;
  EXPECT_TRUE(sim::make_scenario(scenario_name, {640, rate}, &scenario, &error));

  auto run_owner = std::make_unique<tools::ReplayRun>();
  tools::ReplayRun& run = *run_owner;
  tools::ReplayOptions options = testing::quiet_replay(sequence, config);
  if (!run.open(options, &error)) {
    ADD_FAILURE() << error;
    return run_owner;
  }
  run.run();
  const hal::RunStats& stats = run.stats();
  EXPECT_EQ(stats.frames_in, static_cast<std::int64_t>(scenario.trajectory.size()));
  EXPECT_EQ(stats.frames_mapped, stats.frames_in);
  EXPECT_EQ(stats.frames_rejected, 0);
  EXPECT_EQ(stats.heap_allocations_after_init, 0);
  if (expect_sky) {
    EXPECT_GT(stats.pixels_sky, 0) << "the sky filter found the sky";
  }

  const MapCheck check = check_against_scene(run.mapper(), scenario.scene, tolerance_m);
  const double occupied = static_cast<double>(check.occupied);
  const double near = static_cast<double>(check.occupied_near_solid) / occupied;
  const double within = static_cast<double>(check.occupied_within_tolerance) / occupied;
  std::printf(
      "[ %s ] occupied %lld: within one cell of an object or the ground %.2f%%, within "
      "%.2f m %.2f%%; free %lld, inside an object %lld\n",
      scenario_name.c_str(), static_cast<long long>(check.occupied), 100.0 * near, tolerance_m,
      100.0 * within, static_cast<long long>(check.free),
      static_cast<long long>(check.free_inside_solid));
  EXPECT_GT(check.occupied, 1000);
  EXPECT_GE(within, 0.95);
  EXPECT_GT(check.free, 1000);
  EXPECT_EQ(check.free_inside_solid, 0) << "free space contains no object";

  TempDir out;
  EXPECT_TRUE(run.write_outputs(out.path(), &error)) << error;
  for (const char* name : {"stats.json", "height.png", "occupied.ply"}) {
    EXPECT_GT(std::filesystem::file_size(out / name), 100u) << name;
  }
  std::ifstream ply(out / "occupied.ply");
  std::string first;
  std::getline(ply, first);
  EXPECT_EQ(first, "ply");
  return run_owner;
}

TEST(ReplayGenerated, PostsFlightMapsTheScene) {
  replay_and_check("posts-through", 5.0, 0.5, true);  // one 0.5 m cell
}

TEST(ReplayGenerated, BushesFlightMapsTheScene) {
  replay_and_check("bushes", 4.0, 1.0, true);  // one 1 m cell
}

TEST(ReplayGenerated, TreeLineFlightMapsTheTrees) {
  // Ground 25-50 m away, seen 20-40 degrees down: eq. (5)'s positive half (Δd up to
  // 3.1 m along the ray at d_max, six 0.5 m cells) lies partly above the ground, and
  // with every pixel a ray (max-write over ~70 rays per far cell) the ground comes
  // out 2-3 cells thick: 78% of the occupied cells are within one cell (printed),
  // 99.3% within three; the bound here is three cells.
  // 5 frames a second: at 2 the blur's free space had not yet reached the
  // inside of a trunk (57 cells at 10, 33 at 5, 0 at 2 before unknown cells kept it out).
  auto run = replay_and_check("treeline", 5.0, 1.5, false);
  sim::Scenario scenario;
  std::string error;
  ASSERT_TRUE(sim::make_scenario("treeline", {640, 5.0}, &scenario, &error));
  const double s = run->config().cell_size_m;
  for (const sim::Cylinder& tree : scenario.scene.cylinders) {
    // Each tree's column holds an occupied cell within 1.5 m of the tree top.
    std::int32_t top = 0;
    bool seen = false;
    double best = -100.0;
    for (double dx = -tree.radius; dx <= tree.radius; dx += s)
      for (double dy = -tree.radius; dy <= tree.radius; dy += s) {
        if (run->height_profile().top(
                static_cast<std::int32_t>(std::floor((tree.center.x() + dx) / s)),
                static_cast<std::int32_t>(std::floor((tree.center.y() + dy) / s)), &top)) {
          seen = true;
          best = std::max(best, (top + 0.5) * s);
        }
      }
    EXPECT_TRUE(seen) << tree.name;
    EXPECT_NEAR(best, tree.z_max, 1.5) << tree.name;
  }
}

TEST(ReplayGenerated, DenseTreeLineAndHedgeLeaveNoFreeSpaceInsideObjects) {
  // Trunks 0.5-3 m apart and bushes seen through gaps: free space on every side
  // of each, none of it inside (treeline-dense had 42 such cells, hedge 2).
  replay_and_check("treeline-dense", 5.0, 1.5, false);
  replay_and_check("hedge", 5.0, 1.5, false);
}

TEST(ReplayGenerated, HeightProfileShowsBothPostsWhereTheyAre) {
  TempDir dir;
  const std::string sequence = dir / "seq";
  const std::string config = testing::write_test_scenario("posts-around", sequence, 3.0, 4);
  tools::ReplayRun run;
  tools::ReplayOptions options = testing::quiet_replay(sequence, config);
  std::string error;
  ASSERT_TRUE(run.open(options, &error)) << error;
  run.run();
  // Each post's column holds an occupied cell at least 3 m above the ground,
  // and the columns 3 m away from the posts (on the line between them) do not.
  const double s = run.config().cell_size_m;
  auto top_height = [&](double x, double y) {
    std::int32_t top = 0;
    if (!run.height_profile().top(static_cast<std::int32_t>(std::floor(x / s)),
                                  static_cast<std::int32_t>(std::floor(y / s)), &top))
      return -100.0;
    return (top + 0.5) * s;
  };
  auto best_near = [&](double x, double y) {
    double best = -100.0;
    for (double dx = -s; dx <= s; dx += s)
      for (double dy = -s; dy <= s; dy += s) best = std::max(best, top_height(x + dx, y + dy));
    return best;
  };
  EXPECT_GE(best_near(40.0, -3.5), 3.0);
  EXPECT_GE(best_near(40.0, 3.5), 3.0);
  EXPECT_LT(top_height(40.0, 0.0), 1.0);
  EXPECT_LT(top_height(37.0, -3.5), 1.0);
  EXPECT_LT(top_height(43.0, 3.5), 1.0);
}

}  // namespace
}  // namespace zonemap

namespace zonemap {
namespace {

// A TUM RGB-D sequence replays unchanged: no camera.yaml in the directory (given
// with --camera), depth PNGs at 5000 per metre (set by the config), epoch
// timestamps, poses at another rate than the frames, and extra files around.
TEST(ReplayTumLayout, MapsLikeTheSameFlightInMillimetres) {
  testing::TempDir dir;
  const std::string mm = dir / "mm";
  const std::string config = testing::write_test_scenario("posts-through", mm, 5.0, 4, 40);
  ASSERT_FALSE(config.empty());

  // Build the TUM copy.
  const std::string tum = dir / "tum";
  std::filesystem::create_directories(tum + "/depth");
  const double epoch = 1305031102.0;
  replay::ReplaySequence source;
  MapConfig map_config;
  std::string error;
  ASSERT_TRUE(hal::load_map_config(config, &map_config, &error)) << error;
  ASSERT_TRUE(source.open(mm, "", map_config, &error)) << error;
  const CameraModel camera = source.camera();
  std::ofstream list(tum + "/depth.txt");
  list << "# depth maps\n# file: 'rgbd_dataset_zonemap_posts.bag'\n# timestamp filename\n";
  hal::CameraFrame frame = source.make_frame();
  for (std::size_t i = 0; i < source.frame_count(); ++i) {
    ASSERT_TRUE(source.read(i, &frame, &error)) << error;
    // 16-bit PNG at 5000 per metre ends at 13.1 m: drop farther depths from both copies.
    for (auto& v : frame.depth) v = v > 13107 ? 0 : v;
    ASSERT_TRUE(hal::write_png_gray16(source.entry(i).path, camera.width, camera.height,
                                      frame.depth.data(), &error));
    for (auto& v : frame.depth) v = static_cast<std::uint16_t>(v * 5);
    char name[64];
    std::snprintf(name, sizeof(name), "depth/%.6f.png", epoch + frame.time_s);
    ASSERT_TRUE(hal::write_png_gray16(tum + "/" + name, camera.width, camera.height,
                                      frame.depth.data(), &error));
    char line[128];
    std::snprintf(line, sizeof(line), "%.6f %s\n", epoch + frame.time_s, name);
    list << line;
  }
  list.close();
  // Poses at 4x the frame rate, offset by 7 ms: every frame needs interpolation.
  std::ofstream gt(tum + "/groundtruth.txt");
  gt << "# ground truth trajectory\n# timestamp tx ty tz qx qy qz qw\n";
  const auto& samples = source.poses().samples();
  for (std::size_t i = 0; i < samples.size(); ++i) {
    for (int k = 0; k < 4; ++k) {
      // The last pose comes 3 ms before the last frame (within tolerance).
      const double t =
          i + 1 < samples.size() ? samples[i].time_s + 0.007 + k * 0.05 : samples[i].time_s - 0.003;
      if (i + 1 == samples.size() && k > 0) break;
      Eigen::Isometry3d pose;
      ASSERT_NE(source.poses().lookup(t, &pose), PoseLookup::kNoPose);
      const Eigen::Quaterniond q(pose.linear());
      char line[200];
      std::snprintf(line, sizeof(line), "%.4f %.6f %.6f %.6f %.9f %.9f %.9f %.9f\n", epoch + t,
                    pose.translation().x(), pose.translation().y(), pose.translation().z(), q.x(),
                    q.y(), q.z(), q.w());
      gt << line;
    }
  }
  gt.close();
  std::ofstream(tum + "/rgb.txt") << "# color images\n";
  std::ofstream(tum + "/accelerometer.txt") << "# accelerometer data\n";
  // The camera file lives elsewhere, at millimetre scale: the config says 5000.
  std::filesystem::copy_file(mm + "/camera.yaml", dir / "camera-elsewhere.yaml");
  std::string tum_config = config + ".tum.yaml";
  std::ifstream in(config);
  std::stringstream text;
  text << in.rdbuf();
  std::ofstream(tum_config) << text.str() << "camera:\n  depth_scale: 5000.0\n";

  auto map = [&](const std::string& seq, const std::string& camera_path, const std::string& cfg,
                 tools::ReplayRun* run) {
    tools::ReplayOptions options;
    options.sequence_dir = seq;
    options.camera_path = camera_path;
    options.config_path = cfg;
    options.quiet = true;
    ASSERT_TRUE(run->open(options, &error)) << error;
    run->run();
  };
  tools::ReplayRun reference;
  tools::ReplayRun replayed;
  map(mm, "", config, &reference);
  map(tum, dir / "camera-elsewhere.yaml", tum_config, &replayed);
  ASSERT_EQ(replayed.stats().frames_mapped, reference.stats().frames_mapped);
  EXPECT_EQ(replayed.stats().frames_skipped_no_pose, 0);
  EXPECT_EQ(replayed.stats().frames_rejected, 0);

  // Same cells occupied (poses differ only by interpolation rounding).
  std::int64_t both = 0, only_one = 0;
  reference.mapper().zones().for_each_live_zone([&](ZoneView& zone) {
    for (std::size_t i = 0;
         i < static_cast<std::size_t>(zone.dims[0]) * zone.dims[1] * zone.dims[2]; ++i) {
      const int x = static_cast<int>(i % zone.dims[0]);
      const int y = static_cast<int>((i / zone.dims[0]) % zone.dims[1]);
      const int z = static_cast<int>(i / (static_cast<std::size_t>(zone.dims[0]) * zone.dims[1]));
      const bool a = zone.cells[i] > reference.mapper().occupied_threshold();
      FusedCell other = 0;
      const bool held = replayed.mapper().zones().value_at(
          {zone.origin.x + x, zone.origin.y + y, zone.origin.z + z}, &other);
      const bool b = held && other > replayed.mapper().occupied_threshold();
      if (a && b) ++both;
      if (a != b) ++only_one;
    }
  });
  EXPECT_GT(both, 1000);
  EXPECT_LT(static_cast<double>(only_one), 0.02 * static_cast<double>(both));
}

}  // namespace
}  // namespace zonemap

namespace zonemap {
namespace {

TEST(Simulator, SightingsGiveTheHighestPointSeen) {
  // A tree 17 m tall 30 m ahead of a camera at 15 m: pitched down by half the
  // vertical field of view (20 deg) it never sees above its own height; level, it
  // sees the top.
  sim::Scene scene;
  scene.cylinders.push_back({"tree", {30.0, 0.0}, 2.0, 0.0, 17.0});
  const CameraModel camera = sim::paper_camera(320);
  const std::size_t pixels = static_cast<std::size_t>(camera.width) * camera.height;
  std::vector<std::uint16_t> depth(pixels);
  std::vector<std::uint8_t> left(pixels);
  const double half_fov = std::atan2(camera.height / 2.0, camera.fy);
  sim::Rng rng(3);
  sim::ObjectSightings down(1), level(1);
  sim::render(scene, camera, sim::look_pose({0, 0, 15}, 0.0, half_fov), sim::RenderOptions{}, rng,
              depth.data(), left.data(), &down);
  sim::render(scene, camera, sim::look_pose({0, 0, 15}, 0.0, 0.0), sim::RenderOptions{}, rng,
              depth.data(), left.data(), &level);
  EXPECT_GT(down.pixel_hits[0], 1000);
  EXPECT_LE(down.top_z[0], 15.05);
  EXPECT_GT(down.top_z[0], 14.0);
  EXPECT_GT(level.top_z[0], 16.8);
  EXPECT_LE(level.top_z[0], 17.0);
}

TEST(Simulator, GenerationIsDeterministicForASeed) {
  sim::Scenario scenario;
  std::string error;
  ASSERT_TRUE(sim::make_scenario("posts-around", {160, 2.0}, &scenario, &error));
  const std::size_t pixels = 160 * 120;
  std::vector<std::uint16_t> depth_a(pixels), depth_b(pixels), depth_c(pixels);
  std::vector<std::uint8_t> left_a(pixels), left_b(pixels), left_c(pixels);
  const auto& pose = scenario.trajectory[3].world_T_camera;
  sim::RenderOptions options;
  sim::Rng rng_a(options.seed), rng_b(options.seed), rng_c(options.seed + 1);
  sim::render(scenario.scene, scenario.camera, pose, options, rng_a, depth_a.data(), left_a.data());
  sim::render(scenario.scene, scenario.camera, pose, options, rng_b, depth_b.data(), left_b.data());
  sim::render(scenario.scene, scenario.camera, pose, options, rng_c, depth_c.data(), left_c.data());
  EXPECT_EQ(depth_a, depth_b);
  EXPECT_EQ(left_a, left_b);
  EXPECT_NE(depth_a, depth_c) << "another seed gives other noise";
  // Noise follows eq. (1): about Δd(d) with the simulated sigma, never a wild value.
  std::size_t measured = 0;
  for (std::size_t i = 0; i < pixels; ++i) measured += depth_a[i] != 0;
  EXPECT_GT(measured, pixels / 3);
}

}  // namespace
}  // namespace zonemap
