// A replay sequence as a frame source, optionally paced like a camera.
#pragma once

#include <cstddef>
#include <string>

#include "hal/frames/frame_source.hpp"
#include "hal/replay/sequence.hpp"

namespace zonemap::replay {

// A replay sequence as a frame source, optionally paced like a camera.
class ReplayFrameSource final : public hal::FrameSource {
 public:
  ReplayFrameSource(const ReplaySequence& sequence, double rate_hz)
      : sequence_(sequence), rate_hz_(rate_hz) {}
  const CameraModel& camera() const override { return sequence_.camera(); }
  hal::CameraFrame make_frame() const override { return sequence_.make_frame(); }
  hal::FrameRead next(hal::CameraFrame* frame, int wait_ms, std::string* why) override;
  std::size_t next_index() const { return next_; }

 private:
  const ReplaySequence& sequence_;
  double rate_hz_;
  std::size_t next_ = 0;
  bool started_ = false;
  double start_s_ = 0.0;
};

}  // namespace zonemap::replay
