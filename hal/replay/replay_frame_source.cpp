#include "hal/replay/replay_frame_source.hpp"

#include <chrono>
#include <thread>

#include "hal/os/clock.hpp"

namespace zonemap::replay {

hal::FrameRead ReplayFrameSource::next(hal::CameraFrame* frame, int /*wait_ms*/, std::string* why) {
  if (next_ >= sequence_.frame_count()) return hal::FrameRead::kEnd;
  const double now = os::monotonic_now_s();
  if (!started_) {
    started_ = true;
    start_s_ = now;
  }
  if (rate_hz_ > 0.0) {  // a simulated camera: frame i at start + i / rate
    const double due = start_s_ + static_cast<double>(next_) / rate_hz_;
    if (due > now) std::this_thread::sleep_for(std::chrono::duration<double>(due - now));
  }
  const std::size_t i = next_++;
  return sequence_.read(i, frame, why) ? hal::FrameRead::kFrame : hal::FrameRead::kRejected;
}

}  // namespace zonemap::replay
