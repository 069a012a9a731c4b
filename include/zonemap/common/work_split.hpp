// How the mapping step shares its work among threads without knowing them: the
// core splits a step into parts that write disjoint cells, and a WorkSplit runs
// them (hal/os/worker_pool.hpp on the board's cores; inline, one part, when no
// split is given). The result never depends on the number of parts.
#pragma once

#include <type_traits>

namespace zonemap {

class WorkSplit {
 public:
  using Job = void (*)(void* context, int part, int parts);
  virtual ~WorkSplit() = default;
  virtual int parts() const = 0;
  // Calls job(context, p, parts()) once for every p in [0, parts()), possibly at
  // the same time on other threads, and returns when all of them have returned.
  // Allocation-free.
  virtual void run(Job job, void* context) = 0;
};

// Runs job on `parts` parts: inline, as the one part, when there is one (or no
// split); else on the split (the job returns at once for parts past `parts`).
inline void run_parts(WorkSplit* split, int parts, WorkSplit::Job job, void* context) {
  if (split == nullptr || parts <= 1) {
    job(context, 0, 1);
    return;
  }
  split->run(job, context);
}

// Calls part(p, parts) for every p in [0, parts) through run_parts: the part
// is a lambda that takes what it needs by reference (it stays on the caller's
// stack: nothing is allocated), in place of a context struct and a job
// function at every caller.
template <class Part>
void for_each_part(WorkSplit* split, int parts, Part&& part) {
  using Callable = std::remove_reference_t<Part>;
  struct Context {
    Callable* part;
    int parts;
  } context{&part, parts};
  const WorkSplit::Job job = [](void* c, int p, int) {
    const Context& x = *static_cast<const Context*>(c);
    if (p < x.parts) (*x.part)(p, x.parts);
  };
  run_parts(split, parts, job, &context);
}

// A part's share of `count` rows, interleaved (rows part, part + parts, ...) so
// that each part gets near and far rows alike.
struct RowShare {
  int first = 0;
  int step = 1;
};
constexpr RowShare share_of(int part, int parts) {
  return RowShare{part, parts};
}

}  // namespace zonemap
