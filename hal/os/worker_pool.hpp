// The board's cores for the mapping step: a fixed set of worker threads started
// once, each running its part of every job the mapping thread hands out
// (zonemap::WorkSplit). The mapping thread runs part 0 itself, then waits for
// the others. Both sides look for what they wait for during a bounded 40 µs
// before they sleep on a doorbell: a frame hands out several jobs within
// milliseconds, and a futex wake-up costs tens of microseconds on a busy core.
// No lock and no allocation per job.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "hal/os/allocation_counter.hpp"
#include "hal/os/doorbell.hpp"
#include "hal/os/task.hpp"
#include "zonemap/common/work_split.hpp"

namespace zonemap::os {

struct WorkerOptions {
  int parts = 1;          // the mapping thread and parts - 1 workers
  int priority = 0;       // SCHED_FIFO 1..99 for the workers; 0 = normal
  std::vector<int> cpus;  // worker w pinned to cpus[w - 1] when given; -1 = any
};

class WorkerPool final : public WorkSplit {
 public:
  explicit WorkerPool(const WorkerOptions& options);
  ~WorkerPool() override;
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  int parts() const override { return parts_; }
  void run(Job job, void* context) override;
  // Real-time settings a worker could not take (no CAP_SYS_NICE, no such CPU).
  const std::vector<std::string>& warnings() const { return warnings_; }
  // Heap allocations and frees the workers made inside jobs so far (part 0 runs
  // on the caller's thread and counts there). Read between jobs.
  AllocationCounts job_allocations() const {
    return {job_allocations_.load(std::memory_order_relaxed),
            job_frees_.load(std::memory_order_relaxed)};
  }

 private:
  void work(int part);

  int parts_;
  std::unique_ptr<Task[]> workers_;  // part w on workers_[w - 1]
  std::vector<std::string> warnings_;
  // The job of the current round; written before `round_` is published.
  Job job_ = nullptr;
  void* context_ = nullptr;
  std::atomic<std::uint32_t> round_{0};
  std::atomic<int> running_{0};  // workers still in this round's job
  std::atomic<bool> stopping_{false};
  std::atomic<std::int64_t> job_allocations_{0}, job_frees_{0};
  Doorbell start_;  // the workers sleep here between rounds
  Doorbell done_;   // the mapping thread, while the workers finish
};

}  // namespace zonemap::os
