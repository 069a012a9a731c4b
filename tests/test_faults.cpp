// Injected faults through the HAL interfaces, each with the behaviour it must
// produce: INS silent for 2 s, a 100 m pose jump, pose time going backwards, the
// camera stalling for 1 s then bursting, corrupt frames in a stream, the CAN
// transmit queue full, and an LCM provider that never starts. Mapping goes on
// through all of them and every fault is counted.
#include <gtest/gtest.h>

#include <chrono>
#include <set>
#include <thread>

#include "hal/can/obstacle_can_sink.hpp"
#include "hal/config/yaml_config.hpp"
#include "hal/lcm/lcm_sinks.hpp"
#include "hal/replay/replay_frame_source.hpp"
#include "pipeline_support.hpp"
#include "runtime/pipeline.hpp"
#include "test_support.hpp"

namespace zonemap {
namespace {

using testing::Flight;

// A live INS replaying the sequence's poses through the real gate, with faults.
class ScriptedIns final : public hal::PoseSource {
 public:
  ScriptedIns(const std::vector<PoseSample>& truth, std::function<bool(InsSolution*)> fault)
      : truth_(truth),
        fault_(std::move(fault)),
        filter_({}, Eigen::Isometry3d::Identity(), 0.0, "scripted INS") {}
  hal::PollResult poll(hal::PoseSink& sink, int) override {
    for (; next_ < truth_.size(); ++next_) {
      InsSolution s;
      s.time_s = truth_[next_].time_s;
      s.position_m = truth_[next_].position;
      s.attitude = truth_[next_].attitude;
      s.attitude_valid = s.position_valid = true;
      s.position_sigma_m = 0.1;
      if (!fault_(&s)) continue;  // the INS said nothing
      filter_.pass(s, sink, s.time_s);
    }
    return hal::PollResult::kIdle;
  }
  hal::PoseSourceCounters counters() const override {
    hal::PoseSourceCounters c;
    c.poses_out = filter_.poses_out();
    c.gate = filter_.gate_counters();
    return c;
  }
  const char* name() const override { return "scripted INS"; }

 private:
  const std::vector<PoseSample>& truth_;
  std::function<bool(InsSolution*)> fault_;
  hal::InsPoseFilter filter_;
  std::size_t next_ = 0;
};

// Frames from the sequence, with faults: stalls, bursts, corruption.
class ScriptedCamera final : public hal::FrameSource {
 public:
  ScriptedCamera(const replay::ReplaySequence& sequence,
                 std::function<hal::FrameRead(std::size_t, hal::CameraFrame*, std::string*)> fault)
      : inner_(sequence, 0.0), fault_(std::move(fault)), camera_(sequence.camera()) {}
  const CameraModel& camera() const override { return camera_; }
  hal::CameraFrame make_frame() const override { return inner_.make_frame(); }
  hal::FrameRead next(hal::CameraFrame* frame, int wait_ms, std::string* why) override {
    const std::size_t index = inner_.next_index();
    const hal::FrameRead r = inner_.next(frame, wait_ms, why);
    if (r != hal::FrameRead::kFrame) return r;
    return fault_(index, frame, why);
  }

