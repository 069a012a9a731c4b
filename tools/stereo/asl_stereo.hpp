// Stereo recordings in the ASL layout (EuRoC MAV and everything recorded like it:
// DIR/mav0/cam0, cam1, state_groundtruth_estimate0; docs/FORMATS.md §1b) turned
// into a replay sequence (§1) on the host: the pair rectified from both cameras'
// calibration, depth by semi-global matching (OpenCV), the rectified left image
// for the sky filter, camera poses from the body ground truth and cam0's T_BS.
// On the vehicle the FPGA does this; only host tools link OpenCV.
#pragma once

#include <cstdint>
#include <string>

namespace zonemap::stereo {

struct StereoOptions {
  int num_disparities = 64;  // 0..63 px: down to f*b/63 (0.77 m for EuRoC's 11 cm)
  int block_size = 5;
  double depth_scale = 1000.0;  // PNG value per metre
  double min_depth_m = 0.5;
  double max_depth_m = 20.0;
  // The range from the rectified camera and the mapping config instead of the
  // fixed one above: disparities down to d_min (f b / d_min, in steps of 16, at
  // most 256), depth written out to where eq. 1's range error is 10% of the range
  // at kNominalSigmaPx (z = 0.1 f b / sigma), and at least to d_max.
  bool range_from_camera = false;
  double config_d_min_m = 0.5, config_d_max_m = 50.0;
  static constexpr double kNominalSigmaPx = 0.25;
  int reference_every = 10;  // every n-th pair also through the block matcher and right-to-left
};

// What the conversion did and measured, also written to OUT/stereo.json.
struct StereoReport {
  int pairs = 0;    // cam0 frames with a cam1 frame of the same time
  int written = 0;  // depth frames written
  int cam0_without_cam1 = 0, cam1_without_cam0 = 0;
  int unreadable = 0;  // a PNG that could not be read or has the wrong size
  int poses = 0, poses_rejected = 0;
  double focal_px = 0.0, baseline_m = 0.0;        // of the rectified pair (eq. 1's f and b)
  int num_disparities = 0;                        // the matcher's, as used
  double min_depth_m = 0.0, max_depth_m = 0.0;    // the depth written, as used
  double valid_share_median = 0.0;                // SGBM pixels with a depth, per frame
  double reference_valid_share_median = 0.0;      // OpenCV's block matcher, same pairs
  double reference_disagreement_px_median = 0.0;  // |SGBM - BM| where both have one
  double sigma_px = 0.0;                 // matching precision from left-right consistency (MAD)
  double sigma_px_from_reference = 0.0;  // from the disagreement with the block matcher
  double ms_per_pair_median = 0.0;       // rectify + match + depth, one pair
};

// The options `o` leave for a rectified pair of focal length f (px) and baseline b.
StereoOptions range_for(const StereoOptions& o, double f_px, double baseline_m);

// DIR holds an ASL recording (DIR/mav0/cam0/data.csv).
bool is_asl_recording(const std::string& dir);

// Writes OUT as a §1 sequence (depth/, left/, depth.txt, left.txt, camera.yaml,
// groundtruth.txt with camera poses, stereo.json). False with a message naming
// the file when the recording cannot give a correct depth (a camera missing, a
// calibration that does not rectify to a horizontal pair, no pose).
bool convert_asl(const std::string& asl_dir, const std::string& out_dir,
                 const StereoOptions& options, StereoReport* report, std::string* error);

}  // namespace zonemap::stereo
