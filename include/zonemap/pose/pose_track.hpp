// Camera poses over time, associated to depth frames by timestamp: linear
// interpolation of the position and slerp of the attitude between the two
// samples around the frame time (paper §III-A: the pose at the time the image
// was recorded).
#pragma once

#include <cstddef>
#include <limits>
#include <vector>

#include <Eigen/Geometry>

namespace zonemap {

struct PoseSample {
  double time_s = 0.0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Quaterniond attitude = Eigen::Quaterniond::Identity();  // world <- camera, unit
};

enum class PoseLookup { kInterpolated, kNearest, kNoPose };

class PoseTrack {
 public:
  // max_gap_s: the largest interval between two samples that is interpolated over.
  // tolerance_s: outside the samples (or across a larger gap) the nearest sample is
  // used only if it is this close; otherwise the frame has no pose.
  PoseTrack(double max_gap_s, double tolerance_s)
      : max_gap_s_(max_gap_s), tolerance_s_(tolerance_s) {}

  void reserve(std::size_t n) { samples_.reserve(n); }
  void clear() { samples_.clear(); }  // keeps the reserved storage
  // Samples must come with strictly increasing times and unit quaternions; a
  // sample that does not is refused (returns false) so the caller can count it.
  bool append(const PoseSample& sample);

  PoseLookup lookup(double time_s, Eigen::Isometry3d* world_T_camera) const;

  std::size_t size() const { return samples_.size(); }
  const std::vector<PoseSample>& samples() const { return samples_; }

 private:
  double max_gap_s_;
  double tolerance_s_;
  std::vector<PoseSample> samples_;
};

// A pose a moment after the newest one known: `last` moved on for `ahead_s` as it
// moved from `previous` (constant linear and angular velocity). Data computed for
// `last` and sent later (a vehicle's obstacles in its body frame) stay right for
// where the vehicle is when they go. `last` itself when ahead_s <= 0, when the two
// are not max_span_s or less apart in time order, or moved faster than
// max_speed_mps (a re-anchored track, not motion); ahead_s at most max_ahead_s.
struct PoseExtrapolationLimits {
  double max_ahead_s = 0.5;
  double max_span_s = 1.0;
  double max_speed_mps = 50.0;
};
Eigen::Isometry3d extrapolate_pose(const Eigen::Isometry3d& previous, double previous_s,
                                   const Eigen::Isometry3d& last, double last_s, double ahead_s,
                                   const PoseExtrapolationLimits& limits = {});
// The time extrapolate_pose moves `last` on by: ahead_s capped at max_ahead_s, or
// 0 where it keeps `last` (no motion to go by), so a stamp can say which.
double extrapolated_ahead_s(const Eigen::Isometry3d& previous, double previous_s,
                            const Eigen::Isometry3d& last, double last_s, double ahead_s,
                            const PoseExtrapolationLimits& limits = {});

}  // namespace zonemap
