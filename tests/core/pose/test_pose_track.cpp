// PoseTrack: interpolation within gaps, refusal beyond them; a pose extrapolated
// a moment past the newest.
#include <gtest/gtest.h>

#include <cmath>

#include <Eigen/Geometry>

#include "zonemap/pose/pose_track.hpp"

namespace zonemap {
namespace {

TEST(PoseTrack, InterpolatesWithinGapsAndRefusesBeyondTolerance) {
  PoseTrack track(0.5, 0.05);
  const Eigen::Quaterniond a = Eigen::Quaterniond::Identity();
  const Eigen::Quaterniond b(Eigen::AngleAxisd(1.0, Eigen::Vector3d::UnitZ()));
  ASSERT_TRUE(track.append({1.0, {0, 0, 0}, a}));
  ASSERT_TRUE(track.append({1.4, {4, 0, 0}, b}));
  ASSERT_TRUE(track.append({3.0, {8, 0, 0}, b}));  // a 1.6 s gap follows 1.4
  Eigen::Isometry3d pose;
  ASSERT_EQ(track.lookup(1.1, &pose), PoseLookup::kInterpolated);
  EXPECT_NEAR(pose.translation().x(), 1.0, 1e-9);
  EXPECT_NEAR(Eigen::AngleAxisd(pose.linear()).angle(), 0.25, 1e-9) << "slerp";
  EXPECT_EQ(track.lookup(2.0, &pose), PoseLookup::kNoPose) << "inside a gap longer than max_gap";
  EXPECT_EQ(track.lookup(1.43, &pose), PoseLookup::kNearest) << "near a sample across the gap";
  EXPECT_EQ(track.lookup(0.97, &pose), PoseLookup::kNearest);
  EXPECT_EQ(track.lookup(0.9, &pose), PoseLookup::kNoPose) << "before the first sample";
  EXPECT_EQ(track.lookup(3.2, &pose), PoseLookup::kNoPose) << "after the last sample";
  EXPECT_EQ(track.lookup(std::nan(""), &pose), PoseLookup::kNoPose);
}

Eigen::Isometry3d pose_at(double x, double yaw_rad) {
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  p.translation() = Eigen::Vector3d(x, 0, 10);
  return p;
}

double yaw_of(const Eigen::Isometry3d& p) {
  return std::atan2(p.linear()(1, 0), p.linear()(0, 0));
}

TEST(PoseExtrapolation, MovesOnAsTheLastTwoPosesMovedWithinItsLimits) {
  // 4 m/s along x, turning 0.3 rad/s: 0.1 s apart.
  const Eigen::Isometry3d previous = pose_at(0.0, 0.0), last = pose_at(0.4, 0.03);
  const Eigen::Isometry3d on = extrapolate_pose(previous, 5.0, last, 5.1, 0.3);
  EXPECT_NEAR(on.translation().x(), 1.6, 1e-9);
  EXPECT_NEAR(on.translation().z(), 10.0, 1e-9);
  EXPECT_NEAR(yaw_of(on), 0.12, 1e-9);
  // Never more than max_ahead_s (0.5 s) ahead.
  EXPECT_NEAR(extrapolate_pose(previous, 5.0, last, 5.1, 3.0).translation().x(), 2.4, 1e-9);
  // Otherwise the last pose as it is: nothing ahead, no previous pose (or one
  // out of order, or too long before), a jump faster than max_speed_mps.
  const auto unmoved = [&](const Eigen::Isometry3d& p) {
    return p.isApprox(last) && p.translation().isApprox(last.translation());
  };
  EXPECT_TRUE(unmoved(extrapolate_pose(previous, 5.0, last, 5.1, 0.0)));
  EXPECT_TRUE(unmoved(extrapolate_pose(previous, 5.0, last, 5.1, -0.2)));
  EXPECT_TRUE(unmoved(extrapolate_pose(previous, 5.0, last, 5.1, std::nan(""))));
  EXPECT_TRUE(unmoved(extrapolate_pose(previous, -1e300, last, 5.1, 0.3)));
  EXPECT_TRUE(unmoved(extrapolate_pose(previous, 5.2, last, 5.1, 0.3)));
  EXPECT_TRUE(unmoved(extrapolate_pose(previous, 3.0, last, 5.1, 0.3)));
  EXPECT_TRUE(unmoved(extrapolate_pose(pose_at(-100.0, 0.0), 5.0, last, 5.1, 0.3)));
}

// The time a pose was moved on by, as extrapolate_pose moved it: 0 where it kept it.
TEST(PoseExtrapolation, SaysHowFarAheadItMoved) {
  const Eigen::Isometry3d previous = pose_at(0.0, 0.0), last = pose_at(0.4, 0.03);
  EXPECT_DOUBLE_EQ(extrapolated_ahead_s(previous, 5.0, last, 5.1, 0.3), 0.3);
  EXPECT_DOUBLE_EQ(extrapolated_ahead_s(previous, 5.0, last, 5.1, 3.0), 0.5);
  EXPECT_EQ(extrapolated_ahead_s(previous, 3.0, last, 5.1, 0.3), 0.0);
  EXPECT_EQ(extrapolated_ahead_s(pose_at(-100.0, 0.0), 5.0, last, 5.1, 0.3), 0.0);
  EXPECT_EQ(extrapolated_ahead_s(previous, 5.0, last, 5.1, std::nan("")), 0.0);
}

}  // namespace
}  // namespace zonemap
