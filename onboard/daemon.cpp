#include "onboard/daemon.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "hal/can/can_pose_source.hpp"
#include "hal/can/obstacle_can_sink.hpp"
#include "hal/config/prior_map.hpp"
#include "hal/config/yaml_config.hpp"
#include "hal/ins_log/ins_logs.hpp"
#include "hal/lcm/lcm_link.hpp"
#include "hal/lcm/lcm_sinks.hpp"
#include "hal/mavlink/mavlink_udp_sink.hpp"
#include "hal/output/map_saver.hpp"
#include "hal/output/run_outputs.hpp"
#include "hal/replay/replay_frame_source.hpp"
#include "hal/v4l2/v4l2_source.hpp"
#include "runtime/runtime_config.hpp"

namespace zonemap::onboard {

VehicleDaemon::~VehicleDaemon() = default;

bool VehicleDaemon::open(const VehicleConfig& config, std::string* error) {
  return open(config, nullptr, error);
}

bool VehicleDaemon::open(const VehicleConfig& config, std::unique_ptr<hal::FrameSource> frames,
                         std::string* error) {
  config_ = config;
  if (!hal::load_map_config(config.mapping_path, &map_config_, error)) return false;
  config_.gate.time = map_config_.timestamps;
  if (frames) {
    camera_ = frames->camera();
    frames_ = std::move(frames);
    external_frames_ = true;
  } else if (!open_frames(error)) {
    return false;
  }
  if (!open_poses(error)) return false;
  mapper_ = std::make_unique<Mapper>(map_config_, camera_);
  features_ = std::make_unique<FeatureMap>(map_config_, camera_.world_z_up);
  features_->set_camera(camera_);
  mapper_->zones().add_observer(features_.get());
  if (!add_prior_map(error) || !open_sinks(error)) return false;
  open_shared_maps();
  frame_ms_.reserve(1 << 20);  // a day at 10 Hz; beyond it the figures stop growing
  return make_pipeline(error);
}

// The prior map (vehicle.yaml `prior:`): every box in the feature map before the
// first frame; a file with one bad row stops the start with its file and line.
bool VehicleDaemon::add_prior_map(std::string* error) {
  if (config_.prior_path.empty()) return true;
  hal::PriorMap prior;
  if (!hal::load_prior_map(config_.prior_path, camera_.world_z_up, &prior, error)) return false;
  int stored = 0;
  for (const hal::PriorBox& b : prior.boxes) stored += features_->add_prior(b.min, b.max) ? 1 : 0;
  std::fprintf(stderr, "zonemap: prior map %s: %zu obstacles (%d stored whole)\n",
               config_.prior_path.c_str(), prior.boxes.size(), stored);
  return true;
}

// Other vehicles' maps (vehicle.yaml shared_maps): received on a thread of its
// own, taken into the feature map by the extraction thread.
void VehicleDaemon::open_shared_maps() {
  if (!config_.shared_maps) return;
  lcm_link::SharedMapsConfig shared = config_.shared;
  shared.world_z_up = camera_.world_z_up;
  shared_inbox_ = std::make_unique<SharedMapInbox>(shared.max_boxes);
  shared_receiver_ = std::make_unique<lcm_link::LcmSharedMapReceiver>(shared, *shared_inbox_);
}

// Frames from a replay sequence (host, desk) or the V4L2 camera (FPGA depth).
bool VehicleDaemon::open_frames(std::string* error) {
  const VehicleConfig& config = config_;
  if (config.frames == VehicleConfig::FrameSourceKind::kReplay) {
    const ins_log::SequenceInsLogs ins_logs;
    if (!sequence_.open(config.sequence_dir, config.camera_path, map_config_, error, &ins_logs)) {
      return false;
    }
    camera_ = sequence_.camera();
    frames_ = std::make_unique<replay::ReplayFrameSource>(sequence_, config.replay_rate_hz);
    return true;
  }
  if (!hal::load_camera_yaml(config.camera_path, &camera_, error)) return false;
  if (map_config_.depth_scale_override > 0.0)
    camera_.depth_scale = map_config_.depth_scale_override;
  v4l2::V4l2Config v;
  v.device = config.v4l2_device;
  v.format = config.v4l2_format == "Z16" ? v4l2::DepthFormat::kZ16 : v4l2::DepthFormat::kY16;
  v.time = map_config_.timestamps;
  auto camera = std::make_unique<v4l2::V4l2FrameSource>(v, camera_);
  if (!camera->open(error)) return false;
  v4l2_ = camera.get();
  frames_ = std::move(camera);
  return true;
}

// Poses: the sequence's, an INS log read whole at start, or the live INS (LCM, CAN).
bool VehicleDaemon::open_poses(std::string* error) {
  using Poses = VehicleConfig::PoseSourceKind;
  const VehicleConfig& config = config_;
  const bool z_up = camera_.world_z_up;
  const Eigen::Isometry3d& mount = camera_.body_T_camera;
  switch (config.poses) {
    case Poses::kSequence:
      if (sequence_.poses().size() == 0) {
        *error = config.sequence_dir + ": no usable pose in groundtruth.txt";
        return false;
      }
      replay_poses_ = &sequence_.poses();
      return true;
    case Poses::kLcmLog:
    case Poses::kCandump:
      return open_pose_log(error);
    case Poses::kLcm:
      live_poses_ = std::make_unique<lcm_link::LcmPoseSource>(
          config.lcm_url, config.lcm_channel, z_up, config.gate, mount, config.time_offset_s);
      return true;
    case Poses::kCan:
      live_poses_ = std::make_unique<can::SocketCanPoseSource>(
          config.can_interface, config.can_profile, config.gate, mount,
          config.time_offset_s + can::SocketCanPoseSource::monotonic_offset());
      return true;
    case Poses::kMavlink:
      return open_mavlink_poses(error);
  }
  return true;
}

// The autopilot's EKF over MAVLink: positions in its NED frame.
bool VehicleDaemon::open_mavlink_poses(std::string* error) {
  if (camera_.world_z_up) {
    *error =
        "poses.source mavlink gives the autopilot's NED frame: camera.yaml needs "
        "world_z_up: false";
    return false;
  }
  auto source = std::make_unique<mavlink::MavlinkPoseSource>(
      config_.mavlink_poses, config_.gate, camera_.body_T_camera, config_.time_offset_s);
  if (!source->open(error)) return false;
  live_poses_ = std::move(source);
  return true;
}

// A recorded INS log (LCM log, candump), read whole and replayed with the frames.
bool VehicleDaemon::open_pose_log(std::string* error) {
  const VehicleConfig& config = config_;
  ins_log::InsLogSettings settings;
  settings.kind = config.poses == VehicleConfig::PoseSourceKind::kLcmLog
                      ? ins_log::InsLogSettings::Kind::kLcmLog
                      : ins_log::InsLogSettings::Kind::kCandump;
  settings.path = config.pose_log_path;
  settings.lcm_channel = config.lcm_channel;
  settings.can_profile = config.can_profile;
  settings.time_offset_s = config.time_offset_s;
  const std::unique_ptr<hal::PoseSource> log = ins_log::open_ins_log(
      settings, config.gate, camera_.body_T_camera, camera_.world_z_up, error);
  if (!log) return false;
  log_poses_ = PoseTrack(map_config_.pose_max_gap_s, map_config_.pose_tolerance_s);
  pose_counters_ = hal::read_to_end(*log, &log_poses_).counters;
  if (log_poses_.size() == 0) {
    *error = config.pose_log_path + ": no usable INS solution";
    return false;
  }
  replay_poses_ = &log_poses_;
  return true;
}

// The flight controller's links: CAN, LCM, MAVLink, each when configured.
bool VehicleDaemon::open_sinks(std::string* error) {
  const VehicleConfig& config = config_;
  if (config.can_output) {
    sinks_.push_back(std::make_unique<can::CanObstacleSink>(
        config.can_output_interface, config.can_obstacles, features_->capacity()));
  }
  if (config.lcm_output) {
    lcm_link::LcmOutputConfig lcm = config.lcm;
    lcm.body_T_camera = camera_.body_T_camera;  // said on ZONEMAP_MOUNT
    lcm.mount_configured = camera_.mount_configured;
    sinks_.push_back(std::make_unique<lcm_link::LcmObstacleSink>(lcm));
  }
  if (config.mavlink_output) {
    mavlink::MavlinkUdpConfig link = config.mavlink;
    link.kept_boxes = features_->capacity();  // the merged output's sizes: every box fits
    link.kept_rects = runtime::PipelineOptions{}.footprint_rects;
    auto mavlink = std::make_unique<mavlink::MavlinkUdpSink>(link);
    if (!mavlink->open(error)) return false;
    sinks_.push_back(std::move(mavlink));
  }
  if (config.save_map_every_s > 0.0) {
    std::error_code ec;
    std::filesystem::create_directories(config.output_dir, ec);
    auto saver = std::make_unique<hal::MapSaver>(config.output_dir + "/boxes.csv",
                                                 config.save_map_every_s, features_->capacity());
    saver->start();
    map_saver_ = saver.get();
    sinks_.push_back(std::move(saver));
  }
  return true;
}

// The runtime with the config's pipeline: section, the recorder and the sinks.
bool VehicleDaemon::make_pipeline(std::string* error) {
  runtime::PipelineOptions options;
  if (!runtime::load_pipeline_options(config_.mapping_path, &options, error)) return false;
  if (!config_.record_path.empty() && !open_recorder(options.footprint_rects, error)) return false;
  options.lossless = !config_.live;
  options.health_period_s = config_.health_period_s;
  options.body_T_camera = camera_.body_T_camera;
  options.world_z_up = camera_.world_z_up;
  options.sectors = config_.mavlink.sectors;
  options.shared_maps = shared_inbox_.get();
  std::vector<hal::ObstacleSink*> sinks;
  for (auto& s : sinks_) sinks.push_back(s.get());
  pipeline_ = std::make_unique<runtime::Pipeline>(
      *frames_, replay_poses_, live_poses_.get(), sinks, *mapper_, *features_,
      static_cast<runtime::MappingHooks&>(*this), options);
  return true;
}

std::string VehicleDaemon::describe() const {
  std::ostringstream out;
  const auto mib = [](std::size_t b) { return static_cast<double>(b) / 1048576.0; };
  out.precision(2);
  out << std::fixed;
  out << "zonemap: frames from "
      << (external_frames_ ? std::string("the program's own source")
          : config_.frames == VehicleConfig::FrameSourceKind::kReplay ? config_.sequence_dir
                                                                      : config_.v4l2_device)
      << "\nzonemap: poses from "
      << (live_poses_ ? live_poses_->name()
                      : (replay_poses_ == &log_poses_ ? config_.pose_log_path.c_str()
                                                      : "the sequence's groundtruth.txt"))
      << "\n";
  out << "zonemap: " << describe_mount(camera_) << "\n";
  for (const auto& s : sinks_) out << "zonemap: output: " << s->name() << "\n";
  out << "zonemap: reserved " << mib(mapper_->zones().reserved_bytes()) << " MiB zone pool, "
      << mib(mapper_->local_grid().reserved_bytes()) << " MiB local grid, "
      << mib(mapper_->depth_table_bytes()) << " MiB depth table, "
      << mib(features_->reserved_bytes()) << " MiB feature map, "
      << mib(pipeline_->reserved_bytes()) << " MiB pipeline; in all "
      << mib(mapper_->reserved_bytes() + features_->reserved_bytes() + pipeline_->reserved_bytes())
      << " MiB\n";
  if (recorder_ != nullptr) {
    out << "zonemap: recording to " << config_.record_path << " (its own thread; "
        << mib(recorder_->reserved_bytes()) << " MiB of slots, outside the mapping budget)\n";
  }
  if (shared_receiver_) {
    out << "zonemap: maps shared by other vehicles on";
    for (const std::string& c : config_.shared.channels) out << " " << c;
    out << " (" << config_.shared.url << "; its own thread; "
        << mib(shared_inbox_->reserved_bytes()) << " MiB of slots)\n";
  }
  if (map_saver_ != nullptr) {
    out << "zonemap: saving the map every " << config_.save_map_every_s << " s to "
        << config_.output_dir << "/boxes.csv (its own thread; " << mib(map_saver_->reserved_bytes())
        << " MiB, outside the mapping budget)\n";
  }
  return out.str();
}

void VehicleDaemon::after_frame(std::size_t /*frame_index*/, const Eigen::Isometry3d& /*pose*/,
                                const FrameReport& /*report*/, double mapping_ms) {
  ++frames_mapped_;
  if (frame_ms_.size() < frame_ms_.capacity()) frame_ms_.push_back(mapping_ms);
  // Periodic extraction happens on the pipeline's extraction thread.
}

void VehicleDaemon::run() {
  if (shared_receiver_) shared_receiver_->start();
  pipeline_->run();
  if (shared_receiver_) shared_receiver_->stop();
  stats_ = pipeline_->stats();
  if (live_poses_) pose_counters_ = live_poses_->counters();
  // Every live zone's objects into the feature map for the final boxes.
  mapper_->zones().for_each_live_zone([this](ZoneView& zone) { features_->extract(zone); });
  close_recorder();
}

// The recording is one more sink (boxes, sectors, health from the output thread);
// poses and depth come from the mapping thread through frame_mapped().
bool VehicleDaemon::open_recorder(std::size_t footprint_rects, std::string* error) {
  record::RecorderConfig rc =
      record::recorder_config_for(camera_, features_->capacity(), footprint_rects);
  rc.path = config_.record_path;
  rc.sectors = config_.mavlink.sectors;
  std::error_code ec;
  std::filesystem::create_directories(std::filesystem::path(rc.path).parent_path(), ec);
  auto recorder = std::make_unique<record::FlightRecorder>();
  if (!recorder->open(rc, error)) return false;
  recorder_ = recorder.get();
  sinks_.push_back(std::move(recorder));
  return true;
}

void VehicleDaemon::frame_mapped(const hal::CameraFrame& frame, const Eigen::Isometry3d& pose) {
  last_time_s_ = frame.time_s;
  last_world_T_camera_ = pose;
  if (recorder_ == nullptr) return;
  recorder_->record_pose(frame.time_s, pose * camera_.body_T_camera.inverse());
  if (config_.record_depth_every > 0 && depth_offered_++ % config_.record_depth_every == 0) {
    recorder_->record_depth(frame.time_s, frame.depth.data());
  }
}

// The final scene (every feature, with footprints), then the file's summary.
void VehicleDaemon::close_recorder() {
  if (recorder_ == nullptr) return;
  hal::MergedUpdate final_scene;
  final_scene.reserve(features_->capacity(), 1 << 16);
  const hal::ObstacleUpdate update =
      final_scene.fill(*features_, true, last_time_s_,
                       last_world_T_camera_ * camera_.body_T_camera.inverse(), camera_.world_z_up);
  recorder_->record_final_boxes(update);
  // The grid is the mapping thread's during the flight: its cells go in once, now.
  recorder_->record_occupied(last_time_s_, *mapper_);
  std::string error;
  if (!recorder_->close(&error)) std::fprintf(stderr, "zonemap: recording: %s\n", error.c_str());
}

void VehicleDaemon::stop() {
  if (pipeline_) pipeline_->stop();
}

bool VehicleDaemon::write_outputs(std::string* error) {
  if (config_.output_dir.empty()) return true;
  if (map_saver_ != nullptr) map_saver_->stop();  // its last save done: the final one wins
  std::error_code ec;
  std::filesystem::create_directories(config_.output_dir, ec);
  std::vector<ObstacleBox> boxes(features_->capacity());
  boxes.resize(features_->merged(boxes.data(), boxes.size(), true));
  if (!hal::write_boxes_csv(config_.output_dir + "/boxes.csv", boxes.data(), boxes.size(), error)) {
    return false;
  }
  hal::RunStats s;
  runtime::add_to_run_stats(stats_, &s);
  s.frames_mapped = stats_.frames_mapped;
  s.frame_ms_p50 = hal::percentile(frame_ms_, 0.50);
  s.frame_ms_p99 = hal::percentile(frame_ms_, 0.99);
  s.frame_ms_max = frame_ms_.empty() ? 0.0 : *std::max_element(frame_ms_.begin(), frame_ms_.end());
  s.zone_pool_bytes = mapper_->zones().reserved_bytes();
  s.local_grid_bytes = mapper_->local_grid().reserved_bytes();
  s.feature_map_bytes = features_->reserved_bytes();
  s.depth_table_bytes = mapper_->depth_table_bytes();
  s.pipeline_bytes = pipeline_->reserved_bytes();
  s.static_memory_bytes =
      mapper_->reserved_bytes() + features_->reserved_bytes() + pipeline_->reserved_bytes();
  s.zones_allocated = mapper_->zones().zones_allocated();
  s.zones_discarded = mapper_->zones().zones_discarded();
  s.features = static_cast<std::int64_t>(features_->count());
  s.feature_counters = features_->counters();
  s.cell_size_m = map_config_.cell_size_m;
  s.pixels_sky = stats_.pixels_sky;
  s.pixels_sky_refused = stats_.pixels_sky_refused;
  s.sky_refused_max_frame = stats_.sky_refused_max_frame;
  s.poses_rejected = pose_counters_.gate.rejected_total() + pose_counters_.malformed;
  s.frames_ground_below_environment = stats_.frames_ground_below_environment;
  // Every sink's and the INS source's counters under "links".
  hal::HealthSnapshot links;
  links.add("ins_messages", pose_counters_.messages);
  links.add("ins_malformed", pose_counters_.malformed);
  links.add("ins_solutions", pose_counters_.solutions);
  links.add("ins_poses_out", pose_counters_.poses_out);
  links.add("ins_link_errors", pose_counters_.link_errors);
  links.add("ins_reanchors", pose_counters_.gate.reanchors);
  links.add("ins_clock_steps", pose_counters_.gate.clock_steps);
  links.add("ins_incomplete", pose_counters_.incomplete);
  links.add("ins_time_syncs", pose_counters_.time_syncs);
  links.add("ins_time_sync_steps", pose_counters_.time_sync_steps);
  for (int r = 0; r < static_cast<int>(InsRejection::kCount); ++r) {
    static const char* const kNames[] = {"ins_rejected_not_finite",  "ins_rejected_quaternion",
                                         "ins_rejected_flags",       "ins_rejected_time",
                                         "ins_rejected_jump",        "ins_rejected_accuracy",
                                         "ins_rejected_time_outlier"};
    static_assert(std::size(kNames) == static_cast<std::size_t>(InsRejection::kCount));
    links.add(kNames[r], pose_counters_.gate.rejected[static_cast<std::size_t>(r)]);
  }
  links.add("frames_lost", stats_.frames_lost);
  if (v4l2_ != nullptr) {
    const v4l2::V4l2Counters v = v4l2_->counters();
    links.add("v4l2_rejected_size", v.rejected_size);
    links.add("v4l2_rejected_error", v.rejected_error);
    links.add("v4l2_rejected_time", v.rejected_time);
    links.add("v4l2_time_repeated", v.time_repeated);
    links.add("v4l2_time_past", v.time_past);
    links.add("v4l2_time_future", v.time_future);
    links.add("v4l2_sequence_outliers", v.sequence_outliers);
    links.add("v4l2_clock_steps", v.clock_steps);
  }
  if (shared_receiver_) {
    const lcm_link::SharedMapCounters& c = shared_receiver_->counters();
    links.add("shared_maps_in", c.maps);
    links.add("shared_maps_malformed", c.malformed);
    links.add("shared_maps_refused_no_origin", c.refused_no_origin);
    links.add("shared_maps_refused_own", c.refused_own);
    links.add("shared_maps_refused_frame", c.refused_frame);
    links.add("shared_maps_no_slot", c.no_slot);
    links.add("shared_boxes_taken", c.boxes_taken);
    links.add("shared_boxes_not_measured", c.boxes_not_measured);
    links.add("shared_boxes_rejected", c.boxes_rejected);
    links.add("shared_boxes_over_capacity", c.boxes_over_capacity);
    links.add("shared_provider_start_failures", shared_receiver_->start_failures());
  }
  links.add("health_published", stats_.health_published);
  links.add("stopped_by_signal", stats_.stopped ? 1 : 0);
  for (const auto& sink : sinks_) sink->report(&links);
  for (int i = 0; i < links.named; ++i) s.links.emplace_back(links.names[i], links.values[i]);
  return hal::write_stats_json(config_.output_dir + "/stats.json", s, error);
}

}  // namespace zonemap::onboard
