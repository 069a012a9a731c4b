// The V4L2 buffer intake (hal/v4l2/buffer_intake): what the source does with each
// dequeued buffer, fed here with whole flights. A camera whose driver hands the
// posts flight's frames over in V4L2 buffers (row padding, sequence numbers,
// capture times) maps through the threaded pipeline as the daemon does; one bad
// buffer of each kind costs at most its own frame and the rest maps as the clean run.
#include <gtest/gtest.h>

#include <cstring>
#include <functional>

#include "hal/replay/replay_frame_source.hpp"
#include "hal/v4l2/buffer_intake.hpp"
#include "pipeline_support.hpp"

namespace zonemap {
namespace {

using testing::Flight;

constexpr std::uint32_t kRowPadding = 64;  // drivers may pad rows (bytesperline)

// The frames of a replayed sequence as a V4L2 driver would hand them over, with
// one buffer changed by `fault` before the intake sees it.
class DriverBufferCamera final : public hal::FrameSource {
 public:
  using Fault = std::function<void(std::size_t index, v4l2::DequeuedBuffer*)>;
  DriverBufferCamera(const replay::ReplaySequence& sequence, Fault fault)
      : replay_(sequence, 0.0),
        camera_(sequence.camera()),
        decoded_(replay_.make_frame()),
        fault_(std::move(fault)),
        intake_({}, camera_) {
    bytes_per_line_ = static_cast<std::uint32_t>(camera_.width) * 2 + kRowPadding;
    image_bytes_ = bytes_per_line_ * static_cast<std::uint32_t>(camera_.height);
    driver_buffer_.assign(image_bytes_, 0xEE);
    intake_.set_image_bytes(image_bytes_);
  }
  const CameraModel& camera() const override { return camera_; }
  hal::CameraFrame make_frame() const override { return replay_.make_frame(); }
  hal::FrameRead next(hal::CameraFrame* frame, int wait_ms, std::string* why) override {
    const std::size_t index = replay_.next_index();
    const hal::FrameRead r = replay_.next(&decoded_, wait_ms, why);
    if (r != hal::FrameRead::kFrame) return r;
    v4l2::DequeuedBuffer buffer = fill_driver_buffer(index);
    fault_(index, &buffer);
    return intake_.take(buffer, frame, why);
  }
  std::int64_t frames_lost() const override { return intake_.counters().lost; }
  const v4l2::BufferCounters& counters() const { return intake_.counters(); }

 private:
  v4l2::DequeuedBuffer fill_driver_buffer(std::size_t index) {
    const std::size_t row = static_cast<std::size_t>(camera_.width);
    for (int y = 0; y < camera_.height; ++y)
      std::memcpy(driver_buffer_.data() + static_cast<std::size_t>(y) * bytes_per_line_,
                  decoded_.depth.data() + static_cast<std::size_t>(y) * row, row * 2);
    v4l2::DequeuedBuffer b;
    b.image = driver_buffer_.data();
    b.bytes_per_line = bytes_per_line_;
    b.bytes_used = image_bytes_;
    b.sequence = static_cast<std::uint32_t>(100 + index);
    b.timestamp_s = decoded_.time_s;  // the driver's clock is the INS's here
    return b;
  }

