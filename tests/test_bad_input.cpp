// Bad input gets a clear error naming the file (and line), or for per-frame faults
// a counted rejection. Never a crash, never a frame mapped with a bad pose.
#include <gtest/gtest.h>

#include "hal/v4l2/v4l2_source.hpp"

#include <cmath>
#include <fstream>
#include <vector>

#include "hal/codec/png_io.hpp"
#include "hal/config/yaml_config.hpp"
#include "hal/replay/sequence.hpp"
#include "replay_support.hpp"
#include "test_support.hpp"
#include "tools/replay/replay_run.hpp"

namespace zonemap {
namespace {

using testing::TempDir;

using testing::read_text;
using testing::write_text;

TEST(BadPng, CorruptTruncatedWrongSizeAndWrongDepthAreRefusedWithTheFileName) {
  TempDir dir;
  std::vector<std::uint16_t> depth(16 * 12, 1000);
  std::vector<std::uint8_t> grey(16 * 12, 100);
  std::string error;
  ASSERT_TRUE(hal::write_png_gray16(dir / "good.png", 16, 12, depth.data(), &error)) << error;
  ASSERT_TRUE(hal::write_png_gray8(dir / "grey8.png", 16, 12, grey.data(), &error)) << error;
  std::vector<std::uint16_t> out(16 * 12);
  ASSERT_TRUE(hal::read_png_gray16(dir / "good.png", 16, 12, out.data(), &error)) << error;
  EXPECT_EQ(out, depth);

  // Truncated: the first half of a good file.
  const std::string good = read_text(dir / "good.png");
  write_text(dir / "truncated.png", good.substr(0, good.size() / 2));
  EXPECT_FALSE(hal::read_png_gray16(dir / "truncated.png", 16, 12, out.data(), &error));
  EXPECT_NE(error.find("truncated.png"), std::string::npos) << error;

  // Corrupt: a valid signature, then garbage.
  std::string corrupt = good.substr(0, 8) + std::string(200, '\x5a');
  write_text(dir / "corrupt.png", corrupt);
  EXPECT_FALSE(hal::read_png_gray16(dir / "corrupt.png", 16, 12, out.data(), &error));
  EXPECT_NE(error.find("corrupt.png"), std::string::npos) << error;

  // Not a PNG at all.
  write_text(dir / "text.png", "hello");
  EXPECT_FALSE(hal::read_png_gray16(dir / "text.png", 16, 12, out.data(), &error));
  EXPECT_NE(error.find("not a PNG"), std::string::npos) << error;

  // Wrong size.
  std::vector<std::uint16_t> big(20 * 12);
  EXPECT_FALSE(hal::read_png_gray16(dir / "good.png", 20, 12, big.data(), &error));
  EXPECT_NE(error.find("expected 20x12, found 16x12"), std::string::npos) << error;

  // 8-bit where 16-bit is expected.
  EXPECT_FALSE(hal::read_png_gray16(dir / "grey8.png", 16, 12, out.data(), &error));
  EXPECT_NE(error.find("expected 16-bit PNG, found 8-bit"), std::string::npos) << error;

  // Missing file.
  EXPECT_FALSE(hal::read_png_gray16(dir / "missing.png", 16, 12, out.data(), &error));
  EXPECT_NE(error.find("missing.png: cannot open"), std::string::npos) << error;
}

TEST(BadConfig, UnknownKeyNamesFileAndLine) {
  TempDir dir;
  write_text(dir / "c.yaml", "map:\n  cell_size_m: 1.0\n  zone_cels: [8, 8, 8]\n");
  MapConfig config;
  std::string error;
  EXPECT_FALSE(hal::load_map_config(dir / "c.yaml", &config, &error));
  EXPECT_NE(error.find("c.yaml:3: unknown key 'zone_cels' in 'map'"), std::string::npos) << error;
}

TEST(BadConfig, ADirectoryGivenAsAFileIsRefused) {
  // A directory opens as a stream on Linux; reading it must be an error, not a crash.
  TempDir dir;
  std::filesystem::create_directory(dir / "c.yaml");
  std::string error;
  MapConfig config;
  EXPECT_FALSE(hal::load_map_config(dir / "c.yaml", &config, &error));
  EXPECT_NE(error.find("c.yaml: a directory, not a file"), std::string::npos) << error;
  CameraModel camera;
  EXPECT_FALSE(hal::load_camera_yaml(dir / "c.yaml", &camera, &error));
  EXPECT_NE(error.find("c.yaml: a directory, not a file"), std::string::npos) << error;
  std::vector<std::uint16_t> out(16 * 12);
  std::filesystem::create_directory(dir / "d.png");
  EXPECT_FALSE(hal::read_png_gray16(dir / "d.png", 16, 12, out.data(), &error));
  EXPECT_NE(error.find("d.png"), std::string::npos) << error;
}

TEST(BadConfig, WrongTypeNamesFileAndLine) {
  TempDir dir;
  write_text(dir / "c.yaml", "sensor:\n  d_min_m: 8.0\n  d_max_m: far\n");
  MapConfig config;
  std::string error;
  EXPECT_FALSE(hal::load_map_config(dir / "c.yaml", &config, &error));
  EXPECT_NE(error.find("c.yaml:3: bad value for 'd_max_m'"), std::string::npos) << error;
}

TEST(BadConfig, OutOfRangeValuesAreRefused) {
  TempDir dir;
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"map: {cell_size_m: -1.0}\n", "cell_size_m"},
      {"map: {zone_cells: [4096, 4096, 4096]}\n", "zone_cells"},
      {"map: {zone_cells: [8, 8]}\n", "zone_cells"},
      {"sensor: {d_min_m: 10.0, d_max_m: 5.0}\n", "d_max_m"},
      {"fusion: {saturation: 100000}\n", "saturation"},
      {"blur: {radius: 7}\n", "radius"},
      {"blur: {keep_near_m: -1}\n", "keep_near_m"},
      {"map: {cell_size_m: 0.5}\nblur: {keep_near_m: 8.5}\n", "keep_near_m"},
      {"blur: {keep_near_m: .nan}\n", "keep_near_m"},
      {"sky_filter: {min_intensity: 300}\n", "min_intensity"},
      {"sky_filter: {horizon_margin_deg: -1}\n", "horizon_margin_deg"},
      {"sky_filter: {horizon_margin_deg: .nan}\n", "horizon_margin_deg"},
      {"sky_filter: {max_gap_px: 100}\n", "max_gap_px"},
      {"sky_filter: {min_region_share: 1.5}\n", "min_region_share"},
      {"pose: {max_gap_s: 0}\n", "max_gap_s"},
      {"ground: {band_percentile: 1.0}\n", "band_percentile"},
      {"ground: {band_percentile: 0.3, thickness_m: 3.0, max_thickness_m: 2.0}\n",
       "max_thickness_m"},
      {"sensor: {depth_filter_radius: 9}\n", "depth_filter_radius"},
      {"sensor: {depth_filter_radius: -1}\n", "depth_filter_radius"},
      {"sensor: {see_through: 1.5}\n", "see_through"},
      {"sensor: {see_through: -0.5}\n", "see_through"},
      {"sensor: {see_through: 0.5, see_through_behind: 0.7}\n", "see_through_behind"},
      {"sensor: {see_through: 0.5, see_through_behind: -0.2}\n", "see_through_behind"},
      {"features: {peak_fraction: 1.0}\n", "peak_fraction"},
      {"features: {peak_fraction: 0.5, peak_window_m: 100.0}\n", "peak_window_m"},
  };
  for (const auto& [text, word] : cases) {
    write_text(dir / "c.yaml", text);
    MapConfig config;
    std::string error;
    EXPECT_FALSE(hal::load_map_config(dir / "c.yaml", &config, &error)) << text;
    EXPECT_NE(error.find("c.yaml"), std::string::npos) << error;
    EXPECT_NE(error.find(word), std::string::npos) << text << " -> " << error;
  }
}

