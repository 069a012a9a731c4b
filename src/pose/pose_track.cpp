#include "zonemap/pose/pose_track.hpp"

#include <algorithm>
#include <cmath>

namespace zonemap {
namespace {

Eigen::Isometry3d to_isometry(const Eigen::Vector3d& p, const Eigen::Quaterniond& q) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = q.toRotationMatrix();
  pose.translation() = p;
  return pose;
}

}  // namespace

bool PoseTrack::append(const PoseSample& s) {
  if (!std::isfinite(s.time_s) || !s.position.allFinite() || !s.attitude.coeffs().allFinite()) {
    return false;
  }
  if (std::fabs(s.attitude.norm() - 1.0) > 1e-3) return false;
  if (!samples_.empty() && !(s.time_s > samples_.back().time_s)) return false;
  PoseSample normalised = s;
  normalised.attitude.normalize();
  samples_.push_back(normalised);
  return true;
}

PoseLookup PoseTrack::lookup(double t, Eigen::Isometry3d* out) const {
  if (samples_.empty() || !std::isfinite(t)) return PoseLookup::kNoPose;
  const auto after =
      std::lower_bound(samples_.begin(), samples_.end(), t,
                       [](const PoseSample& s, double time) { return s.time_s < time; });
  if (after != samples_.end() && after->time_s == t) {
    *out = to_isometry(after->position, after->attitude);
    return PoseLookup::kInterpolated;
  }
  if (after != samples_.begin() && after != samples_.end()) {
    const PoseSample& a = *(after - 1);
    const PoseSample& b = *after;
    if (b.time_s - a.time_s <= max_gap_s_) {
      const double f = (t - a.time_s) / (b.time_s - a.time_s);
      *out =
          to_isometry(a.position + f * (b.position - a.position), a.attitude.slerp(f, b.attitude));
      return PoseLookup::kInterpolated;
    }
  }
  // No bracketing pair close enough: accept the nearest sample within tolerance.
  const PoseSample* nearest = nullptr;
  if (after != samples_.end()) nearest = &*after;
  if (after != samples_.begin()) {
    const PoseSample* before = &*(after - 1);
    if (nearest == nullptr || t - before->time_s < nearest->time_s - t) nearest = before;
  }
  if (nearest != nullptr && std::fabs(nearest->time_s - t) <= tolerance_s_) {
    *out = to_isometry(nearest->position, nearest->attitude);
    return PoseLookup::kNearest;
  }
  return PoseLookup::kNoPose;
}

double extrapolated_ahead_s(const Eigen::Isometry3d& previous, double previous_s,
                            const Eigen::Isometry3d& last, double last_s, double ahead_s,
                            const PoseExtrapolationLimits& limits) {
  const double span = last_s - previous_s;
  if (!(ahead_s > 0.0) || !(span > 0.0) || !(span <= limits.max_span_s)) return 0.0;
  const double speed = (last.translation() - previous.translation()).norm() / span;
  if (!(speed <= limits.max_speed_mps)) return 0.0;
  return std::min(ahead_s, limits.max_ahead_s);
}

Eigen::Isometry3d extrapolate_pose(const Eigen::Isometry3d& previous, double previous_s,
                                   const Eigen::Isometry3d& last, double last_s, double ahead_s,
                                   const PoseExtrapolationLimits& limits) {
  const double ahead = extrapolated_ahead_s(previous, previous_s, last, last_s, ahead_s, limits);
  if (ahead == 0.0) return last;
  const double span = last_s - previous_s;
  const Eigen::Vector3d velocity = (last.translation() - previous.translation()) / span;
  // The turn from previous to last, in last's frame, scaled to `ahead`.
  const Eigen::AngleAxisd turn(previous.linear().transpose() * last.linear());
  Eigen::Isometry3d moved = Eigen::Isometry3d::Identity();
  moved.linear() = last.linear() *
                   Eigen::AngleAxisd(turn.angle() * ahead / span, turn.axis()).toRotationMatrix();
  moved.translation() = last.translation() + velocity * ahead;
  return moved;
}

}  // namespace zonemap
