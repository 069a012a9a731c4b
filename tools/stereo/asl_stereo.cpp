#include "tools/stereo/asl_stereo.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace zonemap::stereo {
namespace {

namespace fs = std::filesystem;

struct AslCamera {
  std::string dir;
  int width = 0, height = 0;
  cv::Matx33d K = cv::Matx33d::eye();
  cv::Vec4d D;
  Eigen::Isometry3d body_T_sensor = Eigen::Isometry3d::Identity();
  std::map<std::int64_t, std::string> frames;  // time (ns) -> image path
};

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

bool load_sensor_yaml(const std::string& path, AslCamera* cam, std::string* error) {
  try {
    const YAML::Node y = YAML::LoadFile(path);
    const auto intr = y["intrinsics"].as<std::vector<double>>();
    const auto dist = y["distortion_coefficients"].as<std::vector<double>>();
    const auto res = y["resolution"].as<std::vector<int>>();
    const auto t = y["T_BS"]["data"].as<std::vector<double>>();
    const std::string model = y["distortion_model"].as<std::string>("radial-tangential");
    if (intr.size() != 4 || dist.size() != 4 || res.size() != 2 || t.size() != 16) {
      *error = path +
               ": needs intrinsics [fu fv cu cv], 4 distortion_coefficients, "
               "resolution [w h] and a 4x4 T_BS";
      return false;
    }
    if (model != "radial-tangential") {
      *error = path + ": distortion_model " + model + " (only radial-tangential is read)";
      return false;
    }
    cam->K = cv::Matx33d(intr[0], 0, intr[2], 0, intr[1], intr[3], 0, 0, 1);
    cam->D = cv::Vec4d(dist[0], dist[1], dist[2], dist[3]);
    cam->width = res[0];
    cam->height = res[1];
    Eigen::Matrix4d m;
    for (int i = 0; i < 16; ++i) m(i / 4, i % 4) = t[static_cast<std::size_t>(i)];
    cam->body_T_sensor.matrix() = m;
    const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
    if (!((r * r.transpose() - Eigen::Matrix3d::Identity()).norm() < 1e-3) ||
        std::abs(r.determinant() - 1.0) > 1e-3) {
      *error = path + ": T_BS is not a rigid transform";
      return false;
    }
  } catch (const YAML::Exception& e) {
    *error = path + ": " + e.what();
    return false;
  }
  return true;
}

// data.csv: "#timestamp [ns],filename" then "ns,file" lines.
bool load_frame_list(const std::string& csv, const std::string& data_dir, AslCamera* cam,
                     std::string* error) {
  std::ifstream in(csv);
  if (!in) {
    *error = csv + ": cannot open (is the camera missing?)";
    return false;
  }
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    const std::size_t comma = line.find(',');
    char* end = nullptr;
    const long long ns = std::strtoll(line.c_str(), &end, 10);
    if (comma == std::string::npos || end != line.c_str() + comma || ns <= 0) {
      *error = csv + ":" + std::to_string(number) + ": expected 'timestamp_ns,filename'";
      return false;
    }
    std::string file = line.substr(comma + 1);
    file.erase(0, file.find_first_not_of(" \t"));
    cam->frames[ns] = data_dir + "/" + file;
  }
  if (cam->frames.empty()) {
    *error = csv + ": no frames";
    return false;
  }
  return true;
}

bool load_camera(const std::string& dir, AslCamera* cam, std::string* error) {
  cam->dir = dir;
  return load_sensor_yaml(dir + "/sensor.yaml", cam, error) &&
         load_frame_list(dir + "/data.csv", dir + "/data", cam, error);
}

// The rectified pair: maps for both cameras, f and b of eq. (1), and the rotation
// from cam0's frame to the rectified left frame.
struct Rectification {
  cv::Mat map0x, map0y, map1x, map1y;
  double f = 0, cx = 0, cy = 0, baseline_m = 0;
  Eigen::Matrix3d rect_R_cam0 = Eigen::Matrix3d::Identity();
};

