// The pose buffer (one writer, lock-free readers): a reader never sees a torn
// sample and never sees time go back under a racing writer (ThreadSanitizer runs
// this file too: the tsan preset).
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <thread>

#include "zonemap/pose/pose_buffer.hpp"
#include "zonemap/pose/pose_track.hpp"

namespace zonemap {
namespace {

TEST(PoseBuffer, ReaderAlwaysSeesConsistentSamples) {
  PoseBuffer<16> buffer;
  constexpr int kSamples = 100000;
  std::atomic<bool> done{false};
  std::thread writer([&] {
    for (int i = 1; i <= kSamples; ++i) {
      const double t = i * 0.01;
      // Every field derived from t: a torn read would mix two samples.
      buffer.push(
          {t, Eigen::Vector3d(t, 2 * t, 3 * t),
           Eigen::Quaterniond(Eigen::AngleAxisd(std::fmod(t, 3.0), Eigen::Vector3d::UnitZ()))});
    }
    done.store(true, std::memory_order_release);
  });
  PoseTrack track(1.0, 0.1);
  track.reserve(16);
  std::int64_t snapshots = 0;
  double last_newest = -1.0;
  while (!done.load(std::memory_order_acquire) || snapshots < 10) {
    const double newest = buffer.snapshot(&track);
    ++snapshots;
    for (const PoseSample& s : track.samples()) {
      EXPECT_DOUBLE_EQ(s.position.x(), s.time_s);
      EXPECT_DOUBLE_EQ(s.position.z(), 3 * s.time_s);
      EXPECT_NEAR(Eigen::AngleAxisd(s.attitude).angle(), std::fmod(s.time_s, 3.0), 1e-9);
    }
    if (track.size() > 0) {
      EXPECT_GE(newest, last_newest) << "time never goes back";
      last_newest = newest;
    }
    if (HasFailure()) break;  // (the writer is joined below either way)
  }
  writer.join();
  EXPECT_EQ(buffer.count(), static_cast<std::uint64_t>(kSamples));
  buffer.snapshot(&track);
  EXPECT_EQ(track.size(), 15u) << "capacity minus one slot of slack";
  EXPECT_DOUBLE_EQ(track.samples().back().time_s, kSamples * 0.01);
}

}  // namespace
}  // namespace zonemap
