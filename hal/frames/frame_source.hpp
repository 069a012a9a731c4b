// Depth frame sources behind one small interface (the acquisition stage reads
// it): the host replay of a sequence directory (hal/replay/replay_frame_source),
// or a V4L2 camera (hal/v4l2). A source fills
// buffers the pipeline reserved at start-up (make_frame()).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "zonemap/common/camera.hpp"

namespace zonemap::hal {

// One depth frame as every source fills it (replay, V4L2): buffers reserved at
// start-up for the camera's size, reused frame after frame.
struct CameraFrame {
  double time_s = 0.0;
  std::vector<std::uint16_t> depth;  // width * height
  std::vector<std::uint8_t> left;    // the left image, when the source has one
  bool has_left = false;
  std::string left_problem;  // set when a left image exists but could not be used
};

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
  virtual CameraFrame make_frame() const = 0;
  // The next frame into `frame` (buffers from make_frame()), waiting at most wait_ms.
  virtual FrameRead next(CameraFrame* frame, int wait_ms, std::string* why) = 0;
  // Frames the device says it produced but never delivered (sequence gaps).
  virtual std::int64_t frames_lost() const { return 0; }
};

}  // namespace zonemap::hal
