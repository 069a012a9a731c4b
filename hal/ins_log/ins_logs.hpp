// Recorded INS logs read through the vehicle links' own decoders: an LCM log of
// ins_state_t (lcm-logger's format) or a candump log of an INS CAN profile. One
// place opens them, for the daemon's `poses.source: lcm_log | candump` and for a
// replayed sequence that carries its INS log instead of ground truth.
#pragma once

#include <memory>
#include <string>

#include <Eigen/Geometry>

#include "hal/can/ins_can.hpp"
#include "hal/ins/pose_source.hpp"

namespace zonemap::ins_log {

struct InsLogSettings {
  enum class Kind { kLcmLog, kCandump };
  Kind kind = Kind::kLcmLog;
  std::string path;
  std::string lcm_channel = "INS_STATE";  // kLcmLog
  can::InsCanConfig can_profile;          // kCandump
  double time_offset_s = 0.0;             // added to the log's times to reach the frames' clock
};

// The log's pose source (camera poses through the gate, opened); null with
// *error when it cannot be read.
std::unique_ptr<hal::PoseSource> open_ins_log(const InsLogSettings& settings,
                                              const InsGateConfig& gate,
                                              const Eigen::Isometry3d& body_T_camera,
                                              bool world_z_up, std::string* error);

// A sequence's own INS log (FORMATS.md §1): DIR/ins.lcmlog (INS_STATE) or else
// DIR/ins.candump (the zonemap INS profile, INS clock).
class SequenceInsLogs final : public hal::SequenceInsLog {
 public:
  std::unique_ptr<hal::PoseSource> open(const std::string& dir, const CameraModel& camera,
                                        const InsGateConfig& gate,
                                        std::string* error) const override;
};

}  // namespace zonemap::ins_log
