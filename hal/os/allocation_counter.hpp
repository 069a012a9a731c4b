// Counts heap allocations made by the calling thread while counting is armed,
// through replacements of the global operator new/delete and of malloc, calloc,
// realloc, free and the aligned allocators (forwarded to glibc's __libc_*; under
// a sanitizer, which owns malloc, operator new/delete count instead). Linked (as
// an object library) into the executables that must prove "no allocation after
// init".
#pragma once

#include <cstdint>

namespace zonemap::os {

struct AllocationCounts {
  std::int64_t allocations = 0;
  std::int64_t frees = 0;
};

// Arms or disarms counting for the calling thread; returns the previous state.
bool arm_allocation_counting(bool armed);
AllocationCounts thread_allocation_counts();
void count_c_allocation();
void count_c_free();

// Counts what happens in the calling thread during its lifetime.
class AllocationScope {
 public:
  AllocationScope()
      : before_(thread_allocation_counts()), was_armed_(arm_allocation_counting(true)) {}
  ~AllocationScope() { arm_allocation_counting(was_armed_); }  // scopes nest
  AllocationScope(const AllocationScope&) = delete;
  AllocationScope& operator=(const AllocationScope&) = delete;
  AllocationCounts counted() const {
    const AllocationCounts now = thread_allocation_counts();
    return {now.allocations - before_.allocations, now.frees - before_.frees};
  }

 private:
  AllocationCounts before_;
  bool was_armed_;
};

}  // namespace zonemap::os
