// A simulated depth camera for closed-loop flights on a desk: it renders a
// generated scene (zonemap-sim's renderer) at the autopilot's newest pose, at
// the camera's rate, and stamps each frame with that pose's time. Its poses come
// from a pose source of its own (the autopilot's EKF over MAVLink, as the
// mapping's INS does through another port), so the frame and the pose the
// mapping looks up for it are one solution.
#pragma once

#include <memory>
#include <vector>

#include "hal/frames/frame_source.hpp"
#include "hal/ins/pose_source.hpp"
#include "tools/sim/scene.hpp"

namespace zonemap::sitl {

class LiveSimCamera final : public hal::FrameSource {
 public:
  // camera: its world frame (world_z_up) is the pose source's; the scene is z up.
  LiveSimCamera(const sim::Scene& scene, const CameraModel& camera,
                std::unique_ptr<hal::PoseSource> poses, double rate_hz,
                const sim::RenderOptions& render);
  const CameraModel& camera() const override { return camera_; }
  hal::CameraFrame make_frame() const override;
  hal::FrameRead next(hal::CameraFrame* frame, int wait_ms, std::string* why) override;
  std::int64_t rendered() const { return rendered_; }
  // Where the camera was at each rendered frame (its world frame): the flown
  // track for the report, reserved for an hour at 30 Hz (the rest not kept).
  const std::vector<Eigen::Vector3d>& track() const { return track_; }
  // The world_T_camera the renderer takes for a pose in the camera's world frame.
  static Eigen::Isometry3d render_pose(const PoseSample& pose, bool world_z_up);

 private:
  struct Newest final : hal::PoseSink {
    PoseSample pose;
    bool fresh = false;
    void push(const PoseSample& p) override {
      pose = p;
      fresh = true;
    }
  };

  sim::Scene scene_;
  CameraModel camera_;
  std::unique_ptr<hal::PoseSource> poses_;
  double period_s_;
  sim::RenderOptions render_;
  sim::Rng rng_;
  Newest newest_;
  double next_due_s_ = 0.0;
  std::int64_t rendered_ = 0;
  std::vector<Eigen::Vector3d> track_;
};

}  // namespace zonemap::sitl
