#include "zonemap/pose/ins_gate.hpp"

#include <cmath>

namespace zonemap {

const char* to_string(InsRejection reason) {
  switch (reason) {
    case InsRejection::kNotFinite:
      return "not finite";
    case InsRejection::kBadQuaternion:
      return "attitude quaternion not unit";
    case InsRejection::kFlagsInvalid:
      return "INS flags say invalid";
    case InsRejection::kTimeNotIncreasing:
      return "time not after the previous solution";
    case InsRejection::kJump:
      return "position jump beyond the speed limit";
    case InsRejection::kInaccurate:
      return "position accuracy worse than the limit";
    case InsRejection::kTimeOutlier:
      return "time far after the previous solution";
    case InsRejection::kCount:
      break;
  }
  return "?";
}

std::int64_t InsGateCounters::rejected_total() const {
  std::int64_t total = 0;
  for (const std::int64_t n : rejected) total += n;
  return total;
}

bool InsGate::reject(InsRejection reason, InsRejection* why) {
  ++counters_.rejected[static_cast<int>(reason)];
  if (why != nullptr) *why = reason;
  return false;
}

bool InsGate::check(const InsSolution& s, InsRejection* why) {
  if (!std::isfinite(s.time_s) || !s.position_m.allFinite() || !s.attitude.coeffs().allFinite()) {
    return reject(InsRejection::kNotFinite, why);
  }
  if (std::abs(s.attitude.norm() - 1.0) > config_.quaternion_tolerance) {
    return reject(InsRejection::kBadQuaternion, why);
  }
  if (!s.attitude_valid || !s.position_valid) return reject(InsRejection::kFlagsInvalid, why);
  if (config_.max_position_sigma_m >= 0.0 && s.position_sigma_m > config_.max_position_sigma_m) {
    return reject(InsRejection::kInaccurate, why);
  }
  const TimeVerdict time = time_.offer(s.time_s);
  if (time == TimeVerdict::kFuture) return reject(InsRejection::kTimeOutlier, why);
  if (!accepted(time)) return reject(InsRejection::kTimeNotIncreasing, why);
  if (time == TimeVerdict::kAdopted) {
    ++counters_.clock_steps;  // a new clock: positions are compared from here on
    has_last_ = false;
    has_candidate_ = false;
  }
  if (has_last_) {
    const double dt = s.time_s - last_time_s_;
    const double allowed = config_.max_speed_mps * dt + config_.jump_margin_m;
    if ((s.position_m - last_position_).norm() > allowed) {
      // Does this continue a run of jumped solutions that agree with each other?
      const bool continues =
          has_candidate_ && s.time_s > candidate_time_s_ &&
          (s.position_m - candidate_position_).norm() <=
              config_.max_speed_mps * (s.time_s - candidate_time_s_) + config_.jump_margin_m;
      if (!continues) {
        has_candidate_ = true;
        candidate_since_s_ = s.time_s;
      }
      candidate_time_s_ = s.time_s;
      candidate_position_ = s.position_m;
      if (s.time_s - candidate_since_s_ < config_.reanchor_after_s) {
        return reject(InsRejection::kJump, why);
      }
      ++counters_.reanchors;  // the new position held: accept it as the truth
    }
  }
  has_candidate_ = false;
  has_last_ = true;
  last_time_s_ = s.time_s;
  last_position_ = s.position_m;
  ++counters_.accepted;
  return true;
}

PoseSample camera_pose_sample(const InsSolution& solution, const Eigen::Isometry3d& body_T_camera) {
  const Eigen::Quaterniond world_q_body = solution.attitude.normalized();
  PoseSample sample;
  sample.time_s = solution.time_s;
  sample.position = solution.position_m + world_q_body * body_T_camera.translation();
  sample.attitude = (world_q_body * Eigen::Quaterniond(body_T_camera.linear())).normalized();
  return sample;
}

}  // namespace zonemap