bool rectify(const AslCamera& c0, const AslCamera& c1, Rectification* r, std::string* error) {
  if (c0.width != c1.width || c0.height != c1.height) {
    *error = "cam0 and cam1 have different resolutions";
    return false;
  }
  // cam1 <- cam0: the pose OpenCV's stereoRectify wants (R, T of the second camera).
  const Eigen::Isometry3d cam1_T_cam0 = c1.body_T_sensor.inverse() * c0.body_T_sensor;
  cv::Matx33d R;
  cv::Vec3d T;
  for (int i = 0; i < 3; ++i) {
    T[i] = cam1_T_cam0.translation()[i];
    for (int j = 0; j < 3; ++j) R(i, j) = cam1_T_cam0.linear()(i, j);
  }
  const cv::Size size(c0.width, c0.height);
  cv::Mat R1, R2, P1, P2, Q;
  cv::stereoRectify(c0.K, c0.D, c1.K, c1.D, size, R, T, R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY,
                    0.0, size);
  r->f = P1.at<double>(0, 0);
  r->cx = P1.at<double>(0, 2);
  r->cy = P1.at<double>(1, 2);
  // A horizontal pair has P2 = [f 0 cx -f*b; 0 f cy 0; ...] with cam1 to the right.
  const double tx = P2.at<double>(0, 3), ty = P2.at<double>(1, 3);
  if (!(r->f > 0) || std::abs(ty) > 1e-6 * std::abs(tx) + 1e-9 || !(tx < 0)) {
    *error =
        "cam0/cam1 calibration does not rectify to a horizontal pair with cam1 on the right "
        "(T_BS swapped or a vertical pair?)";
    return false;
  }
  r->baseline_m = -tx / r->f;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r->rect_R_cam0(i, j) = R1.at<double>(i, j);
  cv::initUndistortRectifyMap(c0.K, c0.D, R1, P1, size, CV_32FC1, r->map0x, r->map0y);
  cv::initUndistortRectifyMap(c1.K, c1.D, R2, P2, size, CV_32FC1, r->map1x, r->map1y);
  return true;
}

cv::Ptr<cv::StereoSGBM> make_sgbm(const StereoOptions& o) {
  const int b = o.block_size;
  return cv::StereoSGBM::create(0, o.num_disparities, b, 8 * b * b, 32 * b * b, 1, 63, 10, 100, 2,
                                cv::StereoSGBM::MODE_SGBM_3WAY);
}

// Disparity (CV_16S, 1/16 px) to z-depth PNG values; outside [min, max] or no
// match: 0 (missing). Returns the share of pixels with a depth.
double depth_from_disparity(const cv::Mat& disparity16, const Rectification& r,
                            const StereoOptions& o, cv::Mat* depth) {
  *depth = cv::Mat::zeros(disparity16.size(), CV_16UC1);
  const double fb16 = r.f * r.baseline_m * 16.0;
  std::size_t valid = 0;
  for (int y = 0; y < disparity16.rows; ++y) {
    const auto* d = disparity16.ptr<std::int16_t>(y);
    auto* out = depth->ptr<std::uint16_t>(y);
    for (int x = 0; x < disparity16.cols; ++x) {
      if (d[x] <= 0) continue;
      const double z = fb16 / d[x];
      if (z < o.min_depth_m || z > o.max_depth_m) continue;
      out[x] = static_cast<std::uint16_t>(std::min(65535.0, std::round(z * o.depth_scale)));
      ++valid;
    }
  }
  return static_cast<double>(valid) / static_cast<double>(disparity16.total());
}

