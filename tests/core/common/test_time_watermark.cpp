// TimeWatermark: one stamp far off costs only itself; a step that persists is adopted.
#include <gtest/gtest.h>

#include <cmath>

#include "zonemap/common/time_watermark.hpp"

namespace zonemap {
namespace {

TEST(TimeWatermark, ALoneStampFarOffCostsOnlyItself) {
  for (const double bad : {999999.0, -5.0, 0.35, double(NAN)}) {
    TimeWatermark mark;
    int refused = 0;
    for (int i = 0; i < 20; ++i) {
      const double t = i == 10 ? bad : 0.1 * i;
      refused += accepted(mark.offer(t)) ? 0 : 1;
    }
    EXPECT_EQ(refused, 1) << "bad stamp " << bad;
    EXPECT_EQ(mark.steps_adopted(), 0);
    EXPECT_DOUBLE_EQ(mark.newest(), 1.9);
  }
  TimeWatermark mark;
  EXPECT_EQ(mark.offer(1.0), TimeVerdict::kAccepted);
  EXPECT_EQ(mark.offer(1.0), TimeVerdict::kRepeated);
  EXPECT_EQ(mark.offer(0.5), TimeVerdict::kPast);
  EXPECT_EQ(mark.offer(9.0), TimeVerdict::kFuture);
  EXPECT_EQ(mark.offer(INFINITY), TimeVerdict::kNotFinite);
  EXPECT_EQ(mark.offer(1.1), TimeVerdict::kAccepted);
}

TEST(TimeWatermark, AStepThatPersistsIsAdoptedAfterConfirmValues) {
  TimeWatermarkConfig config;
  config.confirm_values = 3;
  TimeWatermark mark(config);
  for (int i = 0; i < 10; ++i) ASSERT_TRUE(accepted(mark.offer(0.1 * i)));
  // The clock jumps 100 s ahead and stays there: two refused, the third adopted.
  EXPECT_EQ(mark.offer(100.0), TimeVerdict::kFuture);
  EXPECT_EQ(mark.offer(100.1), TimeVerdict::kFuture);
  EXPECT_EQ(mark.offer(100.2), TimeVerdict::kAdopted);
  EXPECT_EQ(mark.adopted_run_length(), 3);
  EXPECT_EQ(mark.offer(100.3), TimeVerdict::kAccepted);
  EXPECT_EQ(mark.steps_adopted(), 1);
  // A live clock that goes back (re-initialised) likewise.
  EXPECT_EQ(mark.offer(3.0), TimeVerdict::kPast);
  EXPECT_EQ(mark.offer(3.1), TimeVerdict::kPast);
  EXPECT_EQ(mark.offer(3.2), TimeVerdict::kAdopted);
  EXPECT_EQ(mark.steps_adopted(), 2);
  // Two outliers that do not continue each other never add up to a step.
  EXPECT_EQ(mark.offer(500.0), TimeVerdict::kFuture);
  EXPECT_EQ(mark.offer(900.0), TimeVerdict::kFuture);
  EXPECT_EQ(mark.offer(3.3), TimeVerdict::kAccepted);
  EXPECT_EQ(mark.offer(700.0), TimeVerdict::kFuture);
  EXPECT_EQ(mark.offer(3.4), TimeVerdict::kAccepted);
  EXPECT_EQ(mark.steps_adopted(), 2);
}

TEST(TimeWatermark, AListTakesAForwardStepWholeAndNeverAdoptsAClockGoingBack) {
  const double forward[] = {0.0, 0.1, 0.2, 50.0, 50.1, 50.2, 50.3, 0.3, 50.4};
  TimeVerdict v[9];
  filter_time_list(forward, 9, {2.0, 3, false}, v);
  for (int i = 0; i < 7; ++i) EXPECT_TRUE(accepted(v[i])) << i;  // nothing lost to the step
  EXPECT_EQ(v[7], TimeVerdict::kPast);                           // a lone stamp from before it
  EXPECT_TRUE(accepted(v[8]));
  const double back[] = {10.0, 10.1, 10.2, 1.0, 1.1, 1.2, 1.3};
  filter_time_list(back, 7, {2.0, 3, false}, v);
  for (int i = 3; i < 7; ++i) EXPECT_EQ(v[i], TimeVerdict::kPast) << i;
}

}  // namespace
}  // namespace zonemap
