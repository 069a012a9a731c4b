// The one clock for durations, deadlines and reception stamps: CLOCK_MONOTONIC
// (std::chrono::steady_clock is CLOCK_MONOTONIC in libstdc++ on Linux), the
// clock V4L2 stamps its frames with, so frame and pose stamps compare. The wall
// clock (CLOCK_REALTIME) only where the kernel stamps with it (SocketCAN).
#pragma once

#include <chrono>

namespace zonemap::os {

using Clock = std::chrono::steady_clock;

inline double ms_between(Clock::time_point from, Clock::time_point to) {
  return std::chrono::duration<double, std::milli>(to - from).count();
}
inline double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}
// `seconds` from now, as a deadline for Doorbell::wait_until.
inline Clock::time_point after_seconds(double seconds) {
  return Clock::now() +
         std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
}
// CLOCK_MONOTONIC now, in seconds since boot.
inline double monotonic_now_s() {
  return std::chrono::duration<double>(Clock::now().time_since_epoch()).count();
}
// CLOCK_REALTIME now, in seconds since the epoch.
inline double realtime_now_s() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

}  // namespace zonemap::os
