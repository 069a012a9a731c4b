// The Mapper (paper §III-A..D in one call per frame): bad poses rejected, the
// sky filter, d_max, the ground below the environment, any image width (no
// allocation after start-up: tests/test_core_allocations.cpp).
#include <gtest/gtest.h>

#include <vector>

#include "core_test_support.hpp"
#include "tools/sim/scene.hpp"
#include "zonemap/mapping/mapper.hpp"

namespace zonemap {
namespace {

using testing::small_centred_config;

TEST(Mapper, RejectsNonFinitePoseAndLeavesTheMapAlone) {
  MapConfig config = small_centred_config();
  CameraModel camera;
  camera.width = 8;
  camera.height = 6;
  camera.fx = camera.fy = 8.0;
  camera.cx = 3.5;
  camera.cy = 2.5;
  camera.baseline_m = 0.3;
  camera.match_sigma_px = 0.25;
  Mapper mapper(config, camera);
  std::vector<std::uint16_t> depth(48, 3000);
  DepthFrameView view{depth.data(), nullptr, 8, 6};
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation().x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(mapper.integrate(view, pose).status, FrameStatus::kBadPose);
  Eigen::Isometry3d sheared = Eigen::Isometry3d::Identity();
  sheared.linear()(0, 1) = 0.5;
  EXPECT_EQ(mapper.integrate(view, sheared).status, FrameStatus::kBadPose);
  EXPECT_EQ(mapper.zones().live_zone_count(), 0);
  DepthFrameView wrong_size{depth.data(), nullptr, 6, 8};
  EXPECT_EQ(mapper.integrate(wrong_size, Eigen::Isometry3d::Identity()).status,
            FrameStatus::kBadFrame);
}

CameraModel tiny_camera() {
  CameraModel camera;
  camera.width = 16;
  camera.height = 12;
  camera.fx = camera.fy = 16.0;
  camera.cx = 7.5;
  camera.cy = 5.5;
  camera.baseline_m = 0.3;
  camera.match_sigma_px = 0.25;
  camera.depth_scale = 1000.0;
  return camera;
}

// Camera at the world origin looking along +x (optical z = world x).
Eigen::Isometry3d looking_along_x() {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  return pose;
}

TEST(Mapper, SaysWhenTheGroundItSeesLiesUnderTheEnvironment) {
  MapConfig config = small_centred_config();  // centred, 4 cells tall: the bottom face 2 m down
  config.d_max_m = 30.0;
  CameraModel camera = tiny_camera();
  camera.width = 64;
  camera.height = 48;
  camera.fx = camera.fy = 48.0;
  camera.cx = 31.5;
  camera.cy = 23.5;
  // Depth of a flat ground `drop` metres under a camera looking along +x.
  auto ground_frame = [&](double drop) {
    std::vector<std::uint16_t> depth(64 * 48, 0);
    for (int v = 24; v < 48; ++v)
      for (int u = 0; u < 64; ++u)
        depth[static_cast<std::size_t>(v * 64 + u)] =
            static_cast<std::uint16_t>(drop * camera.fy / (v - camera.cy) * 1000.0);
    return depth;
  };
  Mapper mapper(config, camera);
  const std::vector<std::uint16_t> near = ground_frame(1.5);
  const FrameReport inside = mapper.integrate({near.data(), nullptr, 64, 48}, looking_along_x());
  EXPECT_GT(inside.sampled_hits, 20);
  EXPECT_EQ(inside.sampled_hits_below_environment, 0);
  EXPECT_FALSE(ground_below_environment(inside));
  const std::vector<std::uint16_t> far = ground_frame(6.0);
  const FrameReport under = mapper.integrate({far.data(), nullptr, 64, 48}, looking_along_x());
  EXPECT_GT(under.sampled_hits, 10);
  EXPECT_EQ(under.sampled_hits_below_environment, under.sampled_hits);
  EXPECT_TRUE(ground_below_environment(under));
}

TEST(Mapper, SkyFilterTurnsBrightFlatMissingDepthIntoFreeSpace) {
  MapConfig config = small_centred_config();
  config.zone_cells = {20, 20, 20};
  config.blur_radius = 0;
  const CameraModel camera = tiny_camera();
  Mapper mapper(config, camera);
  std::vector<std::uint16_t> depth(16 * 12, 0);  // no depth anywhere
  std::vector<std::uint8_t> left(16 * 12);
  for (int v = 0; v < 12; ++v)
    for (int u = 0; u < 16; ++u) {
      // Upper half: bright and flat (sky). Lower half: bright but textured.
      left[static_cast<std::size_t>(v * 16 + u)] =
          static_cast<std::uint8_t>(v < 6 ? 235 : ((u + v) % 2 ? 250 : 205));
    }
  const FrameReport report =
      mapper.integrate({depth.data(), left.data(), 16, 12}, looking_along_x());
  EXPECT_EQ(report.status, FrameStatus::kMapped);
  // Rows 0-4 are flat in their whole 3x3 neighbourhood; row 5 touches the texture.
  EXPECT_EQ(report.pixels_sky, 5 * 16);
  EXPECT_EQ(report.rays_free, 5 * 16);
  EXPECT_EQ(report.rays_hit, 0);
  EXPECT_EQ(report.pixels_missing, 7 * 16);
  FusedCell v = 0;
  // Straight ahead and up: free beyond d_min (1 m) up to d_max (8 m).
  ASSERT_TRUE(mapper.zones().value_at(mapper.cell_of({5.0, 0.2, 1.5}), &v));
  EXPECT_LT(v, 0);
  ASSERT_TRUE(mapper.zones().value_at(mapper.cell_of({5.0, 0.2, -1.5}), &v));
  EXPECT_EQ(v, 0) << "missing depth below the horizon is ignored";
  // Without the left image, nothing is sky.
  Mapper blind(config, camera);
  EXPECT_EQ(blind.integrate({depth.data(), nullptr, 16, 12}, looking_along_x()).pixels_sky, 0);
}

TEST(Mapper, SkyFlagsMatchTheirDefinitionAtEveryPixel) {
  // Random bright images near the thresholds (intensity 200, gradient 8) with
  // missing depth here and there; widths with and without interior columns.
  // Sky candidates: missing depth, bright, every 8-neighbour (clamped at the
  // border) within the gradient.
  std::uint32_t state = 7;
  const auto next = [&] {
    state = state * 1664525u + 1013904223u;
    return state >> 8;
  };
  for (const int width : {16, 13, 3, 2, 1}) {
    const int height = 12;
    MapConfig config = small_centred_config();
    config.zone_cells = {20, 20, 20};
    config.integration = MapConfig::Integration::kProjective;
    CameraModel camera = tiny_camera();
    camera.width = width;
    camera.cx = 0.5 * (width - 1);
    Mapper mapper(config, camera);
    const std::size_t pixels = static_cast<std::size_t>(width) * height;
    std::vector<std::uint16_t> depth(pixels);
    std::vector<std::uint8_t> left(pixels);
    for (std::size_t i = 0; i < pixels; ++i) {
      depth[i] = next() % 3 == 0 ? 3000 : 0;
      left[i] = static_cast<std::uint8_t>(195 + next() % 12);  // 195..206
    }
    int expected = 0;
    for (int v = 0; v < height; ++v)
      for (int u = 0; u < width; ++u) {
        const int c = left[static_cast<std::size_t>(v * width + u)];
        bool sky = depth[static_cast<std::size_t>(v * width + u)] == 0 && c >= 200;
        for (int dv = -1; dv <= 1; ++dv)
          for (int du = -1; du <= 1; ++du) {
            const int nu = std::clamp(u + du, 0, width - 1), nv = std::clamp(v + dv, 0, height - 1);
            sky = sky && std::abs(left[static_cast<std::size_t>(nv * width + nu)] - c) <= 8;
          }
        expected += sky ? 1 : 0;
      }
    const FrameReport report =
        mapper.integrate({depth.data(), left.data(), width, height}, looking_along_x());
    // Candidates: taken for sky where SkyFilter's columns allow, refused elsewhere.
    EXPECT_EQ(report.pixels_sky + report.pixels_sky_refused, expected) << width;
  }
}

TEST(Mapper, PixelCountsForAnyImageWidth) {
  // Missing, too near, beyond d_max and real depths in a repeating pattern, for
  // widths that fill whole vector loads, leave a tail, or are narrower than one;
  // both integration paths count alike.
  for (const int width : {16, 13, 5}) {
    for (const auto integration :
         {MapConfig::Integration::kProjective, MapConfig::Integration::kReference}) {
      MapConfig config = small_centred_config();
      config.zone_cells = {20, 20, 20};
      config.integration = integration;
      CameraModel camera = tiny_camera();
      camera.width = width;
      camera.cx = 0.5 * (width - 1);
      Mapper mapper(config, camera);
      const std::uint16_t pattern[4] = {0, 500, 15000, 3000};  // missing, near, far, hit
      std::vector<std::uint16_t> depth(static_cast<std::size_t>(width) * 12);
      int expected[4] = {};
      for (std::size_t i = 0; i < depth.size(); ++i) {
        const std::size_t kind = (i * 7 + i / 3) % 4;
        depth[i] = pattern[kind];
        ++expected[kind];
      }
      const FrameReport report =
          mapper.integrate({depth.data(), nullptr, width, 12}, looking_along_x());
      EXPECT_EQ(report.pixels_missing, expected[0]) << width;
      EXPECT_EQ(report.pixels_too_near, expected[1]) << width;
      EXPECT_EQ(report.rays_free, expected[2]) << width;
      EXPECT_EQ(report.rays_hit, expected[3]) << width;
    }
  }
}

TEST(Mapper, DepthBeyondDmaxGivesFreeSpaceUpToDmaxOnly) {
  MapConfig config = small_centred_config();
  config.zone_cells = {40, 20, 20};
  config.blur_radius = 0;
  config.d_max_m = 8.0;
  Mapper mapper(config, tiny_camera());
  std::vector<std::uint16_t> depth(16 * 12, 15000);  // 15 m, beyond d_max
  const FrameReport report = mapper.integrate({depth.data(), nullptr, 16, 12}, looking_along_x());
  EXPECT_EQ(report.rays_free, 16 * 12);
  EXPECT_EQ(report.rays_hit, 0);
  FusedCell v = 0;
  ASSERT_TRUE(mapper.zones().value_at(mapper.cell_of({6.5, 0.1, 0.1}), &v));
  EXPECT_EQ(v, -kCellScale);
  ASSERT_TRUE(mapper.zones().value_at(mapper.cell_of({9.5, 0.1, 0.1}), &v));
  EXPECT_EQ(v, 0) << "nothing past d_max";
  ASSERT_TRUE(mapper.zones().value_at(mapper.cell_of({15.2, 0.1, 0.1}), &v));
  EXPECT_EQ(v, 0) << "no obstacle at the far depth";

  // Below d_min: ignored entirely.
  std::fill(depth.begin(), depth.end(), std::uint16_t{500});
  const FrameReport near = mapper.integrate({depth.data(), nullptr, 16, 12}, looking_along_x());
  EXPECT_EQ(near.pixels_too_near, 16 * 12);
  EXPECT_EQ(near.cells_visited, 0);
}

}  // namespace
}  // namespace zonemap
