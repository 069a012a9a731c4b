// The replay job: a sequence directory through the host HAL and the mapper, and
// the run's outputs (stats.json, height.png, occupied.ply). Used by the
// zonemap-replay tool and by the end-to-end tests.
#pragma once

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "hal/output/run_outputs.hpp"
#include "hal/record/flight_recorder.hpp"
#include "hal/replay/sequence.hpp"
#include "runtime/pipeline.hpp"
#include "tools/replay/link_capture.hpp"
#include "zonemap/features/extraction_schedule.hpp"
#include "zonemap/mapping/mapper.hpp"
#include "zonemap/outputs/height_profile.hpp"

namespace zonemap::tools {

struct ReplayOptions {
  std::string sequence_dir;
  std::string config_path;
  std::string camera_path;     // empty: SEQUENCE/camera.yaml
  bool progress = false;       // a progress line on stderr
  bool quiet = false;          // no start-up report or rejection log
  std::string record_path;     // an MCAP recording of the run (empty: none)
  int record_depth_every = 5;  // every n-th mapped frame's depth into the recording
  std::string links_dir;       // what the vehicle links would carry, as files (empty: none)
  std::string prior_path;      // a prior map (boxes.csv) in the feature map from the start
};

class ReplayRun : private runtime::MappingHooks {
 public:
  // Loads and checks everything and reserves all memory. False with a message
  // naming the file (and line) when an input is unusable.
  bool open(const ReplayOptions& options, std::string* error);
  // Maps every frame. Per-frame faults are counted in stats(), never fatal.
  void run() {
    run_frames(0, sequence_.frame_count());
    finish();
  }
  // Maps frames [first, last) (for tests that look at the map part-way), then
  // finish() extracts the live zones and completes the statistics.
  void run_frames(std::size_t first, std::size_t last);
  void finish();
  // The same job through the threaded runtime (acquisition, mapping, output
  // threads); then finish() as usual. Pipeline figures go to stats() and to
  // pipeline_stats().
  void run_pipelined(const runtime::PipelineOptions& options);
  const runtime::PipelineStats& pipeline_stats() const { return pipeline_stats_; }
  // Extracts the features of every zone holding a grid now (also done every
  // features.extract_every_frames frames and at finish()).
  void extract_live_zones();
  // The boxes of a prior map (boxes.csv) into the feature map; false with a
  // message naming the file and line when the file is unusable.
  bool add_prior_map(const std::string& path, bool quiet, std::string* error);
  // Writes OUT/stats.json, OUT/boxes.csv, OUT/height.png, OUT/occupied.ply and
  // OUT/report.html.
  bool write_outputs(const std::string& out_dir, std::string* error);

  const hal::RunStats& stats() const { return stats_; }
  // Figures of a step before the run (the host stereo of an ASL recording).
  void set_stereo_figures(std::vector<std::pair<std::string, std::int64_t>> figures) {
    stats_.stereo = std::move(figures);
  }
  Mapper& mapper() { return *mapper_; }
  const replay::ReplaySequence& sequence() const { return sequence_; }
  const MapConfig& config() const { return config_; }
  // The configuration's `pipeline:` section, for run_pipelined().
  const runtime::PipelineOptions& pipeline_options() const { return pipeline_options_; }
  const HeightProfile& height_profile() const { return *height_; }
  FeatureMap& features() { return *features_; }
  // The merged boxes of boxes.csv (obstacles, then ground when asked).
  std::vector<ObstacleBox> boxes(bool include_ground);
  // Camera positions of the mapped frames.
  const std::vector<Eigen::Vector3d>& trajectory() const { return trajectory_; }
  // Poses used for each mapped frame, in order (for evaluation).
  const std::vector<std::size_t>& mapped_frames() const { return mapped_frames_; }

 private:
  void log_feature_store_events();
  void log_removals();
  void warn_if_ground_out_of_reach() const;
  void extract_zone(int live_index);
  void after_frame(std::size_t frame_index, const Eigen::Isometry3d& pose,
                   const FrameReport& report, double mapping_ms) override;
  void frame_mapped(const hal::CameraFrame& frame, const Eigen::Isometry3d& pose) override;
  void account_mapped_frame(std::size_t frame_index, const Eigen::Isometry3d& pose,
                            const FrameReport& report, double mapping_ms);
  void log_rejection(const char* kind, std::int64_t count, const std::string& message) const;
  bool open_recorder(std::string* error);
  void record_frame(const hal::CameraFrame& frame, const Eigen::Isometry3d& pose);
  hal::ObstacleUpdate fill_update(hal::MergedUpdate& storage, bool include_ground, double time_s,
                                  const Eigen::Isometry3d& world_T_camera);
  void record_boxes(double time_s, const Eigen::Isometry3d& world_T_camera, bool final);
  bool open_links(std::string* error);
  void capture_links(double time_s, const Eigen::Isometry3d& world_T_camera);
  void record_health(double time_s);
  void close_recording();
  bool write_report(const std::string& out_dir, std::string* error);
  std::vector<float> occupied_sample(std::size_t most);
  void count_list_rejections();
  mutable bool progress_shown_ = false;  // the progress line holds the cursor

  ReplayOptions options_;
  MapConfig config_;
  runtime::PipelineOptions pipeline_options_;
  replay::ReplaySequence sequence_;
  std::unique_ptr<Mapper> mapper_;
  std::unique_ptr<HeightProfile> height_;
  std::unique_ptr<FeatureMap> features_;
  std::vector<double> extract_ms_;
  hal::RunStats stats_;
  std::vector<double> frame_ms_;
  std::vector<Eigen::Vector3d> trajectory_;
  std::vector<std::size_t> mapped_frames_;
  bool finished_ = false;
  FeatureCounters logged_counters_;
  std::int64_t removals_logged_ = 0;
  bool in_pipeline_ = false;  // on the mapping thread: count, do not print
  ExtractionSchedule schedule_{1};
  runtime::PipelineStats pipeline_stats_;
  // The recording (OUT/run.mcap): its buffers and when each channel was last fed.
  std::unique_ptr<record::FlightRecorder> recorder_;
  // The link capture (options.links_dir) and its update storage.
  std::unique_ptr<LinkCapture> links_;
  hal::MergedUpdate links_update_;
  int links_every_frames_ = 3;
  hal::MergedUpdate update_;
  double recorded_occupied_s_ = -INFINITY, recorded_boxes_s_ = -INFINITY;
  double recorded_health_s_ = -INFINITY;
  std::int64_t last_sky_ = 0, last_sky_refused_ = 0;  // the last mapped frame's sky pixels
  bool boxes_changed_ = false;
  std::int64_t depth_offered_ = 0;
  double last_time_s_ = 0.0;  // the newest mapped frame
  Eigen::Isometry3d last_world_T_camera_ = Eigen::Isometry3d::Identity();
};

}  // namespace zonemap::tools
