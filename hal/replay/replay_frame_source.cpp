#include <chrono>
#include <thread>

#include "hal/replay/replay_frame_source.hpp"

namespace zonemap::hal {

FrameRead ReplayFrameSource::next(CameraFrame* frame, int /*wait_ms*/, std::string* why) {
  using Clock = std::chrono::steady_clock;
  if (next_ >= sequence_.frame_count()) return FrameRead::kEnd;
  const double now = std::chrono::duration<double>(Clock::now().time_since_epoch()).count();
  if (!started_) {
    started_ = true;
    start_s_ = now;
  }
  if (rate_hz_ > 0.0) {  // a simulated camera: frame i at start + i / rate
    const double due = start_s_ + static_cast<double>(next_) / rate_hz_;
    if (due > now) std::this_thread::sleep_for(std::chrono::duration<double>(due - now));
  }
  const std::size_t i = next_++;
  return sequence_.read(i, frame, why) ? FrameRead::kFrame : FrameRead::kRejected;
}

}  // namespace zonemap::hal
