// The lock-free single-producer single-consumer queue: FIFO, full and empty in
// one thread, and order with nothing lost under a racing producer (ThreadSanitizer
// runs this file too: the tsan preset).
#include <gtest/gtest.h>

#include <atomic>
#include <cstdio>
#include <thread>

#include "core_test_support.hpp"
#include "zonemap/containers/spsc_queue.hpp"

namespace zonemap {
namespace {

using testing::jitter;

TEST(SpscQueue, FifoFullAndEmptyInOneThread) {
  SpscQueue<std::uint32_t, 4> q;
  std::uint32_t v = 0;
  EXPECT_FALSE(q.pop(&v));
  for (std::uint32_t i = 0; i < 4; ++i) EXPECT_TRUE(q.push(i));
  EXPECT_FALSE(q.push(99)) << "full";
  for (std::uint32_t i = 0; i < 4; ++i) {
    ASSERT_TRUE(q.pop(&v));
    EXPECT_EQ(v, i);
  }
  EXPECT_FALSE(q.pop(&v));
  // Wrap around many times.
  for (std::uint32_t i = 0; i < 1000; ++i) {
    ASSERT_TRUE(q.push(i));
    ASSERT_TRUE(q.pop(&v));
    ASSERT_EQ(v, i);
  }
}

TEST(SpscQueue, StressKeepsOrderAndLosesNothing) {
  constexpr std::uint64_t kItems = 200000;
  SpscQueue<std::uint64_t, 64> q;
  std::uint64_t full_retries = 0;
  std::thread producer([&] {
    testing::Lcg rng(1);
    for (std::uint64_t i = 1; i <= kItems; ++i) {
      while (!q.push(i)) ++full_retries;
      if ((i & 255) == 0) jitter(rng, 2000);
    }
  });
  testing::Lcg rng(2);
  std::uint64_t expected = 1, v = 0;
  while (expected <= kItems) {
    if (!q.pop(&v)) continue;
    ASSERT_EQ(v, expected) << "order";
    ++expected;
    if ((expected & 127) == 0) jitter(rng, 4000);
  }
  producer.join();
  EXPECT_FALSE(q.pop(&v)) << "nothing extra";
  std::printf("[ spsc ] %llu items, producer found it full %llu times\n",
              static_cast<unsigned long long>(kItems),
              static_cast<unsigned long long>(full_retries));
}

}  // namespace
}  // namespace zonemap