TEST(BadConfig, ShippedConfigsLoad) {
  for (const char* name : {"outdoor-0.5m.yaml", "paper-flight1.yaml", "paper-flight2.yaml",
                           "paper-flight3.yaml", "indoor-kinect.yaml", "tum-rgbd.yaml"}) {
    MapConfig config;
    std::string error;
    EXPECT_TRUE(
        hal::load_map_config(testing::source_path(std::string("config/") + name), &config, &error))
        << error;
  }
  MapConfig flight2;
  std::string error;
  ASSERT_TRUE(
      hal::load_map_config(testing::source_path("config/paper-flight2.yaml"), &flight2, &error));
  EXPECT_EQ(flight2.cell_size_m, 0.5);
  EXPECT_EQ(flight2.zone_cells, (std::array<int, 3>{160, 160, 80}));
  CameraModel tum;
  EXPECT_TRUE(
      hal::load_camera_yaml(testing::source_path("config/camera-tum-fr1.yaml"), &tum, &error))
      << error;
  EXPECT_EQ(tum.depth_scale, 5000.0);
}

TEST(BadConfig, TextLoadersAgreeWithTheFileLoaders) {
  // The fuzz targets go through the text entry points: they must be the same parser.
  const auto read = [](const std::string& path) {
    std::ifstream in(path);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  };
  const std::string flight2 = testing::source_path("config/paper-flight2.yaml");
  MapConfig from_file, from_text;
  std::string error;
  ASSERT_TRUE(hal::load_map_config(flight2, &from_file, &error)) << error;
  ASSERT_TRUE(hal::load_map_config_text(read(flight2), "flight2", &from_text, &error)) << error;
  EXPECT_EQ(from_file.zone_cells, from_text.zone_cells);
  EXPECT_EQ(from_file.cell_size_m, from_text.cell_size_m);
  EXPECT_EQ(from_file.features.capacity, from_text.features.capacity);
  EXPECT_FALSE(
      hal::load_map_config_text("map:\n  zone_cels: [8, 8, 8]\n", "x.yaml", &from_text, &error));
  EXPECT_NE(error.find("x.yaml:2: unknown key 'zone_cels'"), std::string::npos) << error;
  const std::string camera = testing::source_path("config/camera-tum-fr1.yaml");
  CameraModel a, b;
  ASSERT_TRUE(hal::load_camera_yaml(camera, &a, &error)) << error;
  ASSERT_TRUE(hal::load_camera_yaml_text(read(camera), "camera", &b, &error)) << error;
  EXPECT_EQ(a.fx, b.fx);
  EXPECT_EQ(a.depth_scale, b.depth_scale);
  EXPECT_FALSE(hal::load_camera_yaml_text("width: [", "cam.yaml", &b, &error));
  EXPECT_NE(error.find("cam.yaml:"), std::string::npos) << error;
}

