// The onboard daemon: frames, poses and outputs chosen by config/vehicle.yaml,
// wired through the threaded pipeline; boxes.csv and stats.json at the end.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "hal/frames/frame_source.hpp"
#include "hal/ins/pose_source.hpp"
#include "hal/lcm/lcm_shared_maps.hpp"
#include "hal/output/map_saver.hpp"
#include "hal/output/obstacle_sink.hpp"
#include "hal/record/flight_recorder.hpp"
#include "hal/replay/sequence.hpp"
#include "onboard/vehicle_config.hpp"
#include "runtime/pipeline.hpp"
#include "zonemap/features/feature_map.hpp"
#include "zonemap/mapping/mapper.hpp"

namespace zonemap::v4l2 {
class V4l2FrameSource;
}

namespace zonemap::onboard {

class VehicleDaemon : private runtime::MappingHooks {
 public:
  ~VehicleDaemon() override;
  // Loads, checks and reserves everything; opens every source and sink. False
  // with a message naming file (and line) or device when something is unusable.
  bool open(const VehicleConfig& config, std::string* error);
  // The same with frames from `frames` (its camera) instead of frames.source: a
  // simulated camera on a desk (tools/sitl), a source of a test.
  bool open(const VehicleConfig& config, std::unique_ptr<hal::FrameSource> frames,
            std::string* error);
  // A start-up report: sources, sinks, memory by component.
  std::string describe() const;
  // Runs until the frames end or stop() (any thread, e.g. a signal handler's flag).
  void run();
  void stop();
  // boxes.csv and stats.json into outputs.directory (if set).
  bool write_outputs(std::string* error);
  const runtime::PipelineStats& pipeline_stats() const { return stats_; }

 private:
  void after_frame(std::size_t frame_index, const Eigen::Isometry3d& pose,
                   const FrameReport& report, double mapping_ms) override;
  void frame_mapped(const hal::CameraFrame& frame, const Eigen::Isometry3d& pose) override;
  bool open_frames(std::string* error);
  bool open_poses(std::string* error);
  bool open_pose_log(std::string* error);
  bool open_mavlink_poses(std::string* error);
  bool add_prior_map(std::string* error);
  void open_shared_maps();
  bool open_sinks(std::string* error);
  bool make_pipeline(std::string* error);
  bool open_recorder(std::size_t footprint_rects, std::string* error);
  void close_recorder();

  VehicleConfig config_;
  MapConfig map_config_;
  CameraModel camera_;
  replay::ReplaySequence sequence_;
  std::unique_ptr<hal::FrameSource> frames_;
  const v4l2::V4l2FrameSource* v4l2_ = nullptr;  // when frames_ is the camera
  bool external_frames_ = false;                 // frames_ given to open()
  std::unique_ptr<hal::PoseSource> live_poses_;
  PoseTrack log_poses_{0.1, 0.02};
  const PoseTrack* replay_poses_ = nullptr;
  std::vector<std::unique_ptr<hal::ObstacleSink>> sinks_;
  std::unique_ptr<Mapper> mapper_;
  std::unique_ptr<FeatureMap> features_;
  std::unique_ptr<SharedMapInbox> shared_inbox_;  // other vehicles' maps (shared_maps)
  std::unique_ptr<lcm_link::LcmSharedMapReceiver> shared_receiver_;
  std::unique_ptr<runtime::Pipeline> pipeline_;
  runtime::PipelineStats stats_;
  hal::PoseSourceCounters pose_counters_;
  std::int64_t frames_mapped_ = 0;
  std::vector<double> frame_ms_;
  record::FlightRecorder* recorder_ = nullptr;  // one of sinks_, when outputs.record is set
  hal::MapSaver* map_saver_ = nullptr;          // one of sinks_, when outputs.save_map_every_s > 0
  std::int64_t depth_offered_ = 0;
  double last_time_s_ = 0.0;  // the newest mapped frame (mapping thread; read after run)
  Eigen::Isometry3d last_world_T_camera_ = Eigen::Isometry3d::Identity();
};

}  // namespace zonemap::onboard