// The reference: OpenCV's block matcher on the same rectified pair (valid share
// and median disagreement with SGBM), and SGBM right-to-left (the pair mirrored)
// for the matching precision: a pixel's left and right disparities differ by the
// two matches' errors, so sigma = 1.4826 * MAD / sqrt(2).
struct ReferenceFigures {
  double bm_valid_share = 0.0, disagreement_px = 0.0;
  std::vector<double> lr_differences;
};

ReferenceFigures reference(const cv::Mat& left, const cv::Mat& right, const cv::Mat& sgbm16,
                           const StereoOptions& o) {
  ReferenceFigures out;
  cv::Mat bm16;
  auto bm = cv::StereoBM::create(o.num_disparities, 15);
  bm->compute(left, right, bm16);
  std::vector<double> diffs;
  std::size_t bm_valid = 0;
  for (int y = 0; y < bm16.rows; ++y) {
    const auto* b = bm16.ptr<std::int16_t>(y);
    const auto* s = sgbm16.ptr<std::int16_t>(y);
    for (int x = 0; x < bm16.cols; ++x) {
      if (b[x] <= 0) continue;
      ++bm_valid;
      if (s[x] > 0) diffs.push_back(std::abs(b[x] - s[x]) / 16.0);
    }
  }
  out.bm_valid_share = static_cast<double>(bm_valid) / static_cast<double>(bm16.total());
  out.disagreement_px = median(diffs);

  cv::Mat left_flipped, right_flipped, right16_flipped;
  cv::flip(left, left_flipped, 1);
  cv::flip(right, right_flipped, 1);
  make_sgbm(o)->compute(right_flipped, left_flipped, right16_flipped);
  const int w = sgbm16.cols;
  for (int y = 0; y < sgbm16.rows; y += 2) {
    const auto* s = sgbm16.ptr<std::int16_t>(y);
    const auto* rf = right16_flipped.ptr<std::int16_t>(y);
    for (int x = 0; x < w; x += 2) {
      if (s[x] <= 0) continue;
      const double d = s[x] / 16.0;
      const int xr = static_cast<int>(std::lround(x - d));
      if (xr < 0 || xr >= w) continue;
      const std::int16_t dr16 = rf[w - 1 - xr];  // the mirrored image's column
      if (dr16 <= 0) continue;
      const double diff = d - dr16 / 16.0;
      if (std::abs(diff) < 2.0) out.lr_differences.push_back(diff);  // gross mismatches aside
    }
  }
  return out;
}

std::string ns_to_seconds(std::int64_t ns) {
  char buf[40];
  std::snprintf(buf, sizeof(buf), "%lld.%09lld", static_cast<long long>(ns / 1000000000),
                static_cast<long long>(ns % 1000000000));
  return buf;
}

// Body ground truth -> camera poses (TUM); the replay puts them through the same
// plausibility gate as a live INS.
bool write_groundtruth(const std::string& asl_dir, const Eigen::Isometry3d& body_T_camera,
                       const std::string& out_path, StereoReport* report, std::string* error) {
  const std::string csv = asl_dir + "/mav0/state_groundtruth_estimate0/data.csv";
  std::ifstream in(csv);
  if (!in) {
    *error = csv + ": cannot open (no ground truth: no poses to map with)";
    return false;
  }
  std::ofstream out(out_path);
  out << "# camera poses (world <- rectified left camera) from " << csv << "\n";
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::stringstream ss(line);
    std::string field;
    std::vector<double> v;
    long long ns = 0;
    for (int i = 0; std::getline(ss, field, ','); ++i) {
      if (i == 0) {
        ns = std::strtoll(field.c_str(), nullptr, 10);
      } else {
        v.push_back(std::strtod(field.c_str(), nullptr));
      }
    }
    if (v.size() < 7 || ns <= 0) {
      ++report->poses_rejected;
      continue;
    }
    const Eigen::Quaterniond q(v[3], v[4], v[5], v[6]);
    Eigen::Isometry3d world_T_body = Eigen::Isometry3d::Identity();
    world_T_body.linear() = q.normalized().toRotationMatrix();
    world_T_body.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
    if (!world_T_body.matrix().allFinite() || std::abs(q.norm() - 1.0) > 1e-3) {
      ++report->poses_rejected;
      continue;
    }
    const Eigen::Isometry3d world_T_camera = world_T_body * body_T_camera;
    const Eigen::Quaterniond qc(world_T_camera.linear());
    const Eigen::Vector3d t = world_T_camera.translation();
    char buf[200];
    std::snprintf(buf, sizeof(buf), "%s %.6f %.6f %.6f %.9f %.9f %.9f %.9f\n",
                  ns_to_seconds(ns).c_str(), t.x(), t.y(), t.z(), qc.x(), qc.y(), qc.z(), qc.w());
    out << buf;
    ++report->poses;
  }
  if (report->poses == 0) {
    *error = csv + ": no usable pose";
    return false;
  }
  return static_cast<bool>(out);
}

}  // namespace

