// Host HAL frame and pose source: a replay sequence directory (FORMATS.md §1;
// a TUM RGB-D sequence is one). Everything is read and checked when opened;
// frames are decoded one at a time into buffers reserved at open.
#pragma once

#include <cstddef>
#include <cstdint>
#include <istream>
#include <string>
#include <vector>

#include "hal/frames/frame_source.hpp"
#include "hal/ins/pose_source.hpp"
#include "zonemap/common/camera.hpp"
#include "zonemap/common/config.hpp"
#include "zonemap/common/time_watermark.hpp"
#include "zonemap/pose/ins_gate.hpp"
#include "zonemap/pose/pose_track.hpp"

namespace zonemap::replay {

struct FrameListEntry {
  double time_s = 0.0;
  std::string path;           // absolute or relative to the working directory
  int line = 0;               // line in the list file, for messages
  bool time_in_order = true;  // false: refused by the time watermark (time_verdict says why)
  TimeVerdict time_verdict = TimeVerdict::kAccepted;
};

// How lists read whole are cleaned: their time order (a lone stamp far off is
// refused alone, a forward step that persists is taken whole, a clock that goes
// back is not adopted) and, for trajectories, the INS plausibility gate (speed
// limit, jump, re-anchor) every live pose passes too.
struct ListFilterConfig {
  TimeWatermarkConfig time{2.0, 3, false};
  InsGateConfig gate;
};

// Per reason, the poses a trajectory list refused (stats.json names them).
struct PoseListCounts {
  std::int64_t not_finite = 0, quaternion = 0, time_past = 0, time_repeated = 0, time_future = 0;
  std::int64_t jump = 0, reanchors = 0, clock_steps = 0;
  // INS logs (ins.lcmlog, ins.candump): undecodable records (a damaged line, a
  // wrong length, a solution left incomplete by one) and solutions the gate refused.
  std::int64_t log_malformed = 0, log_implausible = 0;
  std::int64_t refused() const {
    return not_finite + quaternion + time_past + time_repeated + time_future + jump;
  }
};

// Reads a TUM-style list (`timestamp path`, '#' comments). A malformed line is an
// error naming file and line. Timestamps the watermark refuses are kept but
// flagged so that the frame is rejected and counted at replay.
bool load_frame_list(const std::string& list_path, const std::string& base_dir,
                     std::vector<FrameListEntry>* entries, std::string* error,
                     const TimeWatermarkConfig& time = ListFilterConfig{}.time);

// Reads a TUM trajectory (`timestamp tx ty tz qx qy qz qw`). A malformed line is an
// error; a sample with NaN, a non-unit quaternion, a stamp the time watermark
// refuses or a position the gate calls a jump is refused, counted in *rejected
// (and per reason in *counts) and described in *warnings (file:line).
bool load_trajectory(const std::string& path, PoseTrack* track, int* rejected,
                     std::vector<std::string>* warnings, std::string* error,
                     const ListFilterConfig& filter = {}, PoseListCounts* counts = nullptr);

// The same from a stream (`name` stands for the file in messages): tests, fuzzing.
bool parse_frame_list(std::istream& in, const std::string& name, const std::string& base_dir,
                      std::vector<FrameListEntry>* entries, std::string* error,
                      const TimeWatermarkConfig& time = ListFilterConfig{}.time);
bool parse_trajectory(std::istream& in, const std::string& name, PoseTrack* track, int* rejected,
                      std::vector<std::string>* warnings, std::string* error,
                      const ListFilterConfig& filter = {}, PoseListCounts* counts = nullptr);

class ReplaySequence {
 public:
  // camera_path: empty to use DIR/camera.yaml. Poses from DIR/groundtruth.txt, or
  // else from the INS log `ins_logs` opens (none given: groundtruth.txt only).
  bool open(const std::string& dir, const std::string& camera_path, const MapConfig& config,
            std::string* error, const hal::SequenceInsLog* ins_logs = nullptr);

  std::size_t frame_count() const { return frames_.size(); }
  const FrameListEntry& entry(std::size_t i) const { return frames_[i]; }
  const CameraModel& camera() const { return camera_; }
  const PoseTrack& poses() const { return poses_; }
  int poses_rejected() const { return poses_rejected_; }
  const PoseListCounts& pose_counts() const { return pose_counts_; }
  const std::vector<std::string>& warnings() const { return warnings_; }

  // Decodes frame i into `frame` (whose buffers must come from make_frame()).
  // Returns false with the reason (file and problem) for a frame that must be
  // rejected: unreadable, corrupt, wrong size or bit depth, time out of order.
  bool read(std::size_t i, hal::CameraFrame* frame, std::string* why) const;
  hal::CameraFrame make_frame() const;

 private:
  CameraModel camera_;
  std::vector<FrameListEntry> frames_;
  std::vector<std::string> left_paths_;  // per frame, empty when none
  PoseTrack poses_{0.1, 0.02};
  int poses_rejected_ = 0;
  PoseListCounts pose_counts_;
  std::vector<std::string> warnings_;
};

}  // namespace zonemap::replay
