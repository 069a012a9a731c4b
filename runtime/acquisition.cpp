// The acquisition thread: frames from the source into the pool's free slots,
// handed to the mapping thread by index. Lossless waits for a slot; newest wins
// reads into a spare buffer and drops the frame when every slot waits.
#include <string>

#include "runtime/pipeline_impl.hpp"

namespace zonemap::runtime {

// Replay poses reach the buffer as the frames come, up to one gap ahead.
void Pipeline::Impl::push_replay_poses_until(double time_s, std::size_t* next_pose) {
  const auto& samples = replay_poses->samples();
  while (*next_pose < samples.size() && samples[*next_pose].time_s <= time_s) {
    poses.push(samples[(*next_pose)++]);
  }
}

void Pipeline::Impl::acquisition() {
  PipelineStats& s = acquisition_stats;
  realtime(options.priority_acquisition, options.cpu_acquisition, &s, "acquisition");
  std::size_t next_pose = 0;
  const double gap = mapper.config().pose_max_gap_s;
  std::uint32_t spare = kEndOfStream;  // a slot taken but not sent (rejected or no frame)
  std::size_t frame_index = 0;
  std::string why;
  why.reserve(512);
  while (!stop_requested.load(std::memory_order_acquire)) {
    std::uint32_t slot = spare;
    spare = kEndOfStream;
    if (slot == kEndOfStream) {
      if (options.lossless) {
        pop_waiting(free_slots, &slot, acquisition_bell);
      } else if (!free_slots.pop(&slot)) {
        slot = kEndOfStream;  // every slot waits for the mapper: this frame will be dropped
      }
    }
    hal::CameraFrame* target = slot == kEndOfStream ? &drop_frame : &frames[slot];
    const hal::FrameRead read = source.next(target, 100, &why);
    if (read == hal::FrameRead::kEnd) {
      spare = slot;
      break;
    }
    if (read == hal::FrameRead::kNone) {
      spare = slot;
      continue;
    }
    ++s.frames_in;
    shared_frames_in.fetch_add(1, std::memory_order_relaxed);
    const std::size_t index = frame_index++;
    // A corrupt frame counts as rejected even when there was no slot for it.
    if (read == hal::FrameRead::kRejected) {
      ++s.frames_rejected;
      shared_rejected.fetch_add(1, std::memory_order_relaxed);
      spare = slot;
      offered.fetch_add(1, std::memory_order_release);
      continue;
    }
    if (slot == kEndOfStream) {
      ++s.dropped_pool_full;  // counted, never mapped
      shared_pool_full.fetch_add(1, std::memory_order_relaxed);
      offered.fetch_add(1, std::memory_order_release);
      continue;
    }
    if (replay_poses != nullptr) {
      push_replay_poses_until(frames[slot].time_s + gap, &next_pose);
      mapping_bell.ring();  // a mapper waiting for a late pose looks again
    }
    frame_info[slot] = {index, Clock::now()};
    push_waiting(filled, slot, acquisition_bell);  // cannot stay full: it holds all the slots
    offered.fetch_add(1, std::memory_order_release);
  }
  if (stop_requested.load(std::memory_order_acquire)) s.stopped = true;
  if (replay_poses != nullptr) {  // every pose left, for the frames still waiting
    const auto& samples = replay_poses->samples();
    while (next_pose < samples.size()) poses.push(samples[next_pose++]);
  }
  s.frames_lost = source.frames_lost();
  push_waiting(filled, kEndOfStream, acquisition_bell);
}

}  // namespace zonemap::runtime