TEST(BadCamera, MissingOrUnknownKeysAreRefused) {
  TempDir dir;
  CameraModel camera;
  std::string error;
  write_text(dir / "camera.yaml", "width: 64\nheight: 48\nfx: 60\n");
  EXPECT_FALSE(hal::load_camera_yaml(dir / "camera.yaml", &camera, &error));
  EXPECT_NE(error.find("required"), std::string::npos) << error;
  write_text(dir / "camera.yaml",
             "width: 64\nheight: 48\nfx: 60\nfy: 60\ncx: 31.5\ncy: 23.5\nbaseline: 0.3\n");
  EXPECT_FALSE(hal::load_camera_yaml(dir / "camera.yaml", &camera, &error));
  EXPECT_NE(error.find("camera.yaml:7: unknown key 'baseline'"), std::string::npos) << error;
  write_text(dir / "camera.yaml",
             "width: 64\nheight: 48\nfx: 60\nfy: 60\ncx: 31.5\ncy: 23.5\nbaseline_m: 0.3\n"
             "match_sigma_px: 0.25\nbody_T_camera: {t: [0, 0, 0], q: [0, 0, 0, 2]}\n");
  EXPECT_FALSE(hal::load_camera_yaml(dir / "camera.yaml", &camera, &error));
  EXPECT_NE(error.find("unit quaternion"), std::string::npos) << error;
}

