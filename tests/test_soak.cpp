// The short soak (the 30-minute one is `zonemap-soak`): a looped flight through
// the threaded pipeline with a live INS thread; memory flat, no allocation, every
// frame accounted for, the feature store not growing lap after lap.
#include <gtest/gtest.h>

#include "tools/soak/soak.hpp"

namespace zonemap {

TEST(Soak, ShortLoopedFlightKeepsMemoryFlatAndTheStoreBounded) {
  soak::SoakOptions options;
  options.rate_hz = 0.0;  // as fast as the mapper goes, lossless
  options.width = 320;
  options.pixel_step = 2;
  options.max_loop_frames = 60;
  options.health_period_s = 0.0;
  std::string error;
  soak::SoakResult two_laps, five_laps;
  options.frames = 120;
  ASSERT_TRUE(soak::run_soak(options, &two_laps, &error)) << error;
  options.frames = 300;
  ASSERT_TRUE(soak::run_soak(options, &five_laps, &error)) << error;
  const runtime::PipelineStats& s = five_laps.stats;
  EXPECT_EQ(s.frames_in, 300);
  EXPECT_EQ(s.frames_mapped, 300);
  EXPECT_EQ(s.mapping_thread_allocations + s.output_thread_allocations + s.ins_thread_allocations +
                s.extraction_thread_allocations,
            0);
  EXPECT_EQ(s.mapping_thread_frees + s.output_thread_frees + s.ins_thread_frees +
                s.extraction_thread_frees,
            0);
  // Resident memory: flat once every code path has run (after the first two laps)
  // within 1 MiB; from start-up within 4 MiB (under qemu-user the emulator's
  // translation cache grows in the same process while new code first runs).
  EXPECT_LT(s.rss_at_end - s.rss_after_start, 4 << 20)
      << s.rss_after_start << " -> " << s.rss_at_end;
  const soak::SoakSample* warm = nullptr;
  for (const soak::SoakSample& x : five_laps.samples) {
    if (warm == nullptr && x.frames_in >= 120) warm = &x;
  }
  ASSERT_NE(warm, nullptr);
  EXPECT_LT(five_laps.samples.back().rss_bytes - warm->rss_bytes, 1 << 20)
      << warm->rss_bytes << " -> " << five_laps.samples.back().rss_bytes;
  // The same places again and again: no new objects after the first laps.
  EXPECT_LE(five_laps.features_at_end, two_laps.features_at_end + 1);
  EXPECT_GT(five_laps.features_at_end, 0);
  // Health came all along, with consistent counters.
  ASSERT_GE(five_laps.samples.size(), 10u);
  for (std::size_t i = 1; i < five_laps.samples.size(); ++i) {
    EXPECT_GE(five_laps.samples[i].frames_mapped, five_laps.samples[i - 1].frames_mapped);
    EXPECT_EQ(five_laps.samples[i].allocations, 0);
  }
}

}  // namespace zonemap
