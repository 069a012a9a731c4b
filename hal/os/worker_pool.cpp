#include "hal/os/worker_pool.hpp"

#include <algorithm>
#include <chrono>
#include <string>

#include "hal/os/clock.hpp"

namespace zonemap::os {
namespace {

inline void cpu_relax() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#elif defined(__aarch64__)
  asm volatile("yield");
#endif
}

// Spins while `waiting()` for at most kSpinBeforeSleep; true when it still is.
// Bounded, so that a worker at SCHED_FIFO never starves its CPU's other threads
// for longer than that (see doorbell.hpp).
constexpr auto kSpinBeforeSleep = std::chrono::microseconds(40);
template <class Waiting>
bool spin_while(Waiting&& waiting) {
  const Clock::time_point until = Clock::now() + kSpinBeforeSleep;
  for (int i = 0;; ++i) {
    if (!waiting()) return false;
    cpu_relax();
    if ((i & 63) == 63 && Clock::now() >= until) return waiting();
  }
}

}  // namespace

WorkerPool::WorkerPool(const WorkerOptions& options)
    : parts_(std::max(1, options.parts)),
      workers_(std::make_unique<Task[]>(static_cast<std::size_t>(parts_ - 1))) {
  for (int part = 1; part < parts_; ++part) {
    const std::size_t slot = static_cast<std::size_t>(part);
    const std::string name = "zonemap-map-" + std::to_string(part);  // as `top -H` shows it
    TaskSettings settings;
    settings.name = name.c_str();
    settings.priority = options.priority;
    settings.cpu = slot - 1 < options.cpus.size() ? options.cpus[slot - 1] : -1;
    // Each worker has set itself up when start() returns: before the first job.
    Task& worker = workers_[slot - 1];
    worker.start(settings, [this, part] { work(part); });
    if (!worker.warning().empty()) warnings_.push_back(worker.warning());
  }
}

WorkerPool::~WorkerPool() {
  stopping_.store(true, std::memory_order_seq_cst);
  start_.ring();
  for (int w = 0; w + 1 < parts_; ++w) workers_[static_cast<std::size_t>(w)].join();
}

void WorkerPool::run(Job job, void* context) {
  if (parts_ == 1) {
    job(context, 0, 1);
    return;
  }
  job_ = job;
  context_ = context;
  running_.store(parts_ - 1, std::memory_order_seq_cst);
  round_.fetch_add(1, std::memory_order_seq_cst);  // publishes job_ and context_
  start_.ring();
  job(context, 0, parts_);
  spin_while([this] { return running_.load(std::memory_order_seq_cst) != 0; });
  for (;;) {
    const std::uint32_t ticket = done_.ticket();
    if (running_.load(std::memory_order_seq_cst) == 0) return;
    done_.wait(ticket);
  }
}

void WorkerPool::work(int part) {
  std::uint32_t seen = 0;
  for (;;) {
    const std::uint32_t ticket = start_.ticket();
    if (stopping_.load(std::memory_order_seq_cst)) return;
    const std::uint32_t round = round_.load(std::memory_order_seq_cst);
    if (round == seen) {
      // The next round of the same frame usually follows within microseconds:
      // a short look before sleeping saves a futex wake-up and a reschedule.
      if (spin_while([this, seen] {
            return round_.load(std::memory_order_seq_cst) == seen &&
                   !stopping_.load(std::memory_order_seq_cst);
          })) {
        start_.wait(ticket);
      }
      continue;
    }
    seen = round;
    AllocationCounts counted;
    {
      const AllocationScope scope;
      job_(context_, part, parts_);
      counted = scope.counted();
    }
    job_allocations_.fetch_add(counted.allocations, std::memory_order_relaxed);
    job_frees_.fetch_add(counted.frees, std::memory_order_relaxed);
    if (running_.fetch_sub(1, std::memory_order_seq_cst) == 1) done_.ring();
  }
}

}  // namespace zonemap::os
