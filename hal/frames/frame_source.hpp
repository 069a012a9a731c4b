// Depth frame sources behind one small interface (the acquisition stage reads
// it): the host replay of a sequence directory, or a V4L2 camera. A source fills
// buffers the pipeline reserved at start-up (make_frame()).
#pragma once

#include <cstdint>
#include <string>

#include "hal/replay/sequence.hpp"
#include "zonemap/camera.hpp"

namespace zonemap::hal {

enum class FrameRead {
  kFrame,     // *frame holds a new frame
  kRejected,  // a frame came but cannot be used (corrupt, wrong size, time backwards): *why
  kNone,      // nothing within wait_ms (a live source)
  kEnd,       // no more frames (a replay ran out, the device is gone for good)
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  virtual const CameraModel& camera() const = 0;
  virtual ReplayFrame make_frame() const = 0;
  // The next frame into `frame` (buffers from make_frame()), waiting at most wait_ms.
  virtual FrameRead next(ReplayFrame* frame, int wait_ms, std::string* why) = 0;
  // Frames the device says it produced but never delivered (sequence gaps).
  virtual std::int64_t frames_lost() const { return 0; }
};

// A replay sequence as a frame source, optionally paced like a camera.
class ReplayFrameSource final : public FrameSource {
 public:
  ReplayFrameSource(const ReplaySequence& sequence, double rate_hz)
      : sequence_(sequence), rate_hz_(rate_hz) {}
  const CameraModel& camera() const override { return sequence_.camera(); }
  ReplayFrame make_frame() const override { return sequence_.make_frame(); }
  FrameRead next(ReplayFrame* frame, int wait_ms, std::string* why) override;
  std::size_t next_index() const { return next_; }

 private:
  const ReplaySequence& sequence_;
  double rate_hz_;
  std::size_t next_ = 0;
  bool started_ = false;
  double start_s_ = 0.0;
};

}  // namespace zonemap::hal
