// The V4L2 frame source against the kernel's vivid virtual capture device, in the
// test VM (tools/vm-test loads vivid with one capture node, /dev/video0).
#include <gtest/gtest.h>
#include <time.h>

#include <cstdio>

#include "hal/v4l2/v4l2_source.hpp"

using namespace zonemap;

namespace {

v4l2::V4l2Config device_config(const char* device, int buffers) {
  v4l2::V4l2Config c;
  c.device = device;
  c.format = v4l2::DepthFormat::kY16;
  c.buffers = buffers;
  return c;
}

CameraModel vga() {
  CameraModel c;
  c.width = 640;
  c.height = 480;
  c.fx = c.fy = 500;
  c.cx = 319.5;
  c.cy = 239.5;
  c.baseline_m = 0.3;
  c.match_sigma_px = 0.25;
  return c;
}

double monotonic_s() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

}  // namespace

TEST(V4l2Vm, StreamsY16FramesWithDriverTimestampsAndSequence) {
  v4l2::V4l2FrameSource source(device_config("/dev/video0", 4), vga());
  std::string error;
  ASSERT_TRUE(source.open(&error)) << error;
  hal::CameraFrame frame = source.make_frame();
  double last_time = -1.0;
  int frames = 0;
  std::string why;
  const double deadline = monotonic_s() + 20.0;
  while (frames < 10 && monotonic_s() < deadline) {
    const hal::FrameRead r = source.next(&frame, 1000, &why);
    ASSERT_NE(r, hal::FrameRead::kRejected) << why;
    if (r != hal::FrameRead::kFrame) continue;
    ++frames;
    EXPECT_GT(frame.time_s, last_time);
    // Driver timestamps are CLOCK_MONOTONIC: close to now (vivid stamps a frame
    // period ahead under emulation, so within a second either way).
    EXPECT_NEAR(frame.time_s, monotonic_s(), 1.0);
    last_time = frame.time_s;
  }
  EXPECT_EQ(frames, 10);
  // The test pattern is not flat: the 16-bit image holds more than one value.
  bool varied = false;
  for (std::uint16_t v : frame.depth) varied |= v != frame.depth[0];
  EXPECT_TRUE(varied);
}

TEST(V4l2Vm, AStalledConsumerShowsLostFramesFromSequenceGaps) {
  v4l2::V4l2FrameSource source(device_config("/dev/video0", 2), vga());
  std::string error;
  ASSERT_TRUE(source.open(&error)) << error;
  hal::CameraFrame frame = source.make_frame();
  std::string why;
  while (source.next(&frame, 1000, &why) != hal::FrameRead::kFrame) {
  }
  // The consumer stalls for 2 s (a fault, not a synchronisation): the driver has
  // two buffers, so most of those seconds' frames (vivid: >= 5 per second) are
  // never delivered.
  timespec stall{2, 0};
  nanosleep(&stall, nullptr);
  int frames = 0;
  while (frames < 5) {
    if (source.next(&frame, 1000, &why) == hal::FrameRead::kFrame) ++frames;
  }
  std::printf("V4L2 stall 2 s: %lld frames lost (sequence gaps), %lld delivered\n",
              static_cast<long long>(source.frames_lost()),
              static_cast<long long>(source.counters().frames));
  EXPECT_GE(source.frames_lost(), 5) << "frames delivered " << source.counters().frames;
}

TEST(V4l2Vm, AFormatTheDeviceCannotGiveIsAClearError) {
  CameraModel odd = vga();
  odd.width = 641;  // vivid's webcam input has discrete sizes only
  odd.height = 479;
  v4l2::V4l2FrameSource source(device_config("/dev/video0", 4), odd);
  std::string error;
  EXPECT_FALSE(source.open(&error));
  EXPECT_NE(error.find("camera.yaml needs 641x479"), std::string::npos) << error;
  v4l2::V4l2FrameSource missing(device_config("/dev/video9", 4), vga());
  EXPECT_FALSE(missing.open(&error));
  EXPECT_NE(error.find("/dev/video9"), std::string::npos) << error;
}
