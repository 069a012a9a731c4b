// zonemap-stereo ASL_DIR OUT_DIR: an ASL stereo recording (EuRoC MAV layout) as a
// replay sequence (docs/FORMATS.md §1), depth by semi-global matching, so a run can
// be repeated without OpenCV. Host only: on the vehicle the FPGA matches.
#include <cstdio>
#include <string>

#include "tools/stereo/asl_stereo.hpp"

namespace {
constexpr const char* kUsage =
    "usage: zonemap-stereo ASL_DIR OUT_DIR\n"
    "  ASL_DIR   a recording in the ASL layout: ASL_DIR/mav0/cam0, cam1 (data.csv, data/,\n"
    "            sensor.yaml) and state_groundtruth_estimate0/data.csv (body poses)\n"
    "  OUT_DIR   the replay sequence: depth/, left/ (rectified), depth.txt, left.txt,\n"
    "            camera.yaml (rectified camera, measured sigma), groundtruth.txt, stereo.json\n"
    "  --help    this text\n";
}  // namespace

int main(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    if (std::string(argv[i]) == "--help" || std::string(argv[i]) == "-h") {
      std::fputs(kUsage, stdout);
      return 0;
    }
  }
  if (argc != 3) {
    std::fputs(kUsage, stderr);
    return 2;
  }
  zonemap::stereo::StereoReport report;
  std::string error;
  if (!zonemap::stereo::convert_asl(argv[1], argv[2], {}, &report, &error)) {
    std::fprintf(stderr, "zonemap-stereo: %s\n", error.c_str());
    return 1;
  }
  std::printf(
      "%d pairs, %d depth frames written (%d cam0 without cam1, %d cam1 without cam0, %d "
      "unreadable); f %.1f px, b %.4f m; valid %.1f%% (block matcher %.1f%%), median |SGBM-BM| "
      "%.2f px; sigma %.3f px (left-right) / %.3f px (vs BM); %.1f ms per pair -> %s\n",
      report.pairs, report.written, report.cam0_without_cam1, report.cam1_without_cam0,
      report.unreadable, report.focal_px, report.baseline_m, 100 * report.valid_share_median,
      100 * report.reference_valid_share_median, report.reference_disagreement_px_median,
      report.sigma_px, report.sigma_px_from_reference, report.ms_per_pair_median, argv[2]);
  return 0;
}
