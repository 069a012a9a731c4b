// Where a pipeline thread sleeps while it has no work, instead of spinning. The
// threads that give it work (a frame, a job, room in a full queue) ring its bell
// after they push or pop: an atomic increment, plus a futex wake only when the
// owner sleeps. The owner takes a ticket, looks at its queues once more and
// sleeps only while no ring came after the ticket, so no ring is lost. No lock:
// a ringing thread never waits, whatever the priorities.
//
// Why not yield in a loop: a thread at SCHED_FIFO priority that spins starves
// every lower-priority thread on its CPU (the INS thread it waits for, say), and
// the kernel's real-time throttling then stops it for 50 ms in every second.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>

namespace zonemap::os {

class Doorbell {
 public:
  // The number of rings so far; take it before the last look at the queues.
  std::uint32_t ticket() const { return rings_.load(std::memory_order_seq_cst); }
  void ring();
  // Sleeps until there has been a ring after `ticket` (at once if there was).
  void wait(std::uint32_t ticket);
  // As wait(), but not past `deadline`: false when it passed without a ring.
  bool wait_until(std::uint32_t ticket, std::chrono::steady_clock::time_point deadline);
  // A thread is inside wait() / wait_until() (for tests).
  bool has_sleeper() const { return sleepers_.load(std::memory_order_seq_cst) != 0; }

 private:
  std::atomic<std::uint32_t> rings_{0};
  std::atomic<std::uint32_t> sleepers_{0};
};

}  // namespace zonemap::os
