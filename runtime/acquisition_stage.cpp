// Lossless waits for a free slot; newest wins reads into a spare buffer and
// drops the frame when every slot waits for the mapper.
#include "runtime/acquisition_stage.hpp"

#include <limits>
#include <string>

namespace zonemap::runtime {

AcquisitionStage::AcquisitionStage(Links& links, hal::FrameSource& source,
                                   const PoseTrack* replay_poses, const PipelineOptions& options,
                                   double pose_max_gap_s)
    : links_(links),
      source_(source),
      replay_poses_(replay_poses),
      lossless_(options.lossless),
      pose_max_gap_s_(pose_max_gap_s),
      drop_frame_(source.make_frame()) {}

// Replay poses reach the buffer as the frames come, up to one gap ahead.
void AcquisitionStage::push_replay_poses_until(double time_s) {
  const auto& samples = replay_poses_->samples();
  while (next_pose_ < samples.size() && samples[next_pose_].time_s <= time_s) {
    links_.poses.push(samples[next_pose_++]);
  }
}

// A free slot, or kEndOfStream when newest wins finds every slot waiting (the
// frame read next is dropped).
void AcquisitionStage::take_slot(std::uint32_t* slot) {
  if (lossless_) {
    pop_waiting(links_.free_slots, slot, links_.acquisition_bell);
  } else if (!links_.free_slots.pop(slot)) {
    *slot = kEndOfStream;
  }
}

void AcquisitionStage::run() {
  PipelineStats& s = stats_;
  std::uint32_t spare = kEndOfStream;  // a slot taken but not sent (rejected or no frame)
  std::size_t frame_index = 0;
  std::string why;
  why.reserve(512);
  while (!links_.stop_requested.load(std::memory_order_acquire)) {
    std::uint32_t slot = spare;
    spare = kEndOfStream;
    if (slot == kEndOfStream) take_slot(&slot);
    hal::CameraFrame* target = slot == kEndOfStream ? &drop_frame_ : &links_.frames[slot];
    const hal::FrameRead read = source_.next(target, 100, &why);
    if (read == hal::FrameRead::kEnd) {
      spare = slot;
      break;
    }
    if (read == hal::FrameRead::kNone) {
      spare = slot;
      continue;
    }
    ++s.frames_in;
    links_.acquired.frames_in.fetch_add(1, std::memory_order_relaxed);
    const std::size_t index = frame_index++;
    // A corrupt frame counts as rejected even when there was no slot for it.
    if (read == hal::FrameRead::kRejected) {
      ++s.frames_rejected;
      links_.acquired.rejected.fetch_add(1, std::memory_order_relaxed);
      spare = slot;
      links_.acquired.offered.fetch_add(1, std::memory_order_release);
      continue;
    }
    if (slot == kEndOfStream) {
      ++s.dropped_pool_full;  // counted, never mapped
      links_.acquired.pool_full.fetch_add(1, std::memory_order_relaxed);
      links_.acquired.offered.fetch_add(1, std::memory_order_release);
      continue;
    }
    if (replay_poses_ != nullptr) {
      push_replay_poses_until(links_.frames[slot].time_s + pose_max_gap_s_);
      links_.mapping_bell.ring();  // a mapper waiting for a late pose looks again
    }
    links_.frame_info[slot] = {index, Clock::now()};
    // Cannot stay full: it holds all the slots.
    push_waiting(links_.filled, slot, links_.acquisition_bell);
    links_.acquired.offered.fetch_add(1, std::memory_order_release);
  }
  if (links_.stop_requested.load(std::memory_order_acquire)) s.stopped = true;
  if (replay_poses_ != nullptr) {  // every pose left, for the frames still waiting
    push_replay_poses_until(std::numeric_limits<double>::infinity());
  }
  s.frames_lost = source_.frames_lost();
  push_waiting(links_.filled, kEndOfStream, links_.acquisition_bell);
}

}  // namespace zonemap::runtime
