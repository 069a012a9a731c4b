// The onboard daemon's configuration (config/vehicle.yaml): where frames and
// poses come from, where the obstacles go. Strict: unknown keys and bad values
// are errors naming file and line; paths are relative to the file.
#pragma once

#include <string>

#include "hal/can/ins_can.hpp"
#include "hal/can/obstacle_can.hpp"
#include "hal/lcm/lcm_shared_maps.hpp"
#include "hal/lcm/lcm_sinks.hpp"
#include "hal/mavlink/mavlink_pose_source.hpp"
#include "hal/mavlink/mavlink_udp_sink.hpp"
#include "zonemap/pose/ins_gate.hpp"

namespace zonemap::onboard {

struct VehicleConfig {
  std::string path;          // this file
  std::string mapping_path;  // the mapping configuration (config/*.yaml)
  std::string prior_path;    // a prior map (boxes.csv) in the feature map from the start
  double save_map_every_s =
      0.0;                  // outputs.save_map_every_s: boxes.csv during the flight (0: at stop)
  std::string camera_path;  // camera.yaml (v4l2; replay: empty = the sequence's)

  enum class FrameSourceKind { kReplay, kV4l2 };
  FrameSourceKind frames = FrameSourceKind::kReplay;
  std::string sequence_dir;  // replay
  double replay_rate_hz = 0.0;
  std::string v4l2_device = "/dev/video0";
  std::string v4l2_format = "Y16";  // Y16 | Z16

  enum class PoseSourceKind { kSequence, kLcm, kLcmLog, kCan, kCandump, kMavlink };
  PoseSourceKind poses = PoseSourceKind::kSequence;
  std::string lcm_url = "udpm://239.255.76.67:7667?ttl=0";
  std::string lcm_channel = "INS_STATE";
  std::string pose_log_path;  // lcm_log, candump
  std::string can_interface = "can0";
  can::InsCanConfig can_profile;
  double time_offset_s = 0.0;  // added to INS / receive times to reach the frames' clock
  mavlink::MavlinkPoseConfig mavlink_poses;  // poses.source mavlink: the autopilot's EKF
  InsGateConfig gate;

  std::string output_dir;  // boxes.csv and stats.json at shutdown (empty: none)
  bool can_output = false;
  std::string can_output_interface = "can0";
  can::ObstacleCanConfig can_obstacles;
  bool lcm_output = false;
  lcm_link::LcmOutputConfig lcm;
  bool mavlink_output = false;
  mavlink::MavlinkUdpConfig mavlink;
  double health_period_s = 1.0;
  std::string record_path;      // a Foxglove recording (MCAP) of the flight (empty: none)
  int record_depth_every = 10;  // every n-th mapped depth frame into it (0: none)
  bool live = false;            // newest wins (drop frames when behind); replay default: lossless

  // This vehicle among others: its name and its world frame's WGS84 origin, said
  // in every obstacle_map_t it publishes; with them a daemon takes the maps other
  // vehicles publish (shared_maps), each into its own frame.
  std::string vehicle = "zonemap";
  bool vehicle_named = false;
  bool has_world_origin = false;
  Geodetic world_origin;
  bool shared_maps = false;
  lcm_link::SharedMapsConfig shared;
};

bool load_vehicle_config(const std::string& path, VehicleConfig* config, std::string* error);
// The same from text (`name` stands for the file in messages): tests, fuzzing.
bool load_vehicle_config_text(const std::string& text, const std::string& name,
                              VehicleConfig* config, std::string* error);

}  // namespace zonemap::onboard
