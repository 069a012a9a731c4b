// The INS plausibility gate: every implausible solution refused and counted by
// kind, silence and re-anchoring, the camera pose through the mount.
#include <gtest/gtest.h>

#include <cmath>

#include "core_test_support.hpp"
#include "zonemap/pose/ins_gate.hpp"

using namespace zonemap;

namespace {

using zonemap::testing::valid_at;

}  // namespace

TEST(InsGate, RefusesEveryImplausibleSolutionAndCountsWhy) {
  InsGate gate;
  InsRejection why{};
  EXPECT_TRUE(gate.check(valid_at(1.0, {0, 0, -50}), &why));
  InsSolution nan = valid_at(1.01, {0, 0, -50});
  nan.position_m.x() = std::nan("");
  EXPECT_FALSE(gate.check(nan, &why));
  EXPECT_EQ(why, InsRejection::kNotFinite);
  InsSolution bad_q = valid_at(1.01, {0, 0, -50});
  bad_q.attitude.coeffs() *= 1.5;
  EXPECT_FALSE(gate.check(bad_q, &why));
  EXPECT_EQ(why, InsRejection::kBadQuaternion);
  InsSolution invalid = valid_at(1.01, {0, 0, -50});
  invalid.position_valid = false;
  EXPECT_FALSE(gate.check(invalid, &why));
  EXPECT_EQ(why, InsRejection::kFlagsInvalid);
  InsSolution vague = valid_at(1.01, {0, 0, -50});
  vague.position_sigma_m = 12.0;
  EXPECT_FALSE(gate.check(vague, &why));
  EXPECT_EQ(why, InsRejection::kInaccurate);
  EXPECT_FALSE(gate.check(valid_at(0.99, {0, 0, -50}), &why));
  EXPECT_EQ(why, InsRejection::kTimeNotIncreasing);
  EXPECT_FALSE(gate.check(valid_at(1.0, {0, 0, -50}), &why));
  // A 100 m jump in 10 ms.
  EXPECT_FALSE(gate.check(valid_at(1.01, {100, 0, -50}), &why));
  EXPECT_EQ(why, InsRejection::kJump);
  // Normal flight goes on.
  EXPECT_TRUE(gate.check(valid_at(1.02, {0.5, 0, -50}), &why));
  const InsGateCounters& c = gate.counters();
  EXPECT_EQ(c.accepted, 2);
  EXPECT_EQ(c.rejected_total(), 7);
  EXPECT_EQ(c.rejected[static_cast<int>(InsRejection::kTimeNotIncreasing)], 2);
}

TEST(InsGate, SilenceThenResumeIsNotAJumpAndAPersistentJumpReanchors) {
  InsGate gate;
  InsRejection why{};
  ASSERT_TRUE(gate.check(valid_at(0.0, {0, 0, 0}), &why));
  // INS silent for 2 s while flying 20 m/s: 40 m further is plausible.
  EXPECT_TRUE(gate.check(valid_at(2.0, {40, 0, 0}), &why));
  // A jump of 100 m that persists (GNSS re-acquired): refused for 1 s, then taken.
  int refused = 0;
  bool taken = false;
  for (int i = 1; i <= 150 && !taken; ++i) {
    const double t = 2.0 + i * 0.01;
    taken = gate.check(valid_at(t, {140 + 0.2 * i, 0, 0}), &why);
    if (!taken) ++refused;
  }
  EXPECT_TRUE(taken);
  EXPECT_GE(refused, 99);
  EXPECT_LE(refused, 101);
  EXPECT_EQ(gate.counters().reanchors, 1);
}

TEST(InsGate, CameraPoseFollowsTheMount) {
  InsSolution s = valid_at(1.0, {10, 20, -30});
  s.attitude = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ());  // heading east
  Eigen::Isometry3d body_T_camera = Eigen::Isometry3d::Identity();
  body_T_camera.translation() = Eigen::Vector3d(1.0, 0.0, 0.5);  // 1 m ahead, 0.5 m below
  const PoseSample p = camera_pose_sample(s, body_T_camera);
  EXPECT_LT((p.position - Eigen::Vector3d(10, 21, -29.5)).norm(), 1e-12);
}
