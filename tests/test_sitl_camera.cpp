// The closed loop's simulated camera (tools/sitl): a frame is the scene rendered
// at the newest pose the autopilot gave, stamped with that pose's time, in the
// autopilot's NED turned into the renderer's z-up world; no new pose, no frame.
#include <gtest/gtest.h>

#include <vector>

#include "tools/sim/scenarios.hpp"
#include "tools/sitl/live_camera.hpp"

namespace zonemap {
namespace {

// Hands out its poses one poll at a time.
class OnePoseAPoll final : public hal::PoseSource {
 public:
  explicit OnePoseAPoll(std::vector<PoseSample> samples) : samples_(std::move(samples)) {}
  hal::PollResult poll(hal::PoseSink& sink, int) override {
    if (next_ < samples_.size()) sink.push(samples_[next_++]);
    return hal::PollResult::kIdle;
  }
  hal::PoseSourceCounters counters() const override { return {}; }
  const char* name() const override { return "list"; }

 private:
  std::vector<PoseSample> samples_;
  std::size_t next_ = 0;
};

TEST(SitlCamera, AFrameIsTheSceneAtTheAutopilotsNewestPoseInItsNed) {
  sim::Scenario course;
  sim::ScenarioOptions options;
  options.width = 160;
  std::string error;
  ASSERT_TRUE(sim::make_scenario("sitl-course", options, &course, &error)) << error;
  // z up: 10 m over home looking north, pitched 10 degrees down; in NED the same
  // pose turned about north.
  const Eigen::Isometry3d up = sim::look_pose({0.0, 0.0, 10.0}, 0.0, 10.0 * M_PI / 180.0);
  Eigen::Isometry3d turn = Eigen::Isometry3d::Identity();
  turn.linear() = Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal();
  const Eigen::Isometry3d ned = turn * up;
  PoseSample first;
  first.time_s = 12.5;
  first.position = ned.translation();
  first.attitude = Eigen::Quaterniond(ned.linear());
  PoseSample second = first;
  second.time_s = 12.6;
  CameraModel camera = course.camera;
  camera.world_z_up = false;
  sim::RenderOptions render;
  render.noise_sigma_px = 0.0;
  render.hole_fraction = 0.0;
  render.hole_block_fraction = 0.0;
  sitl::LiveSimCamera live(course.scene, camera,
                           std::make_unique<OnePoseAPoll>(std::vector<PoseSample>{first, second}),
                           1000.0, render);
  hal::CameraFrame frame = live.make_frame();
  std::string why;
  ASSERT_EQ(live.next(&frame, 100, &why), hal::FrameRead::kFrame);
  EXPECT_EQ(frame.time_s, 12.5);
  // The same picture the renderer draws at the z-up pose.
  std::vector<std::uint16_t> depth(frame.depth.size());
  std::vector<std::uint8_t> left(frame.left.size());
  sim::Rng rng(render.seed);
  sim::render(course.scene, course.camera, up, render, rng, depth.data(), left.data());
  EXPECT_EQ(frame.depth, depth);
  // The posts 20 m ahead are in it (depths 18-22 m).
  int post_pixels = 0;
  for (const std::uint16_t d : frame.depth) {
    const double m = d / camera.depth_scale;
    post_pixels += m > 18.0 && m < 22.0;
  }
  EXPECT_GT(post_pixels, 20);
  ASSERT_EQ(live.next(&frame, 100, &why), hal::FrameRead::kFrame);
  EXPECT_EQ(frame.time_s, 12.6);
  EXPECT_EQ(live.next(&frame, 20, &why), hal::FrameRead::kNone) << "no new pose, no frame";
  EXPECT_EQ(live.rendered(), 2);
}

}  // namespace
}  // namespace zonemap