TEST(BadTrajectory, NanNonUnitAndBackwardsPosesAreRejectedAndCounted) {
  TempDir dir;
  write_text(dir / "gt.txt",
             "# timestamp tx ty tz qx qy qz qw\n"
             "0.0 0 0 0 0 0 0 1\n"
             "0.1 nan 0 0 0 0 0 1\n"
             "0.2 0 0 0 0 0 0 1.5\n"
             "0.3 0 0 0 0 0 0 1\n"
             "0.25 0 0 0 0 0 0 1\n"
             "0.4 0 0 0 0.5 0.5 0.5 0.5\n");
  PoseTrack track(0.5, 0.02);
  int rejected = 0;
  std::vector<std::string> warnings;
  std::string error;
  ASSERT_TRUE(replay::load_trajectory(dir / "gt.txt", &track, &rejected, &warnings, &error))
      << error;
  EXPECT_EQ(track.size(), 3u);
  EXPECT_EQ(rejected, 3);
  ASSERT_EQ(warnings.size(), 3u);
  EXPECT_NE(warnings[0].find("gt.txt:3: pose rejected: non-finite"), std::string::npos)
      << warnings[0];
  EXPECT_NE(warnings[1].find("gt.txt:4: pose rejected: quaternion"), std::string::npos)
      << warnings[1];
  EXPECT_NE(warnings[2].find("gt.txt:6: pose rejected: timestamp"), std::string::npos)
      << warnings[2];

  write_text(dir / "bad.txt", "0.0 0 0 0 0 0 1\n");  // seven fields
  EXPECT_FALSE(replay::load_trajectory(dir / "bad.txt", &track, &rejected, &warnings, &error));
  EXPECT_NE(error.find("bad.txt:1:"), std::string::npos) << error;
  write_text(dir / "bad.txt", "0.0 0 0 zero 0 0 0 1\n");
  EXPECT_FALSE(replay::load_trajectory(dir / "bad.txt", &track, &rejected, &warnings, &error));
  EXPECT_NE(error.find("'zero' is not a number"), std::string::npos) << error;
}

// A generated flight, then damaged: each kind of per-frame fault must be counted.
TEST(BadSequence, PerFrameFaultsAreCountedNotFatal) {
  TempDir dir;
  const std::string seq = dir / "seq";
  const std::string config = testing::write_test_scenario("posts-through", seq, 2.0, 8, 12);
  ASSERT_FALSE(config.empty());
  // Frame 2: corrupt. Frame 3: missing. Frame 4: 8-bit instead of 16-bit.
  write_text(seq + "/depth/000002.png", "\x89PNG\r\n\x1a\n garbage");
  std::filesystem::remove(seq + "/depth/000003.png");
  std::filesystem::copy_file(seq + "/left/000004.png", seq + "/depth/000004.png",
                             std::filesystem::copy_options::overwrite_existing);
  // Frame 5's left image is broken: the frame still maps, without the sky filter.
  write_text(seq + "/left/000005.png", "broken");
  // A frame listed with a time going backwards, and one far in the future (a lone
  // stamp: refused by the time watermark, the frames before it unaffected).
  std::string list = read_text(seq + "/depth.txt");
  list += "1.0 depth/000001.png\n";
  list += "99.0 depth/000001.png\n";
  write_text(seq + "/depth.txt", list);
  // A pose with NaN in the middle of the trajectory: counted, the rest still used.
  std::string poses = read_text(seq + "/groundtruth.txt");
  poses += "100.0 nan 0 0 0 0 0 1\n";
  write_text(seq + "/groundtruth.txt", poses);

  tools::ReplayRun run;
  tools::ReplayOptions options = testing::quiet_replay(seq, config);
  std::string error;
  ASSERT_TRUE(run.open(options, &error)) << error;
  run.run();
  const hal::RunStats& s = run.stats();
  EXPECT_EQ(s.frames_in, 14);
  EXPECT_EQ(s.frames_rejected_bad_image, 3);
  EXPECT_EQ(s.frames_rejected_time_order, 2);
  EXPECT_EQ(s.frames_rejected, 5);
  EXPECT_EQ(s.frames_skipped_no_pose, 0);
  EXPECT_EQ(s.frames_mapped, 9);
  EXPECT_EQ(s.left_images_rejected, 1);
  EXPECT_EQ(s.poses_rejected, 1);
  EXPECT_EQ(s.frames_in, s.frames_mapped + s.frames_rejected + s.frames_skipped_no_pose)
      << "every frame is accounted for";
  EXPECT_EQ(s.heap_allocations_after_init, 0);

  TempDir out;
  ASSERT_TRUE(run.write_outputs(out.path(), &error)) << error;
  const std::string json = read_text(out / "stats.json");
  EXPECT_NE(json.find("\"frames_rejected\": 5"), std::string::npos) << json;
  EXPECT_NE(json.find("\"frames_time_past\": 1, \"frames_time_repeated\": 0"), std::string::npos)
      << json;
  EXPECT_NE(json.find("\"frames_time_future\": 1"), std::string::npos) << json;
  EXPECT_NE(json.find("\"poses_not_finite\": 1"), std::string::npos) << json;
}

