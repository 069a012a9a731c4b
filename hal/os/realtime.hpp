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
// False, with what is missing in *missing, when this CPU lacks an instruction-set
// extension the build was compiled for (ZONEMAP_X86_LEVEL): checked at start-up
// so that an old x86 CPU gets a clear message instead of an illegal instruction.
bool cpu_runs_this_build(std::string* missing);
// Resident set size of this process in bytes (from /proc/self/statm), 0 if unknown.
long resident_bytes();

}  // namespace zonemap::os
