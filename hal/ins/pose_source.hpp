// Pose sources (INS over CAN, LCM, or their logs) behind one small interface: a
// source runs on the INS thread, reads what has arrived, passes every solution
// through the plausibility gate and hands accepted camera poses to a sink (the
// pipeline's lock-free PoseBuffer). Refusals are counted and logged, rate-limited.
#pragma once

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

#include <Eigen/Geometry>

#include "zonemap/common/camera.hpp"

#include "zonemap/pose/ins_gate.hpp"
#include "zonemap/pose/pose_track.hpp"

namespace zonemap::hal {

class PoseSink {
 public:
  virtual ~PoseSink() = default;
  virtual void push(const PoseSample& camera_pose) = 0;
};

enum class PollResult { kIdle, kGotData, kEnd };

struct PoseSourceCounters {
  std::int64_t messages = 0;     // messages / frames read
  std::int64_t malformed = 0;    // undecodable (wrong size, fingerprint, log line)
  std::int64_t solutions = 0;    // complete INS solutions decoded
  std::int64_t poses_out = 0;    // accepted, handed to the mapper
  std::int64_t link_errors = 0;  // transport went down (reopened with backoff)
  std::int64_t incomplete = 0;   // parts that made no solution (no partner, clock not synced)
  std::int64_t time_syncs = 0, time_sync_steps = 0;  // source clock -> ours (MAVLink TIMESYNC)
  InsGateCounters gate;
};

class PoseSource {
 public:
  virtual ~PoseSource() = default;
  // Reads what has arrived, waiting at most wait_ms for something (0: never wait).
  // kEnd: a log is exhausted (live sources never end).
  virtual PollResult poll(PoseSink& sink, int wait_ms) = 0;
  virtual PoseSourceCounters counters() const = 0;
  virtual const char* name() const = 0;
};

// A recorded pose source (an INS log) read to its end into `track`, as a replay
// uses it: the poses the track refused (out of order) and the source's counters.
struct PoseLogRead {
  std::int64_t refused_by_track = 0;
  PoseSourceCounters counters;
};
PoseLogRead read_to_end(PoseSource& log, PoseTrack* track);

// The INS log a recorded sequence carries instead of ground truth (FORMATS.md §1:
// ins.lcmlog, ins.candump). Decoding it is the vehicle links' work (hal/ins_log);
// the replay back-end asks through this, so that it links no vehicle link.
class SequenceInsLog {
 public:
  virtual ~SequenceInsLog() = default;
  // The log's pose source (camera poses through the gate); null with *error when
  // `dir` holds no INS log or it cannot be opened.
  virtual std::unique_ptr<PoseSource> open(const std::string& dir, const CameraModel& camera,
                                           const InsGateConfig& gate, std::string* error) const = 0;
};

// What a pose source logs, each with a rate limit of its own: the INS gate's
// refusals (InsRejection's values, gate_reason()), then the link's own troubles.
enum class LogReason : int {
  kWrongWorldFrame = 12,   // a message in another world frame than the map's
  kMalformedMessage = 13,  // fingerprint or length wrong: not decodable
  kDamagedLogRecord = 14,  // a damaged log event or candump line, skipped
  kLinkDown = 15,          // the bus or the LCM provider is not there (retrying)
  kRejectedItem = 16,      // one item of a message refused (a shared map's box)
};
inline constexpr int kLogReasons = 17;
static_assert(static_cast<int>(InsRejection::kCount) <=
              static_cast<int>(LogReason::kWrongWorldFrame));
inline LogReason gate_reason(InsRejection why) {
  return static_cast<LogReason>(static_cast<int>(why));
}

// At most one line per reason and interval, with the number left unsaid.
// Allocation-free (fprintf to stderr).
class RateLimitedLog {
 public:
  explicit RateLimitedLog(double interval_s = 1.0) : interval_s_(interval_s) {}
  void log(LogReason reason, double now_s, const char* source, const char* what);

 private:
  static constexpr int kReasons = kLogReasons;
  double interval_s_;
  double last_s_[kReasons] = {};
  bool logged_[kReasons] = {};
  std::int64_t suppressed_[kReasons] = {};
};

// Gate + mount: INS solution (body) -> camera pose, counted and logged.
class InsPoseFilter {
 public:
  InsPoseFilter(const InsGateConfig& gate, const Eigen::Isometry3d& body_T_camera,
                double time_offset_s, const char* source_name)
      : gate_(gate),
        body_T_camera_(body_T_camera),
        time_offset_s_(time_offset_s),
        name_(source_name) {}
  // Returns true when a pose went to the sink.
  bool pass(InsSolution solution, PoseSink& sink, double now_s);
  const InsGateCounters& gate_counters() const { return gate_.counters(); }
  std::int64_t poses_out() const { return poses_out_; }
  RateLimitedLog& log() { return log_; }

 private:
  InsGate gate_;
  Eigen::Isometry3d body_T_camera_;
  double time_offset_s_;  // added to solution times: INS/receive clock -> frame clock
  const char* name_;
  std::int64_t poses_out_ = 0;
  RateLimitedLog log_;
};

}  // namespace zonemap::hal
