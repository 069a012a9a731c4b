// ExtractionSchedule: every live zone comes round about every
// extract_every_frames, one zone a frame at most.
#include <gtest/gtest.h>

#include <vector>

#include "zonemap/common/config.hpp"
#include "zonemap/features/extraction_schedule.hpp"

namespace zonemap {
namespace {

TEST(ExtractionSchedule, EachLiveZoneComesRoundOnceInEveryPeriod) {
  const int every = 40;  // a stride of every / kZonesHeld frames
  ExtractionSchedule schedule(every);
  const int live = kZonesHeld;
  std::vector<int> times(live, 0);
  int extractions = 0;
  for (int frame = 1; frame <= 10 * every; ++frame) {
    const int zone = schedule.after_frame(frame, live);
    if (zone < 0) continue;
    ASSERT_LT(zone, live);
    ++times[static_cast<std::size_t>(zone)];
    ++extractions;
  }
  EXPECT_EQ(extractions, 10 * every / (every / kZonesHeld)) << "one zone a stride, never more";
  for (int z = 0; z < live; ++z) EXPECT_EQ(times[static_cast<std::size_t>(z)], 10) << "zone " << z;
}

TEST(ExtractionSchedule, NoLiveZoneNothingToDoAndShortPeriodsEveryFrame) {
  ExtractionSchedule schedule(1);  // shorter than one zone a frame: every frame
  EXPECT_EQ(schedule.after_frame(1, 0), -1);
  int done = 0;
  for (int frame = 1; frame <= 9; ++frame) done += schedule.after_frame(frame, 3) >= 0 ? 1 : 0;
  EXPECT_EQ(done, 9);
}

}  // namespace
}  // namespace zonemap
