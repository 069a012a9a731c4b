// zonemap-sitl-camera: the onboard daemon with a simulated depth camera, for a
// closed loop with a simulated autopilot on a desk (tools/sitl-flight). The
// camera renders a generated scene at the autopilot's pose (its EKF over MAVLink,
// on a port of its own); everything else is the daemon as vehicle.yaml sets it up
// (poses.source mavlink, outputs.mavlink to the autopilot).
//   zonemap-sitl-camera --config vehicle.yaml --scene NAME --camera-listen ADDR:PORT
//                       [--rate HZ] [--width PX] [--pitch-deg DEG]
#include <atomic>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "hal/config/yaml_config.hpp"
#include "hal/mavlink/mavlink_pose_source.hpp"
#include "onboard/daemon.hpp"
#include "onboard/vehicle_config.hpp"
#include "tools/eval/evaluate.hpp"
#include "tools/report/report.hpp"
#include "tools/sim/scenarios.hpp"
#include "tools/sitl/live_camera.hpp"

namespace {

std::atomic<zonemap::onboard::VehicleDaemon*> g_daemon{nullptr};

void on_signal(int) {
  if (auto* d = g_daemon.load()) d->stop();
}

int usage() {
  std::fprintf(stderr,
               "usage: zonemap-sitl-camera --config vehicle.yaml --scene NAME --camera-listen "
               "ADDR:PORT [--rate HZ] [--width PX] [--pitch-deg DEG]\n");
  return 2;
}

// The camera looking along the nose, pitched down: body FRD <- camera optical.
Eigen::Isometry3d nose_camera(double pitch_down_deg) {
  const double p = pitch_down_deg * M_PI / 180.0;
  Eigen::Matrix3d r;
  r.col(0) = Eigen::Vector3d(0.0, 1.0, 0.0);                   // optical x: right
  r.col(1) = Eigen::Vector3d(-std::sin(p), 0.0, std::cos(p));  // optical y: down
  r.col(2) = Eigen::Vector3d(std::cos(p), 0.0, std::sin(p));   // optical z: ahead, down
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = r;
  return t;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// report.html beside boxes.csv and stats.json: the map and the track the camera
// flew (the autopilot's NED).
bool write_flight_report(const std::string& dir, const std::string& title,
                         const std::vector<Eigen::Vector3d>& track, double cell_size_m,
                         std::string* error) {
  zonemap::tools::ReportInputs in;
  in.title = title;
  in.stats_json = read_file(dir + "/stats.json");
  std::vector<zonemap::tools::RunBox> boxes;
  if (!zonemap::tools::load_boxes_csv(dir + "/boxes.csv", &boxes, error)) return false;
  for (const zonemap::tools::RunBox& b : boxes) {
    zonemap::ObstacleBox box;
    box.id = b.id;
    box.kind = b.kind == "ground" ? zonemap::FeatureKind::kGround : zonemap::FeatureKind::kObstacle;
    box.min = b.min;
    box.max = b.max;
    box.cells = b.cells;
    in.boxes.push_back(box);
    in.footprints.emplace_back();
  }
  in.trajectory = track;
  in.world_z_up = false;
  in.cell_size_m = cell_size_m;
  return zonemap::tools::write_report(dir + "/report.html", in, error);
}

}  // namespace

int main(int argc, char** argv) {
  std::string config_path, scene_name, listen;
  double rate_hz = 10.0, pitch_deg = 10.0;
  int width = 320;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const bool has_value = i + 1 < argc;
    if (arg == "--config" && has_value) {
      config_path = argv[++i];
    } else if (arg == "--scene" && has_value) {
      scene_name = argv[++i];
    } else if (arg == "--camera-listen" && has_value) {
      listen = argv[++i];
    } else if (arg == "--rate" && has_value) {
      rate_hz = std::atof(argv[++i]);
    } else if (arg == "--width" && has_value) {
      width = std::atoi(argv[++i]);
    } else if (arg == "--pitch-deg" && has_value) {
      pitch_deg = std::atof(argv[++i]);
    } else {
      return usage();
    }
  }
  if (config_path.empty() || scene_name.empty() || listen.empty() || !(rate_hz > 0.0)) {
    return usage();
  }
  zonemap::onboard::VehicleConfig config;
  std::string error;
  if (!zonemap::onboard::load_vehicle_config(config_path, &config, &error)) {
    std::fprintf(stderr, "zonemap-sitl-camera: %s\n", error.c_str());
    return 1;
  }
  if (config.poses != zonemap::onboard::VehicleConfig::PoseSourceKind::kMavlink) {
    std::fprintf(stderr, "zonemap-sitl-camera: %s: poses.source must be mavlink\n",
                 config_path.c_str());
    return 1;
  }
  zonemap::sim::Scenario scenario;
  zonemap::sim::ScenarioOptions options;
  options.width = width;
  if (!zonemap::sim::make_scenario(scene_name, options, &scenario, &error)) {
    std::fprintf(stderr, "zonemap-sitl-camera: %s\n", error.c_str());
    return 1;
  }
  zonemap::CameraModel camera = scenario.camera;
  camera.world_z_up = false;  // the autopilot's NED
  camera.body_T_camera = nose_camera(pitch_deg);
  camera.mount_configured = true;
  zonemap::mavlink::MavlinkPoseConfig camera_poses = config.mavlink_poses;
  camera_poses.listen = listen;
  auto poses = std::make_unique<zonemap::mavlink::MavlinkPoseSource>(
      camera_poses, config.gate, camera.body_T_camera, config.time_offset_s);
  if (!poses->open(&error)) {
    std::fprintf(stderr, "zonemap-sitl-camera: %s\n", error.c_str());
    return 1;
  }
  auto frames = std::make_unique<zonemap::sitl::LiveSimCamera>(
      scenario.scene, camera, std::move(poses), rate_hz, zonemap::sim::RenderOptions{});
  const zonemap::sitl::LiveSimCamera& live = *frames;
  zonemap::MapConfig map;
  if (!zonemap::hal::load_map_config(config.mapping_path, &map, &error)) {
    std::fprintf(stderr, "zonemap-sitl-camera: %s\n", error.c_str());
    return 1;
  }
  zonemap::onboard::VehicleDaemon daemon;
  if (!daemon.open(config, std::move(frames), &error)) {
    std::fprintf(stderr, "zonemap-sitl-camera: %s\n", error.c_str());
    return 1;
  }
  std::fputs(daemon.describe().c_str(), stderr);
  g_daemon.store(&daemon);
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  daemon.run();
  g_daemon.store(nullptr);
  if (!daemon.write_outputs(&error) ||
      (!config.output_dir.empty() &&
       !write_flight_report(config.output_dir, scene_name + " (closed loop)", live.track(),
                            map.cell_size_m, &error))) {
    std::fprintf(stderr, "zonemap-sitl-camera: %s\n", error.c_str());
    return 1;
  }
  const auto& s = daemon.pipeline_stats();
  std::fprintf(stderr, "zonemap-sitl-camera: %lld frames in, %lld mapped, %lld without pose\n",
               static_cast<long long>(s.frames_in), static_cast<long long>(s.frames_mapped),
               static_cast<long long>(s.frames_skipped_no_pose));
  return 0;
}
