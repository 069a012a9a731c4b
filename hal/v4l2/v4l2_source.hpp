// Depth frames from a V4L2 capture device (what FPGA video pipelines expose):
// memory-mapped streaming of 16-bit depth (V4L2_PIX_FMT_Y16 or Z16), buffers
// queued and dequeued without allocation, the driver's timestamps, lost frames
// from sequence-number gaps. A frame of the wrong size or flagged bad is refused
// and counted; a device that goes away is reopened with backoff.
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "hal/frames/frame_source.hpp"
#include "hal/v4l2/buffer_intake.hpp"
#include "zonemap/common/time_watermark.hpp"

namespace zonemap::v4l2 {

enum class DepthFormat { kY16, kZ16 };

struct V4l2Config {
  std::string device = "/dev/video0";
  DepthFormat format = DepthFormat::kY16;
  int buffers = 4;
  double reopen_backoff_min_s = 0.2, reopen_backoff_max_s = 5.0;
  TimeWatermarkConfig time;  // buffer timestamps: a lone one far off costs its frame
};

struct V4l2Counters : BufferCounters {
  std::int64_t device_errors = 0, reopens = 0;
};

class V4l2FrameSource final : public hal::FrameSource {
 public:
  V4l2FrameSource(const V4l2Config& config, const CameraModel& camera);
  ~V4l2FrameSource() override;
  // Opens and starts streaming; false with the reason (device, ioctl, what it offers).
  bool open(std::string* error);
  const CameraModel& camera() const override { return camera_; }
  hal::CameraFrame make_frame() const override;
  hal::FrameRead next(hal::CameraFrame* frame, int wait_ms, std::string* why) override;
  std::int64_t frames_lost() const override { return intake_.counters().lost; }
  V4l2Counters counters() const;

 private:
  void close_device();
  bool reopen_due(double now_s);

  V4l2Config config_;
  CameraModel camera_;
  int fd_ = -1;
  struct Mapping {
    void* start = nullptr;
    std::size_t length = 0;
  };
  std::array<Mapping, 16> mappings_{};
  int mapped_ = 0;
  std::uint32_t bytes_per_line_ = 0;
  double backoff_s_ = 0.0, next_reopen_s_ = 0.0;
  bool ever_opened_ = false;
  std::int64_t device_errors_ = 0, reopens_ = 0;
  BufferIntake intake_;
};

}  // namespace zonemap::v4l2
