// What happens to one buffer the V4L2 driver hands back, apart from the ioctls
// (pure: the same code runs on the vehicle and in host tests that feed whole
// flights through it). A buffer flagged bad or of the wrong size is refused; its
// sequence number shows the frames the driver skipped; its timestamp passes a
// time watermark, so one garbage stamp costs only its own frame and a clock that
// really stepped is adopted after a few frames and counted.
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "hal/frames/frame_source.hpp"
#include "zonemap/common/time_watermark.hpp"

namespace zonemap::v4l2 {

// The checks on one dequeued buffer's flags, size and sequence number.
struct BufferVerdict {
  bool usable = false;
  const char* why = nullptr;      // when not usable
  std::int64_t lost_before = 0;   // frames the driver skipped before this one
  bool sequence_outlier = false;  // a sequence number far ahead: not counted as lost frames
};
inline constexpr std::uint32_t kMaxCountedSequenceGap = 10000;  // ~5 min at 30 Hz
BufferVerdict check_buffer(bool error_flag, std::uint32_t bytes_used, std::uint32_t expected_bytes,
                           std::uint32_t sequence, bool has_last, std::uint32_t last_sequence);

// One buffer as VIDIOC_DQBUF returned it, its image still in the driver's mapping.
struct DequeuedBuffer {
  const std::uint8_t* image = nullptr;  // 16-bit depth, little-endian, bytes_per_line a row
  std::uint32_t bytes_per_line = 0;
  std::uint32_t bytes_used = 0;
  std::uint32_t sequence = 0;
  double timestamp_s = 0.0;  // the driver's capture time
  bool error_flag = false;   // V4L2_BUF_FLAG_ERROR
};

struct BufferCounters {
  std::int64_t frames = 0, rejected_size = 0, rejected_error = 0, lost = 0;
  std::int64_t rejected_time = 0, sequence_outliers = 0, clock_steps = 0;
  // rejected_time by kind: repeated, past, future (TimeVerdict order).
  std::int64_t time_repeated = 0, time_past = 0, time_future = 0;
};

class BufferIntake {
 public:
  BufferIntake(const TimeWatermarkConfig& time, const CameraModel& camera)
      : camera_(camera), frame_time_(time) {}
  // The size the negotiated format gives every frame (sizeimage).
  void set_image_bytes(std::uint32_t bytes) { image_bytes_ = bytes; }
  // A reopened device counts its sequence numbers afresh.
  void restart_sequence() { has_last_ = false; }
  // Copies a usable buffer into `frame` (kFrame) or says why not (kRejected, *why).
  hal::FrameRead take(const DequeuedBuffer& buffer, hal::CameraFrame* frame, std::string* why);
  const BufferCounters& counters() const { return counters_; }

 private:
  void count_refused_time(TimeVerdict verdict);

  CameraModel camera_;
  TimeWatermark frame_time_;
  std::uint32_t image_bytes_ = 0;
  bool has_last_ = false;
  std::uint32_t last_sequence_ = 0;
  BufferCounters counters_;
};

}  // namespace zonemap::v4l2
