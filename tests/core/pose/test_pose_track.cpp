// PoseTrack: interpolation within gaps, refusal beyond them.
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

}  // namespace
}  // namespace zonemap
