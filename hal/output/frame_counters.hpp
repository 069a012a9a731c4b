// The frame and output counters every report shares, under one name each:
// stats.json (RunStats), the health message (HealthSnapshot) and the runtime's
// figures (runtime::PipelineStats) are each a FrameCounters plus their own.
// Counts only (no timings), so adding two runs' or two threads' is `+=`.
#pragma once

#include <cstdint>

namespace zonemap::hal {

struct FrameCounters {
  std::int64_t frames_in = 0;
  std::int64_t frames_mapped = 0;
  std::int64_t frames_rejected = 0;         // unreadable, corrupt, bad pose
  std::int64_t frames_skipped_no_pose = 0;  // no pose within tolerance (after waiting)
  // Sampled measurements mostly under the environment's bottom face: the ground
  // lies out of the map's reach.
  std::int64_t frames_ground_below_environment = 0;
  std::int64_t dropped_mapper_behind = 0;  // newest wins: older waiting frames dropped
  std::int64_t dropped_pool_full = 0;      // no free frame slot: the new frame dropped
  std::int64_t pose_waits = 0;             // frames that had to wait for their pose
  std::int64_t outputs_published = 0;
  std::int64_t outputs_skipped = 0;  // the output stage still held every buffer
  std::int64_t deadline_misses = 0;  // end-to-end latency over the frame period
  std::int64_t heap_allocations_after_init = 0;
  std::int64_t heap_frees_after_init = 0;

  std::int64_t frames_dropped() const { return dropped_mapper_behind + dropped_pool_full; }
  FrameCounters& operator+=(const FrameCounters& o) {
    frames_in += o.frames_in;
    frames_mapped += o.frames_mapped;
    frames_rejected += o.frames_rejected;
    frames_skipped_no_pose += o.frames_skipped_no_pose;
    frames_ground_below_environment += o.frames_ground_below_environment;
    dropped_mapper_behind += o.dropped_mapper_behind;
    dropped_pool_full += o.dropped_pool_full;
    pose_waits += o.pose_waits;
    outputs_published += o.outputs_published;
    outputs_skipped += o.outputs_skipped;
    deadline_misses += o.deadline_misses;
    heap_allocations_after_init += o.heap_allocations_after_init;
    heap_frees_after_init += o.heap_frees_after_init;
    return *this;
  }
};

}  // namespace zonemap::hal
