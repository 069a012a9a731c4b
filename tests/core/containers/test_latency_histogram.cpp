// LatencyHistogram: log-spaced bins, percentiles within one bin of the truth.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "zonemap/containers/latency_histogram.hpp"

namespace zonemap {
namespace {

// One bin is a twentieth of a decade: its upper edge lies at most this factor
// above any value in it.
const double kBinFactor = std::pow(10.0, 1.0 / 20.0);

TEST(LatencyHistogram, PercentilesLieWithinOneBinOfTheTrueQuantile) {
  LatencyHistogram h;
  for (int i = 1; i <= 1000; ++i) h.record(0.01 * i);  // 0.01 .. 10 ms
  EXPECT_EQ(h.count(), 1000u);
  for (const double q : {0.01, 0.5, 0.9, 0.99, 0.999}) {
    const double truth = 0.01 * std::ceil(q * 1000.0);
    const double got = h.percentile(q);
    EXPECT_GE(got, truth * (1.0 - 1e-9)) << "q " << q;
    EXPECT_LE(got, truth * kBinFactor) << "q " << q;
  }
  EXPECT_DOUBLE_EQ(h.percentile(1.0), 10.0) << "the top percentile is the largest sample";
  EXPECT_DOUBLE_EQ(h.max_ms(), 10.0);
}

TEST(LatencyHistogram, NeverAboveTheLargestSampleAndEmptyReadsZero) {
  LatencyHistogram empty;
  EXPECT_EQ(empty.percentile(0.5), 0.0);
  LatencyHistogram h;
  h.record(3.0);
  EXPECT_DOUBLE_EQ(h.percentile(0.5), 3.0) << "a bin's edge above the only sample is not reported";
  h.record(3.01);
  EXPECT_LE(h.percentile(0.999), 3.01);
}

TEST(LatencyHistogram, OddSamplesAreCountedWithoutBreakingIt) {
  LatencyHistogram h;
  h.record(-1.0);                                      // a clock that went back
  h.record(std::numeric_limits<double>::quiet_NaN());  // a broken stamp
  h.record(1e9);                                       // past the last bin
  h.record(2.0);
  EXPECT_EQ(h.count(), 4u);
  EXPECT_DOUBLE_EQ(h.max_ms(), 1e9) << "NaN leaves the maximum alone";
  EXPECT_EQ(h.bin_count(0), 2u) << "negative and NaN: the first bin";
  EXPECT_EQ(h.bin_count(LatencyHistogram::kBins - 1), 1u);
  EXPECT_EQ(h.count_above(1.0), 2u);  // 2 ms and 1e9 ms
  EXPECT_EQ(h.count_above(5.0), 1u);
}

}  // namespace
}  // namespace zonemap
