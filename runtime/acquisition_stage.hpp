// The acquisition stage: frames from the source into the pool's free slots,
// handed to the mapping stage by index; replay poses into the pose buffer as
// their frames come.
#pragma once

#include "runtime/links.hpp"

namespace zonemap::runtime {

class AcquisitionStage {
 public:
  // `replay_poses` null: the INS stage fills the pose buffer. `pose_max_gap_s`:
  // how far past a frame's time the replay poses go into the buffer with it.
  AcquisitionStage(Links& links, hal::FrameSource& source, const PoseTrack* replay_poses,
                   const PipelineOptions& options, double pose_max_gap_s);
  void run();  // until the source ends or stop(); then the end of the stream
  const PipelineStats& stats() const { return stats_; }
  std::size_t reserved_bytes() const {
    return drop_frame_.depth.capacity() * sizeof(std::uint16_t) + drop_frame_.left.capacity();
  }

 private:
  void take_slot(std::uint32_t* slot);
  void push_replay_poses_until(double time_s);

  Links& links_;
  hal::FrameSource& source_;
  const PoseTrack* replay_poses_;
  const bool lossless_;
  const double pose_max_gap_s_;
  // Newest wins with every slot waiting: the next frame is read into this spare
  // buffer and dropped (a live source must be drained, not left to queue up).
  hal::CameraFrame drop_frame_;
  std::size_t next_pose_ = 0;
  PipelineStats stats_;
};

}  // namespace zonemap::runtime
