#include "hal/v4l2/buffer_intake.hpp"

#include <cstring>

namespace zonemap::v4l2 {

BufferVerdict check_buffer(bool error_flag, std::uint32_t bytes_used, std::uint32_t expected_bytes,
                           std::uint32_t sequence, bool has_last, std::uint32_t last_sequence) {
  BufferVerdict v;
  // Sequence numbers count every frame the device produced, delivered or not
  // (unsigned difference: wraps at 2^32 correctly).
  if (has_last) {
    const std::uint32_t step = sequence - last_sequence;
    if (step > kMaxCountedSequenceGap && step < 0x80000000u) {
      v.sequence_outlier = true;  // a bit flip or a garbage field, not 10000 lost frames
    } else if (step > 1 && step < 0x80000000u) {
      v.lost_before = step - 1;
    }
  }
  if (error_flag) {
    v.why = "the driver flagged the buffer as corrupted (V4L2_BUF_FLAG_ERROR)";
  } else if (bytes_used != expected_bytes) {
    v.why = "frame of the wrong size (bytesused differs from the negotiated format)";
  } else {
    v.usable = true;
  }
  return v;
}

void BufferIntake::count_refused_time(TimeVerdict verdict) {
  ++counters_.rejected_time;
  counters_.time_repeated += verdict == TimeVerdict::kRepeated ? 1 : 0;
  counters_.time_past += verdict == TimeVerdict::kPast ? 1 : 0;
  counters_.time_future += verdict == TimeVerdict::kFuture ? 1 : 0;
}

hal::FrameRead BufferIntake::take(const DequeuedBuffer& buffer, hal::CameraFrame* frame,
                                  std::string* why) {
  const BufferVerdict verdict = check_buffer(buffer.error_flag, buffer.bytes_used, image_bytes_,
                                             buffer.sequence, has_last_, last_sequence_);
  counters_.lost += verdict.lost_before;
  counters_.sequence_outliers += verdict.sequence_outlier ? 1 : 0;
  // After a lone outlier the next step back reads as a restart (no frames lost);
  // a counter that really jumped goes on from its new value.
  has_last_ = true;
  last_sequence_ = buffer.sequence;
  if (!verdict.usable) {
    ++(buffer.error_flag ? counters_.rejected_error : counters_.rejected_size);
    if (why != nullptr) why->assign(verdict.why);
    return hal::FrameRead::kRejected;
  }
  const TimeVerdict time = frame_time_.offer(buffer.timestamp_s);
  if (!accepted(time)) {
    count_refused_time(time);
    if (why != nullptr) why->assign(to_string(time));
    return hal::FrameRead::kRejected;
  }
  counters_.clock_steps += time == TimeVerdict::kAdopted ? 1 : 0;
  const std::size_t row_bytes = static_cast<std::size_t>(camera_.width) * 2;
  for (int y = 0; y < camera_.height; ++y) {
    std::memcpy(frame->depth.data() + static_cast<std::size_t>(y) * camera_.width,
                buffer.image + static_cast<std::size_t>(y) * buffer.bytes_per_line, row_bytes);
  }
  frame->time_s = buffer.timestamp_s;
  frame->has_left = false;
  ++counters_.frames;
  return hal::FrameRead::kFrame;
}

}  // namespace zonemap::v4l2
