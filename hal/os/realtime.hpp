// Real-time set-up on Linux: lock memory, scheduling class, CPU affinity. When
// not permitted (no privileges), a clear warning and the run goes on.
#pragma once

#include <string>

namespace zonemap::os {

// mlockall(MCL_CURRENT | MCL_FUTURE). False with the reason in *warning.
bool lock_memory(std::string* warning);
// For the calling thread: SCHED_FIFO at `priority` (1..99; 0 leaves the policy
// alone) and pinned to `cpu` (-1 leaves affinity alone).
bool set_thread_realtime(int priority, int cpu, std::string* warning);
// Resident set size of this process in bytes (from /proc/self/statm), 0 if unknown.
long resident_bytes();

}  // namespace zonemap::os
