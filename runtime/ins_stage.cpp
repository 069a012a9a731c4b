// Poses: a live source polled on the INS thread into the lock-free pose buffer,
// and, on the mapping thread, the pose of a frame's time — waited for a bounded
// time when it is late, never longer.
#include "runtime/pipeline_impl.hpp"

namespace zonemap::runtime {
namespace {

struct BufferSink final : hal::PoseSink {
  PoseBuffer<512>* buffer = nullptr;
  os::Doorbell* mapping_bell = nullptr;
  void push(const PoseSample& p) override {
    buffer->push(p);
    mapping_bell->ring();  // a mapper waiting for this pose looks again
  }
};

}  // namespace

void SharedInsCounters::store(const hal::PoseSourceCounters& c) {
  messages.store(c.messages, std::memory_order_relaxed);
  malformed.store(c.malformed, std::memory_order_relaxed);
  solutions.store(c.solutions, std::memory_order_relaxed);
  poses_out.store(c.poses_out, std::memory_order_relaxed);
  link_errors.store(c.link_errors, std::memory_order_relaxed);
  rejected.store(c.gate.rejected_total(), std::memory_order_relaxed);
  reanchors.store(c.gate.reanchors, std::memory_order_relaxed);
}

void Pipeline::Impl::ins() {
  PipelineStats& s = ins_stats;
  realtime(options.priority_ins, options.cpu_ins, &s, "ins");
  BufferSink sink;
  sink.buffer = &poses;
  sink.mapping_bell = &mapping_bell;
  os::AllocationScope scope;
  while (!mapping_done.load(std::memory_order_acquire)) {
    const hal::PollResult r = live_poses->poll(sink, 20);
    ins_counters.store(live_poses->counters());
    if (r == hal::PollResult::kEnd) break;
  }
  const os::AllocationCounts counted = scope.counted();
  s.ins_thread_allocations = counted.allocations;
  s.ins_thread_frees = counted.frees;
}

bool Pipeline::Impl::pose_for(double time_s, Eigen::Isometry3d* pose, PipelineStats* s) {
  double newest = poses.snapshot(&mapping_track);
  if (mapping_track.lookup(time_s, pose) != PoseLookup::kNoPose) return true;
  if (newest >= time_s) return false;  // the poses are there, none fits
  // The pose is late: wait a bounded time for it, then give up on the frame.
  ++s->pose_waits;
  const Clock::time_point deadline = os::after_seconds(options.pose_wait_s);
  while (true) {
    const std::uint32_t ticket = mapping_bell.ticket();
    newest = poses.snapshot(&mapping_track);
    if (mapping_track.lookup(time_s, pose) != PoseLookup::kNoPose) return true;
    if (newest >= time_s) return false;
    if (!mapping_bell.wait_until(ticket, deadline)) return false;  // rung by every pose
  }
}

}  // namespace zonemap::runtime