bool is_asl_recording(const std::string& dir) {
  return fs::exists(fs::path(dir) / "mav0" / "cam0" / "data.csv");
}

namespace {

// The figures the matcher gathers over the pairs, for the report.
struct PairFigures {
  std::vector<double> valid_shares, bm_shares, disagreements, lr, ms;
};

// Every cam0 image with a cam1 image at the same time: rectified, matched, written
// as OUT/depth/<ns>.png and OUT/left/<ns>.png and listed.
bool match_pairs(const AslCamera& cam0, const AslCamera& cam1, const Rectification& r,
                 const StereoOptions& o, const std::string& asl_dir, const std::string& out_dir,
                 StereoReport* report, PairFigures* figures, std::string* error) {
  std::ofstream depth_list(out_dir + "/depth.txt"), left_list(out_dir + "/left.txt");
  depth_list << "# depth by SGBM from " << asl_dir << " (zonemap-stereo)\n";
  left_list << "# rectified left images\n";
  for (const auto& [ns, path] : cam1.frames) report->cam1_without_cam0 += !cam0.frames.count(ns);
  auto sgbm = make_sgbm(o);
  int index = 0;
  for (const auto& [ns, left_path] : cam0.frames) {
    const auto right = cam1.frames.find(ns);
    if (right == cam1.frames.end()) {
      ++report->cam0_without_cam1;
      std::fprintf(stderr, "zonemap-stereo: %s: no cam1 image at the same time: skipped\n",
                   left_path.c_str());
      continue;
    }
    ++report->pairs;
    const cv::Mat left_raw = cv::imread(left_path, cv::IMREAD_GRAYSCALE);
    const cv::Mat right_raw = cv::imread(right->second, cv::IMREAD_GRAYSCALE);
    if (left_raw.empty() || right_raw.empty() || left_raw.cols != cam0.width ||
        left_raw.rows != cam0.height || right_raw.size() != left_raw.size()) {
      ++report->unreadable;
      std::fprintf(stderr, "zonemap-stereo: %s: unreadable or not %dx%d: pair skipped\n",
                   (left_raw.empty() ? left_path : right->second).c_str(), cam0.width, cam0.height);
      continue;
    }
    const auto start = std::chrono::steady_clock::now();
    cv::Mat left, right_rect, disparity, depth;
    cv::remap(left_raw, left, r.map0x, r.map0y, cv::INTER_LINEAR);
    cv::remap(right_raw, right_rect, r.map1x, r.map1y, cv::INTER_LINEAR);
    sgbm->compute(left, right_rect, disparity);
    figures->valid_shares.push_back(depth_from_disparity(disparity, r, o, &depth));
    figures->ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
            .count());
    if (o.reference_every > 0 && index % o.reference_every == 0) {
      const ReferenceFigures ref = reference(left, right_rect, disparity, o);
      figures->bm_shares.push_back(ref.bm_valid_share);
      figures->disagreements.push_back(ref.disagreement_px);
      figures->lr.insert(figures->lr.end(), ref.lr_differences.begin(), ref.lr_differences.end());
    }
    ++index;
    const std::string name = std::to_string(ns) + ".png";
    if (!cv::imwrite(out_dir + "/depth/" + name, depth) ||
        !cv::imwrite(out_dir + "/left/" + name, left)) {
      *error = out_dir + ": cannot write " + name;
      return false;
    }
    depth_list << ns_to_seconds(ns) << " depth/" << name << "\n";
    left_list << ns_to_seconds(ns) << " left/" << name << "\n";
    ++report->written;
  }
  return true;
}