  replay::ReplayFrameSource replay_;
  CameraModel camera_;
  hal::CameraFrame decoded_;
  Fault fault_;
  v4l2::BufferIntake intake_;
  std::vector<std::uint8_t> driver_buffer_;
  std::uint32_t bytes_per_line_ = 0, image_bytes_ = 0;
};

constexpr std::size_t kFrames = 24;
constexpr std::size_t kBad = 12;

struct BadBuffer {
  const char* name;
  std::function<void(v4l2::DequeuedBuffer*)> inject;
  int frames_lost;                                                   // at most
  std::function<std::int64_t(const v4l2::BufferCounters&)> counted;  // must read 1
  std::int64_t lost_reported;  // frames the sequence numbers say the driver skipped
};
void PrintTo(const BadBuffer& bad, std::ostream* out) {
  *out << bad.name;
}

const BadBuffer kBadBuffers[] = {
    {"StampFarInTheFuture", [](v4l2::DequeuedBuffer* b) { b->timestamp_s += 3.0e5; }, 1,
     [](const v4l2::BufferCounters& c) { return c.time_future; }, 0},
    {"StampFromThePast", [](v4l2::DequeuedBuffer* b) { b->timestamp_s -= 2.0; }, 1,
     [](const v4l2::BufferCounters& c) { return c.time_past; }, 0},
    {"StampZero", [](v4l2::DequeuedBuffer* b) { b->timestamp_s = 0.0; }, 1,
     [](const v4l2::BufferCounters& c) { return c.time_past; }, 0},
    {"StampRepeated", [](v4l2::DequeuedBuffer* b) { b->timestamp_s -= 0.25; }, 1,
     [](const v4l2::BufferCounters& c) { return c.time_repeated; }, 0},
    {"FlaggedCorrupt", [](v4l2::DequeuedBuffer* b) { b->error_flag = true; }, 1,
     [](const v4l2::BufferCounters& c) { return c.rejected_error; }, 0},
    {"ShortBuffer", [](v4l2::DequeuedBuffer* b) { b->bytes_used /= 2; }, 1,
     [](const v4l2::BufferCounters& c) { return c.rejected_size; }, 0},
    {"SequenceNumberGarbage", [](v4l2::DequeuedBuffer* b) { b->sequence += 0x00F00000u; }, 0,
     [](const v4l2::BufferCounters& c) { return c.sequence_outliers; }, 0},
    {"DriverSkippedThreeFrames", [](v4l2::DequeuedBuffer* b) { b->sequence += 3; }, 0,
     [](const v4l2::BufferCounters& c) { return c.lost == 3 ? 1 : 0; }, 3},
};

class OneBadBuffer : public ::testing::TestWithParam<BadBuffer> {};

TEST_P(OneBadBuffer, CostsAtMostItsFrameAndTheFlightMapsAsTheCleanOne) {
  const BadBuffer& bad = GetParam();
  Flight clean(kFrames);
  DriverBufferCamera clean_camera(clean.sequence, [](std::size_t, v4l2::DequeuedBuffer*) {});
  const runtime::PipelineStats clean_stats = clean.run(clean_camera, nullptr, {});
  ASSERT_EQ(clean_stats.frames_mapped, static_cast<std::int64_t>(kFrames))
      << "the padded driver buffers are read right";
  const std::vector<ObstacleBox> expected = clean.boxes();
  ASSERT_FALSE(expected.empty());

  Flight faulty(kFrames);
  DriverBufferCamera camera(faulty.sequence, [&](std::size_t index, v4l2::DequeuedBuffer* b) {
    if (index == kBad) bad.inject(b);
  });
  const runtime::PipelineStats s = faulty.run(camera, nullptr, {});
  EXPECT_GE(s.frames_mapped, static_cast<std::int64_t>(kFrames) - bad.frames_lost);
  EXPECT_EQ(s.frames_in, s.frames_mapped + s.frames_rejected + s.frames_skipped_no_pose)
      << "every frame accounted for";
  EXPECT_EQ(bad.counted(camera.counters()), 1) << "the bad buffer counted under its kind";
  EXPECT_EQ(camera.counters().lost, bad.lost_reported);
  EXPECT_EQ(s.frames_lost, bad.lost_reported);
  EXPECT_EQ(camera.counters().clock_steps, 0) << "a lone stamp is not a clock step";
  const std::vector<ObstacleBox> got = faulty.boxes();
  ASSERT_EQ(got.size(), expected.size());
  // Obstacles within a cell; the ground's far rim may move by two (one view fewer
  // reaches less far).
  const double cell = faulty.config.cell_size_m;
  for (std::size_t i = 0; i < got.size(); ++i) {
    const double limit = (got[i].kind == FeatureKind::kGround ? 2 : 1) * cell + 1e-9;
    EXPECT_LE((got[i].min - expected[i].min).cwiseAbs().maxCoeff(), limit) << "box " << i;
    EXPECT_LE((got[i].max - expected[i].max).cwiseAbs().maxCoeff(), limit) << "box " << i;
    if (s.frames_mapped == clean_stats.frames_mapped) {
      EXPECT_EQ(got[i].cells, expected[i].cells);
    }
  }
}

std::string bad_buffer_name(const ::testing::TestParamInfo<BadBuffer>& param) {
  return param.param.name;
}
INSTANTIATE_TEST_SUITE_P(V4l2Flight, OneBadBuffer, ::testing::ValuesIn(kBadBuffers),
                         bad_buffer_name);

// The buffers of a 30 Hz camera whose clock steps by `step_s` at buffer 10.
std::vector<hal::FrameRead> stepped_clock(double step_s, v4l2::BufferIntake* intake) {
  std::vector<std::uint8_t> image(640 * 2 * 480, 0);
  intake->set_image_bytes(static_cast<std::uint32_t>(image.size()));
  hal::CameraFrame frame;
  frame.depth.resize(640 * 480);
  std::vector<hal::FrameRead> reads;
  for (std::uint32_t i = 0; i < 30; ++i) {
    v4l2::DequeuedBuffer b;
    b.image = image.data();
    b.bytes_per_line = 640 * 2;
    b.bytes_used = static_cast<std::uint32_t>(image.size());
    b.sequence = i;
    b.timestamp_s = 1000.0 + i / 30.0 + (i >= 10 ? step_s : 0.0);
    std::string why;
    reads.push_back(intake->take(b, &frame, &why));
  }
  return reads;
}

CameraModel vga() {
  CameraModel c;
  c.width = 640;
  c.height = 480;
  return c;
}

TEST(V4l2BufferIntake, AClockThatReallySteppedIsAdoptedAfterConfirmValuesFramesAndCounted) {
  for (const double step_s : {+3600.0, -3600.0}) {
    TimeWatermarkConfig time;  // confirm_values 3: two frames refused, the third adopts
    v4l2::BufferIntake intake(time, vga());
    const std::vector<hal::FrameRead> reads = stepped_clock(step_s, &intake);
    int refused = 0;
    for (std::size_t i = 0; i < reads.size(); ++i) {
      const bool expect_refused = i == 10 || i == 11;
      EXPECT_EQ(reads[i] == hal::FrameRead::kRejected, expect_refused) << "buffer " << i;
      refused += reads[i] == hal::FrameRead::kRejected ? 1 : 0;
    }
    EXPECT_EQ(refused, time.confirm_values - 1) << "step " << step_s;
    EXPECT_EQ(intake.counters().clock_steps, 1) << "step " << step_s;
    EXPECT_EQ(intake.counters().frames, 28);
  }
}

}  // namespace
}  // namespace zonemap
