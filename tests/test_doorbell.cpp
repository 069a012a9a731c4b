// The doorbell the pipeline's threads sleep on (hal/os): no ring lost, a
// deadline kept, a waiter asleep in the kernel, and the queue waits built on it.
#include <gtest/gtest.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <string>
#include <thread>

#include "core/core_test_support.hpp"
#include "hal/os/doorbell.hpp"
#include "zonemap/containers/spsc_queue.hpp"

namespace zonemap {
namespace {

using testing::jitter;

TEST(Doorbell, ARingBeforeTheWaitIsNotLost) {
  os::Doorbell bell;
  const std::uint32_t ticket = bell.ticket();
  bell.ring();
  bell.wait(ticket);  // returns at once (a lost ring would hang here)
  EXPECT_NE(bell.ticket(), ticket);
  EXPECT_FALSE(bell.has_sleeper());
}

TEST(Doorbell, WaitUntilGivesUpAtItsDeadlineAndNotBeforeARing) {
  os::Doorbell bell;
  const auto now = std::chrono::steady_clock::now();
  EXPECT_FALSE(bell.wait_until(bell.ticket(), now - std::chrono::milliseconds(1)));
  const auto start = std::chrono::steady_clock::now();
  EXPECT_FALSE(bell.wait_until(bell.ticket(), start + std::chrono::milliseconds(20)));
  EXPECT_GE(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(20));
  const std::uint32_t ticket = bell.ticket();
  bell.ring();
  EXPECT_TRUE(bell.wait_until(ticket, std::chrono::steady_clock::now() + std::chrono::hours(1)));
}

// The pipeline's waiting: consumer and producer sleep on their own bells (the
// producer when the queue is full), ring the other's after each push / pop.
TEST(Doorbell, QueueWaitersSleepAndMissNoRing) {
  constexpr std::uint64_t kItems = 100000;
  SpscQueue<std::uint64_t, 16> q;
  os::Doorbell producer_bell, consumer_bell;
  std::atomic<std::uint64_t> producer_sleeps{0};
  std::thread producer([&] {
    testing::Lcg rng(3);
    for (std::uint64_t i = 1; i <= kItems; ++i) {
      while (!q.push(i)) {
        const std::uint32_t ticket = producer_bell.ticket();
        if (q.push(i)) break;
        producer_sleeps.fetch_add(1, std::memory_order_relaxed);
        producer_bell.wait(ticket);
      }
      consumer_bell.ring();
      if ((i & 1023) == 0) jitter(rng, 20000);
    }
  });
  testing::Lcg rng(4);
  std::uint64_t expected = 1, v = 0, consumer_sleeps = 0;
  while (expected <= kItems) {
    if (!q.pop(&v)) {
      const std::uint32_t ticket = consumer_bell.ticket();
      if (!q.pop(&v)) {
        ++consumer_sleeps;
        consumer_bell.wait(ticket);
        continue;
      }
    }
    producer_bell.ring();
    ASSERT_EQ(v, expected) << "order";
    ++expected;
    if ((expected & 511) == 0) jitter(rng, 20000);
  }
  producer.join();
  EXPECT_FALSE(q.pop(&v)) << "nothing extra";
  std::printf("[ doorbell ] %llu items, consumer slept %llu times, producer %llu\n",
              static_cast<unsigned long long>(kItems),
              static_cast<unsigned long long>(consumer_sleeps),
              static_cast<unsigned long long>(producer_sleeps.load()));
}

// A waiting thread is asleep in the kernel (state S), not spinning (state R).
TEST(Doorbell, AWaitingThreadSleepsInTheKernel) {
  os::Doorbell bell;
  std::atomic<long> waiter_tid{0};
  const std::uint32_t ticket = bell.ticket();
  std::thread waiter([&] {
    waiter_tid.store(static_cast<long>(syscall(SYS_gettid)));
    bell.wait(ticket);
  });
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  char state = '?';
  while (std::chrono::steady_clock::now() < give_up) {
    if (waiter_tid.load() == 0 || !bell.has_sleeper()) continue;
    std::ifstream stat("/proc/self/task/" + std::to_string(waiter_tid.load()) + "/stat");
    std::string line;
    std::getline(stat, line);
    const std::size_t paren = line.rfind(')');  // "tid (name) S ..."
    if (paren != std::string::npos && paren + 2 < line.size()) state = line[paren + 2];
    if (state == 'S') break;
  }
  bell.ring();
  waiter.join();
  EXPECT_EQ(state, 'S') << "the waiter should sleep in futex, not run";
}

}  // namespace
}  // namespace zonemap
