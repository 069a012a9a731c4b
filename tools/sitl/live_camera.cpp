#include "tools/sitl/live_camera.hpp"

#include <algorithm>

#include "hal/os/clock.hpp"

namespace zonemap::sitl {

LiveSimCamera::LiveSimCamera(const sim::Scene& scene, const CameraModel& camera,
                             std::unique_ptr<hal::PoseSource> poses, double rate_hz,
                             const sim::RenderOptions& render)
    : scene_(scene),
      camera_(camera),
      poses_(std::move(poses)),
      period_s_(1.0 / rate_hz),
      render_(render),
      rng_(render.seed) {
  track_.reserve(30 * 3600);
}

hal::CameraFrame LiveSimCamera::make_frame() const {
  hal::CameraFrame frame;
  const std::size_t pixels = static_cast<std::size_t>(camera_.width) * camera_.height;
  frame.depth.assign(pixels, 0);
  frame.left.assign(pixels, 0);
  return frame;
}

Eigen::Isometry3d LiveSimCamera::render_pose(const PoseSample& pose, bool world_z_up) {
  Eigen::Isometry3d world_T_camera = Eigen::Isometry3d::Identity();
  world_T_camera.linear() = pose.attitude.toRotationMatrix();
  world_T_camera.translation() = pose.position;
  if (world_z_up) return world_T_camera;
  // NED -> north, west, up: a half turn about north.
  Eigen::Isometry3d turn = Eigen::Isometry3d::Identity();
  turn.linear() = Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal();
  return turn * world_T_camera;
}

// Waits until the next frame is due, taking every pose that comes meanwhile;
// renders at the newest one (none new since the last frame: nothing).
hal::FrameRead LiveSimCamera::next(hal::CameraFrame* frame, int wait_ms, std::string* /*why*/) {
  const double deadline_s = os::monotonic_now_s() + wait_ms * 1e-3;
  while (true) {
    const double now = os::monotonic_now_s();
    const double until = std::min(deadline_s, std::max(next_due_s_, now));
    const int poll_ms = static_cast<int>(std::max(0.0, (until - now) * 1e3));
    if (poses_->poll(newest_, poll_ms) == hal::PollResult::kEnd) return hal::FrameRead::kEnd;
    const double after = os::monotonic_now_s();
    if (after >= next_due_s_ && newest_.fresh) break;
    if (after >= deadline_s) return hal::FrameRead::kNone;
  }
  newest_.fresh = false;
  next_due_s_ = std::max(next_due_s_ + period_s_, os::monotonic_now_s() - period_s_);
  sim::render(scene_, camera_, render_pose(newest_.pose, camera_.world_z_up), render_, rng_,
              frame->depth.data(), frame->left.data());
  frame->has_left = true;
  frame->time_s = newest_.pose.time_s;
  if (track_.size() < track_.capacity()) track_.push_back(newest_.pose.position);
  ++rendered_;
  return hal::FrameRead::kFrame;
}

}  // namespace zonemap::sitl