TEST(BadSequence, MissingFilesAreErrorsNamingTheFile) {
  TempDir dir;
  const std::string seq = dir / "seq";
  const std::string config = testing::write_test_scenario("posts-through", seq, 2.0, 8, 3);
  tools::ReplayRun run;
  tools::ReplayOptions options = testing::quiet_replay(seq, config);
  std::string error;

  std::filesystem::rename(seq + "/groundtruth.txt", seq + "/gt.bak");
  EXPECT_FALSE(run.open(options, &error));
  EXPECT_NE(error.find("groundtruth.txt"), std::string::npos) << error;
  std::filesystem::rename(seq + "/gt.bak", seq + "/groundtruth.txt");

  std::filesystem::rename(seq + "/depth.txt", seq + "/depth.bak");
  EXPECT_FALSE(run.open(options, &error));
  EXPECT_NE(error.find("depth.txt: cannot open"), std::string::npos) << error;
  std::filesystem::rename(seq + "/depth.bak", seq + "/depth.txt");

  write_text(seq + "/depth.txt", "0.0 depth/000000.png\nzero depth/000001.png\n");
  EXPECT_FALSE(run.open(options, &error));
  EXPECT_NE(error.find("depth.txt:2:"), std::string::npos) << error;

  std::filesystem::remove(seq + "/camera.yaml");
  EXPECT_FALSE(run.open(options, &error));
  EXPECT_NE(error.find("camera.yaml: cannot open"), std::string::npos) << error;

  options.sequence_dir = dir / "nowhere";
  EXPECT_FALSE(run.open(options, &error));
  EXPECT_NE(error.find("nowhere: not a directory"), std::string::npos) << error;
}

}  // namespace
}  // namespace zonemap

TEST(BadInput, V4l2BufferChecksRefuseWrongSizeAndFlaggedFramesAndCountGaps) {
  using zonemap::v4l2::check_buffer;
  const std::uint32_t size = 640 * 480 * 2;
  auto v = check_buffer(false, size, size, 10, true, 9);
  EXPECT_TRUE(v.usable);
  EXPECT_EQ(v.lost_before, 0);
  v = check_buffer(false, size - 2, size, 11, true, 10);
  EXPECT_FALSE(v.usable);
  EXPECT_NE(std::string(v.why).find("wrong size"), std::string::npos);
  v = check_buffer(true, size, size, 12, true, 11);
  EXPECT_FALSE(v.usable);
  v = check_buffer(false, size, size, 20, true, 12);  // 7 frames never delivered
  EXPECT_TRUE(v.usable);
  EXPECT_EQ(v.lost_before, 7);
  v = check_buffer(false, size, size, 2, true, 0xFFFFFFFEu);  // the counter wrapped
  EXPECT_EQ(v.lost_before, 3);
  v = check_buffer(false, size, size, 5, true, 9);  // restarted stream: no "lost" flood
  EXPECT_EQ(v.lost_before, 0);
}