 private:
  replay::ReplayFrameSource inner_;
  std::function<hal::FrameRead(std::size_t, hal::CameraFrame*, std::string*)> fault_;
  CameraModel camera_;
};

}  // namespace

TEST(Faults, InsSilentForTwoSecondsSkipsThoseFramesAndResumes) {
  Flight f(40);
  const double t0 = f.sequence.entry(10).time_s;
  ScriptedIns ins(f.sequence.poses().samples(), [&](InsSolution* s) {
    return !(s->time_s > t0 && s->time_s < t0 + 2.0);  // silent in (t0, t0 + 2 s)
  });
  replay::ReplayFrameSource camera(f.sequence, 0.0);
  const runtime::PipelineStats s = f.run(camera, &ins, {});
  // 4 Hz: the 7 frames strictly inside the silence have no pose; none is mapped.
  EXPECT_EQ(s.frames_skipped_no_pose, 7);
  EXPECT_EQ(s.frames_mapped, 33);
  for (std::size_t index : f.hooks.mapped) {
    const double t = f.sequence.entry(index).time_s;
    EXPECT_FALSE(t > t0 && t < t0 + 2.0) << "frame " << index << " mapped with a stale pose";
  }
  EXPECT_GT(f.hooks.mapped.back(), 17u) << "mapping resumed after the silence";
  EXPECT_EQ(s.mapping_thread_allocations, 0);
}

TEST(Faults, PoseJumpAndTimeGoingBackwardsAreRefusedAndTheMapIsUnchanged) {
  Flight clean(32);
  ScriptedIns truth(clean.sequence.poses().samples(), [](InsSolution*) { return true; });
  replay::ReplayFrameSource camera_a(clean.sequence, 0.0);
  clean.run(camera_a, &truth, {});
  const std::vector<ObstacleBox> expected = clean.boxes();

  Flight faulty(32);
  int n = 0;
  ScriptedIns ins(faulty.sequence.poses().samples(), [&](InsSolution* s) {
    ++n;
    if (n == 12) s->position_m.x() += 100.0;  // a 100 m jump for one solution
    if (n == 20) s->time_s -= 0.6;            // a stamp from the past
    return true;
  });
  replay::ReplayFrameSource camera_b(faulty.sequence, 0.0);
  const runtime::PipelineStats s = faulty.run(camera_b, &ins, {});
  const InsGateCounters gate = ins.counters().gate;
  EXPECT_EQ(gate.rejected[static_cast<int>(InsRejection::kJump)], 1);
  EXPECT_EQ(gate.rejected[static_cast<int>(InsRejection::kTimeNotIncreasing)], 1);
  // Around a refused pose the gap is 0.5 s (> pose.max_gap_s): those frames are
  // skipped and counted, never mapped with a guessed pose.
  EXPECT_EQ(s.frames_mapped + s.frames_skipped_no_pose, 32);
  const std::vector<ObstacleBox> got = faulty.boxes();
  ASSERT_EQ(got.size(), expected.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    // Obstacles within a cell or two; the ground's far rim moves with the frames
    // skipped around the refused poses (fewer views reach as far).
    const double limit = got[i].kind == FeatureKind::kGround ? 2.51 : 1.01;
    EXPECT_LT((got[i].min - expected[i].min).norm(), limit) << "box " << i;
    EXPECT_LT((got[i].max - expected[i].max).norm(), limit) << "box " << i;
  }
}

TEST(Faults, CameraStallsOneSecondThenBurstsAndCorruptFramesAreCounted) {
  Flight f(48);
  ScriptedCamera camera(f.sequence, [](std::size_t index, hal::CameraFrame*, std::string* why) {
    if (index == 12) std::this_thread::sleep_for(std::chrono::seconds(1));  // the stall
    if (index % 9 == 4) {
      why->assign("injected: corrupt frame");
      return hal::FrameRead::kRejected;
    }
    return hal::FrameRead::kFrame;
  });
  const runtime::PipelineStats s = f.run(camera, nullptr, {}, /*lossless=*/false);
  EXPECT_EQ(s.frames_in, 48);
  EXPECT_EQ(s.frames_rejected, 5);  // indices 4, 13, 22, 31, 40
  EXPECT_EQ(s.frames_in, s.frames_mapped + s.frames_rejected + s.frames_skipped_no_pose +
                             s.dropped_mapper_behind + s.dropped_pool_full)
      << "every frame accounted for";
  bool after_stall = false;
  for (std::size_t index : f.hooks.mapped) after_stall |= index > 12;
  EXPECT_TRUE(after_stall) << "mapping resumed after the stall";
  EXPECT_EQ(s.mapping_thread_allocations, 0);
}

namespace {

// A CAN bus whose transmit queue fills after `room` frames per update window.
class FullQueue final : public can::CanTransport {
 public:
  explicit FullQueue(int room) : room_(room) {}
  can::CanIo send(const can::CanFrame&, double) override {
    if (sent_in_window_ >= room_) {
      ++refused;
      sent_in_window_ = 0;  // the queue drains by the next update
      return can::CanIo::kWouldBlock;
    }
    ++sent_in_window_;
    ++accepted;
    return can::CanIo::kOk;
  }
  int refused = 0, accepted = 0;

 private:
  int room_;
  int sent_in_window_ = 0;
};

}  // namespace

TEST(Faults, CanQueueFullAndLcmProviderDownAreCountedMappingUnaffected) {
  Flight f(32);
  FullQueue bus(3);  // fewer than one update needs (BEGIN, 2 per box, END)
  can::ObstacleCanConfig can_config;
  can_config.rate_hz = 1e6;  // every update
  can::CanObstacleSink can_out(bus, can_config, f.features->capacity());
  lcm_link::LcmOutputConfig lcm_config;
  lcm_config.url = "nonsense://provider-that-cannot-start";
  lcm_config.rate_hz = 1e6;
  lcm_link::LcmObstacleSink lcm_out(lcm_config);
  hal::ObstacleSink* sinks[] = {&can_out, &lcm_out};
  replay::ReplayFrameSource camera(f.sequence, 0.0);
  const runtime::PipelineStats s = f.run(camera, nullptr, sinks);
  EXPECT_EQ(s.frames_mapped, 32);
  EXPECT_EQ(s.outputs_published + s.outputs_skipped, 32);  // skipped: output thread still busy
  EXPECT_GT(s.outputs_published, 0);
  EXPECT_GT(can_out.updates_cut_short(), 0);
  EXPECT_EQ(bus.refused, can_out.updates_cut_short());
  hal::HealthSnapshot health;
  lcm_out.report(&health);
  ASSERT_GE(health.named, 3);
  EXPECT_EQ(std::string(health.names[2]), "lcm_out_provider_down");
  EXPECT_GT(health.values[2], 0);
  EXPECT_EQ(s.output_thread_allocations, 0);
}

}  // namespace zonemap
