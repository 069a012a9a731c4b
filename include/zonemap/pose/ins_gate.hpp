// An INS solution as the vehicle links deliver it (body pose in a local NED or
// other z-vertical world frame), and the plausibility gate every solution passes
// before it may place a depth frame: a map built with one bad pose is wrong for
// the rest of the flight, so anything doubtful is refused and counted.
#pragma once

#include <array>
#include <cstdint>

#include <Eigen/Geometry>

#include "zonemap/common/time_watermark.hpp"
#include "zonemap/pose/pose_track.hpp"

namespace zonemap {

struct InsSolution {
  double time_s = 0.0;  // on the clock the depth frames use (the source converts)
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();          // world <- body
  Eigen::Quaterniond attitude = Eigen::Quaterniond::Identity();  // world <- body
  bool attitude_valid = false;
  bool position_valid = false;
  double position_sigma_m = -1.0;  // 1-sigma, < 0 = not reported
};

struct InsGateConfig {
  double max_speed_mps = 80.0;         // faster than any helicopter: a position step beyond
  double jump_margin_m = 5.0;          // max_speed * dt + margin is a jump
  double max_position_sigma_m = 5.0;   // a worse solution is refused (< 0: no limit)
  double quaternion_tolerance = 0.01;  // | |q| - 1 | accepted (scaled integers)
  // A jump that persists (consecutive solutions agreeing with each other) this long
  // is accepted as the new truth (e.g. GNSS re-acquired) and counted as a re-anchor.
  double reanchor_after_s = 1.0;
  // Time order: one stamp far off is refused alone; a step that persists is
  // adopted (counted as a clock step) and the jump check starts afresh.
  TimeWatermarkConfig time;
};

enum class InsRejection : std::uint8_t {
  kNotFinite,
  kBadQuaternion,
  kFlagsInvalid,
  kTimeNotIncreasing,
  kJump,
  kInaccurate,
  kTimeOutlier,  // far after the previous solution (held as a possible clock step)
  kCount
};
const char* to_string(InsRejection reason);

struct InsGateCounters {
  std::int64_t accepted = 0;
  std::int64_t reanchors = 0;
  std::int64_t clock_steps = 0;  // persistent time steps adopted
  std::array<std::int64_t, static_cast<int>(InsRejection::kCount)> rejected{};
  std::int64_t rejected_total() const;
};

class InsGate {
 public:
  explicit InsGate(const InsGateConfig& config = {}) : config_(config), time_(config.time) {}

  // True when the solution may be used; otherwise *why says which rule refused it
  // (the caller logs, rate-limited). Counts both. Allocation-free.
  bool check(const InsSolution& solution, InsRejection* why);
  const InsGateCounters& counters() const { return counters_; }
  void reset_track() {
    has_last_ = false;
    time_.reset();
  }

 private:
  bool reject(InsRejection reason, InsRejection* why);

  InsGateConfig config_;
  InsGateCounters counters_;
  TimeWatermark time_;
  bool has_last_ = false;
  double last_time_s_ = 0.0;
  Eigen::Vector3d last_position_ = Eigen::Vector3d::Zero();
  // A run of jumped solutions consistent with each other (re-anchor candidate).
  bool has_candidate_ = false;
  double candidate_since_s_ = 0.0, candidate_time_s_ = 0.0;
  Eigen::Vector3d candidate_position_ = Eigen::Vector3d::Zero();
};

// The camera's pose from the body's: world <- camera = (world <- body)(body <- camera).
PoseSample camera_pose_sample(const InsSolution& solution, const Eigen::Isometry3d& body_T_camera);

}  // namespace zonemap