// Medians and the matcher's sigma; returns eq. (1)'s sigma: the larger of the two
// measurements (left-right consistency shares the matcher's own biases and reads
// low), never below the 1/16 px step.
double summarise(const PairFigures& figures, StereoReport* report) {
  report->valid_share_median = median(figures.valid_shares);
  report->reference_valid_share_median = median(figures.bm_shares);
  report->reference_disagreement_px_median = median(figures.disagreements);
  report->ms_per_pair_median = median(figures.ms);
  if (!figures.lr.empty()) {
    const double m = median(figures.lr);
    std::vector<double> dev;
    for (double d : figures.lr) dev.push_back(std::abs(d - m));
    report->sigma_px = 1.4826 * median(dev) / std::sqrt(2.0);
  }
  // The block matcher's disagreement, read as two independent matchers of equal
  // precision: median |d1 - d2| = 0.6745 * sqrt(2) * sigma.
  report->sigma_px_from_reference =
      report->reference_disagreement_px_median / (0.6745 * std::sqrt(2.0));
  return std::max({report->sigma_px, report->sigma_px_from_reference, 1.0 / 16.0});
}

bool write_camera_yaml(const std::string& path, const std::string& asl_dir, const AslCamera& cam0,
                       const Rectification& r, double sigma, double depth_scale,
                       const Eigen::Isometry3d& frd_T_camera) {
  const Eigen::Quaterniond q(frd_T_camera.linear());
  const Eigen::Vector3d t = frd_T_camera.translation();
  std::ofstream camera(path);
  char buf[160];
  camera << "# rectified left camera of " << asl_dir << " (zonemap-stereo)\n";
  camera << "width: " << cam0.width << "\nheight: " << cam0.height << "\n";
  std::snprintf(buf, sizeof(buf), "fx: %.4f\nfy: %.4f\ncx: %.4f\ncy: %.4f\n", r.f, r.f, r.cx, r.cy);
  camera << buf;
  std::snprintf(buf, sizeof(buf),
                "baseline_m: %.6f\nmatch_sigma_px: %.3f   # measured: left-right consistency\n",
                r.baseline_m, sigma);
  camera << buf << "depth_scale: " << depth_scale << "\n";
  std::snprintf(buf, sizeof(buf),
                "body_T_camera: {t: [%.6f, %.6f, %.6f], q: [%.9f, %.9f, %.9f, %.9f]}\n", t.x(),
                t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
  camera << buf << "world_z_up: true\n";
  return static_cast<bool>(camera);
}

bool write_stereo_json(const std::string& path, const StereoReport& report, const Rectification& r,
                       double sigma) {
  std::ofstream json(path);
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.4f", report.valid_share_median);
  json << "{\"pairs\": " << report.pairs << ", \"written\": " << report.written
       << ", \"cam0_without_cam1\": " << report.cam0_without_cam1
       << ", \"cam1_without_cam0\": " << report.cam1_without_cam0
       << ", \"unreadable\": " << report.unreadable << ", \"poses\": " << report.poses
       << ", \"poses_rejected\": " << report.poses_rejected << ",\n \"focal_px\": " << r.f
       << ", \"baseline_m\": " << r.baseline_m
       << ", \"num_disparities\": " << report.num_disparities
       << ", \"min_depth_m\": " << report.min_depth_m << ", \"max_depth_m\": " << report.max_depth_m
       << ", \"sigma_px_left_right\": " << report.sigma_px
       << ", \"sigma_px_from_reference\": " << report.sigma_px_from_reference
       << ", \"match_sigma_px\": " << sigma << ",\n \"valid_share_median\": " << buf
       << ", \"reference_bm_valid_share_median\": " << report.reference_valid_share_median
       << ", \"reference_disagreement_px_median\": " << report.reference_disagreement_px_median
       << ",\n \"stereo_ms_per_pair_median\": " << report.ms_per_pair_median << "}\n";
  return static_cast<bool>(json);
}

}  // namespace

