// ASL stereo recordings with one thing wrong (built from the first pairs of the
// EuRoC excerpt in ../shared/data): a clear error, or a counted rejection that
// costs only the bad pair; never a silently wrong depth.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "test_support.hpp"
#include "tools/stereo/asl_stereo.hpp"

namespace zonemap {
namespace {

namespace fs = std::filesystem;
const std::string kAsl = std::string(ZONEMAP_SHARED_DATA_DIR) + "/euroc-mh01-0000-0099";
constexpr int kPairs = 8;

// The first kPairs pairs of the excerpt, with its calibration and ground truth.
std::string small_recording(const std::string& dir) {
  for (const char* cam : {"cam0", "cam1"}) {
    const fs::path from = fs::path(kAsl) / "mav0" / cam;
    const fs::path to = fs::path(dir) / "mav0" / cam;
    fs::create_directories(to / "data");
    fs::copy_file(from / "sensor.yaml", to / "sensor.yaml");
    std::ifstream in(from / "data.csv");
    std::ofstream out(to / "data.csv");
    std::string line;
    int n = 0;
    while (n < kPairs && std::getline(in, line)) {
      out << line << "\n";
      if (line[0] == '#') continue;
      const std::string file = line.substr(line.find(',') + 1);
      fs::copy_file(from / "data" / file, to / "data" / file);
      ++n;
    }
  }
  fs::create_directories(fs::path(dir) / "mav0" / "state_groundtruth_estimate0");
  fs::copy_file(fs::path(kAsl) / "mav0/state_groundtruth_estimate0/data.csv",
                fs::path(dir) / "mav0/state_groundtruth_estimate0/data.csv");
  return dir;
}

class AslStereo : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(kAsl + "/mav0/cam0/data.csv"))
      GTEST_SKIP() << "real test data absent: " << kAsl;
    asl_ = small_recording(dir_ / "asl");
  }
  bool convert(std::string* error) {
    return stereo::convert_asl(asl_, dir_ / "seq", {}, &report_, error);
  }
  testing::TempDir dir_;
  std::string asl_;
  stereo::StereoReport report_;
};

TEST_F(AslStereo, AGoodRecordingGivesEveryPair) {
  std::string error;
  ASSERT_TRUE(convert(&error)) << error;
  EXPECT_EQ(report_.written, kPairs);
  EXPECT_NEAR(report_.baseline_m, 0.110, 0.002);
  EXPECT_GT(report_.valid_share_median, 0.3);
}

TEST_F(AslStereo, AMissingCameraIsAClearError) {
  fs::remove_all(fs::path(asl_) / "mav0" / "cam1");
  std::string error;
  EXPECT_FALSE(convert(&error));
  EXPECT_NE(error.find("cam1"), std::string::npos) << error;
}

TEST_F(AslStereo, MismatchedTimestampsCostOnlyTheirPair) {
  // cam1's third frame stamped 1 ms late: no cam1 image at cam0's time.
  const std::string csv = asl_ + "/mav0/cam1/data.csv";
  std::string text = testing::read_text(csv);
  const std::size_t line = text.find('\n', text.find('\n', text.find('\n') + 1) + 1) + 1;
  const std::size_t digit = text.find(',', line) - 7;  // the millisecond digit
  text[digit] = text[digit] == '9' ? '0' : static_cast<char>(text[digit] + 1);
  testing::write_text(csv, text);
  std::string error;
  ASSERT_TRUE(convert(&error)) << error;
  EXPECT_EQ(report_.cam0_without_cam1, 1);
  EXPECT_EQ(report_.cam1_without_cam0, 1);
  EXPECT_EQ(report_.written, kPairs - 1);
}

TEST_F(AslStereo, AnUnreadableImageCostsOnlyItsPair) {
  const fs::path data = fs::path(asl_) / "mav0" / "cam1" / "data";
  const fs::path victim = *fs::directory_iterator(data);
  testing::write_text(victim.string(), "not a png");
  std::string error;
  ASSERT_TRUE(convert(&error)) << error;
  EXPECT_EQ(report_.unreadable, 1);
  EXPECT_EQ(report_.written, kPairs - 1);
}

TEST_F(AslStereo, ACalibrationThatDoesNotRectifyIsRefused) {
  // The cameras' extrinsics swapped: cam1 would be left of cam0.
  const std::string y0 = asl_ + "/mav0/cam0/sensor.yaml", y1 = asl_ + "/mav0/cam1/sensor.yaml";
  const std::string t0 = testing::read_text(y0), t1 = testing::read_text(y1);
  auto with_extrinsics_of = [](std::string target, const std::string& source) {
    const std::size_t a = target.find("T_BS:"), b = target.find("rate_hz");
    const std::size_t c = source.find("T_BS:"), d = source.find("rate_hz");
    return target.replace(a, b - a, source.substr(c, d - c));
  };
  testing::write_text(y0, with_extrinsics_of(t0, t1));
  testing::write_text(y1, with_extrinsics_of(t1, t0));
  std::string error;
  EXPECT_FALSE(convert(&error));
  EXPECT_NE(error.find("horizontal pair"), std::string::npos) << error;
}

}  // namespace
}  // namespace zonemap

namespace zonemap {
namespace {

// The matcher's range from the rectified camera and the mapping config: KITTI's
// 0.54 m baseline reaches far past a fixed 20 m, and a 64-disparity search would
// stop it at 6 m whatever d_min says.
TEST(StereoRange, DisparitiesFromBaselineFocalAndDMinDepthOutToWhereTheMatcherReaches) {
  stereo::StereoOptions o;
  EXPECT_EQ(stereo::range_for(o, 721.5, 0.54).num_disparities, 64);  // off: as given
  o.range_from_camera = true;
  o.config_d_min_m = 8.0;
  o.config_d_max_m = 50.0;
  const double fb = 721.5 * 0.54;  // KITTI
  stereo::StereoOptions r = stereo::range_for(o, 721.5, 0.54);
  EXPECT_EQ(r.num_disparities, 64);  // f b / 8 m = 48.7 px
  EXPECT_NEAR(r.min_depth_m, fb / 63, 1e-9);
  EXPECT_NEAR(r.max_depth_m, 0.1 * fb / 0.25, 1e-9);  // 156 m: eq. 1's error 10% there
  o.config_d_min_m = 2.0;
  r = stereo::range_for(o, 721.5, 0.54);
  EXPECT_EQ(r.num_disparities, 208);  // 194.8 px, in steps of 16
  EXPECT_LT(r.min_depth_m, 2.0);
  o.config_d_min_m = 0.5;
  EXPECT_EQ(stereo::range_for(o, 721.5, 0.54).num_disparities, 256);  // at most
  // EuRoC's 11 cm at d_min 0.8 m: the 64 it always had; d_max is reached even
  // where the 10% rule would stop short of it.
  o.config_d_min_m = 0.8;
  o.config_d_max_m = 30.0;
  r = stereo::range_for(o, 435.0, 0.11);
  EXPECT_EQ(r.num_disparities, 64);
  EXPECT_NEAR(r.max_depth_m, 30.0, 1e-9);
}

}  // namespace
}  // namespace zonemap
