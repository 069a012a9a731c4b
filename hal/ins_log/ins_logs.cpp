#include "hal/ins_log/ins_logs.hpp"

#include <filesystem>

#include "hal/can/can_pose_source.hpp"
#include "hal/lcm/lcm_link.hpp"

namespace zonemap::ins_log {

std::unique_ptr<hal::PoseSource> open_ins_log(const InsLogSettings& settings,
                                              const InsGateConfig& gate,
                                              const Eigen::Isometry3d& body_T_camera,
                                              bool world_z_up, std::string* error) {
  if (settings.kind == InsLogSettings::Kind::kLcmLog) {
    auto log = std::make_unique<lcm_link::LcmLogPoseSource>(settings.lcm_channel, world_z_up, gate,
                                                            body_T_camera, settings.time_offset_s);
    if (!log->open(settings.path, error)) return nullptr;
    return log;
  }
  auto log = std::make_unique<can::CandumpPoseSource>(settings.can_profile, gate, body_T_camera,
                                                      settings.time_offset_s);
  if (!log->open(settings.path, error)) return nullptr;
  return log;
}

std::unique_ptr<hal::PoseSource> SequenceInsLogs::open(const std::string& dir,
                                                       const CameraModel& camera,
                                                       const InsGateConfig& gate,
                                                       std::string* error) const {
  InsLogSettings settings;
  const std::filesystem::path base(dir);
  if (std::filesystem::exists(base / "ins.lcmlog")) {
    settings.path = (base / "ins.lcmlog").string();
  } else if (std::filesystem::exists(base / "ins.candump")) {
    settings.kind = InsLogSettings::Kind::kCandump;
    settings.path = (base / "ins.candump").string();
    settings.can_profile.profile = can::InsCanProfile::kZonemapIns;
    settings.can_profile.time_source = can::InsTimeSource::kIns;
  } else {
    *error = dir + ": no pose source (groundtruth.txt, ins.lcmlog or ins.candump)";
    return nullptr;
  }
  return open_ins_log(settings, gate, camera.body_T_camera, camera.world_z_up, error);
}

}  // namespace zonemap::ins_log