StereoOptions range_for(const StereoOptions& o, double f_px, double baseline_m) {
  if (!o.range_from_camera) return o;
  StereoOptions out = o;
  const double fb = f_px * baseline_m;
  const int needed = static_cast<int>(std::ceil(fb / std::max(o.config_d_min_m, 0.01)));
  out.num_disparities = std::clamp((needed + 15) / 16 * 16, 16, 256);
  out.min_depth_m = fb / (out.num_disparities - 1);
  out.max_depth_m = std::max(o.config_d_max_m, 0.1 * fb / StereoOptions::kNominalSigmaPx);
  return out;
}

bool convert_asl(const std::string& asl_dir, const std::string& out_dir,
                 const StereoOptions& requested, StereoReport* report, std::string* error) {
  *report = StereoReport{};
  AslCamera cam0, cam1;
  if (!load_camera(asl_dir + "/mav0/cam0", &cam0, error) ||
      !load_camera(asl_dir + "/mav0/cam1", &cam1, error)) {
    return false;
  }
  Rectification r;
  if (!rectify(cam0, cam1, &r, error)) return false;
  report->focal_px = r.f;
  report->baseline_m = r.baseline_m;
  const StereoOptions o = range_for(requested, r.f, r.baseline_m);
  report->num_disparities = o.num_disparities;
  report->min_depth_m = o.min_depth_m;
  report->max_depth_m = o.max_depth_m;
  std::error_code ec;
  fs::create_directories(fs::path(out_dir) / "depth", ec);
  fs::create_directories(fs::path(out_dir) / "left", ec);
  if (ec) {
    *error = out_dir + ": cannot create (" + ec.message() + ")";
    return false;
  }
  // The rectified left camera in the vehicle body frame (FRD). The ASL body frame is
  // the IMU's; for the VI-sensor (camera looking along body z, image right = body y,
  // image down = -body x) FRD is forward = z, right = y, down = -x.
  Eigen::Isometry3d cam0_T_rect = Eigen::Isometry3d::Identity();
  cam0_T_rect.linear() = r.rect_R_cam0.transpose();
  const Eigen::Isometry3d aslbody_T_camera = cam0.body_T_sensor * cam0_T_rect;
  if (!write_groundtruth(asl_dir, aslbody_T_camera, out_dir + "/groundtruth.txt", report, error)) {
    return false;
  }
  Eigen::Isometry3d frd_T_aslbody = Eigen::Isometry3d::Identity();
  frd_T_aslbody.linear() << 0, 0, 1, 0, 1, 0, -1, 0, 0;
  PairFigures figures;
  if (!match_pairs(cam0, cam1, r, o, asl_dir, out_dir, report, &figures, error)) return false;
  if (report->written == 0) {
    *error = asl_dir + ": no stereo pair could be matched";
    return false;
  }
  const double sigma = summarise(figures, report);
  const bool camera_ok = write_camera_yaml(out_dir + "/camera.yaml", asl_dir, cam0, r, sigma,
                                           o.depth_scale, frd_T_aslbody * aslbody_T_camera);
  const bool json_ok = write_stereo_json(out_dir + "/stereo.json", *report, r, sigma);
  return camera_ok && json_ok;
}

}  // namespace zonemap::stereo
