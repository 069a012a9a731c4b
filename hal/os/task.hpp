// A thread of the program, as F Prime's Os::Task has it: started with a name,
// a scheduling priority and a CPU, joined once. Every thread zonemap runs is
// started through here (Layers.ThreadsStartOnlyThroughTask says so), so that
// each carries a name in `top -H` and the kernel's logs, takes its real-time
// settings before it does any work, and reports a refusal the same way.
#pragma once

#include <functional>
#include <string>
#include <thread>

namespace zonemap::os {

struct TaskSettings {
  const char* name = "zonemap";  // at most 15 characters reach the kernel
  int priority = 0;              // SCHED_FIFO 1..99; 0 = the normal policy
  int cpu = -1;                  // pinned to this CPU; -1 = any
};

class Task {
 public:
  Task() = default;
  ~Task() { join(); }
  Task(const Task&) = delete;
  Task& operator=(const Task&) = delete;

  // Runs `body` on a new thread. Returns once the thread has named itself and
  // taken its settings, so warning() is already what it will be. Start-up only:
  // it allocates.
  void start(const TaskSettings& settings, std::function<void()> body);
  // Waits for the body to return; nothing when not started or already joined.
  void join();
  bool started() const { return thread_.joinable(); }
  // Why the real-time settings were refused (no CAP_SYS_NICE, no such CPU),
  // prefixed with the task's name; empty when they were taken.
  const std::string& warning() const { return warning_; }

 private:
  std::thread thread_;
  std::string warning_;
};

}  // namespace zonemap::os
