#include "tools/replay/replay_run.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <span>

#include "hal/config/prior_map.hpp"
#include "hal/config/yaml_config.hpp"
#include "hal/ins_log/ins_logs.hpp"
#include "hal/os/allocation_counter.hpp"
#include "hal/os/clock.hpp"
#include "hal/output/height_png.hpp"
#include "hal/replay/replay_frame_source.hpp"
#include "runtime/runtime_config.hpp"
#include "tools/eval/evaluate.hpp"
#include "tools/report/report.hpp"

namespace zonemap::tools {
namespace {
constexpr std::int64_t kLoggedPerKind = 5;        // then only the totals in stats.json
constexpr double kRecordedOccupiedPeriodS = 1.0;  // occupied cells into the recording
constexpr double kRecordedBoxesPeriodS = 0.5;     // boxes, when they changed
constexpr std::size_t kRecordedRects = 16384;     // footprint rectangles per update
std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}
double mebibytes(std::uint64_t bytes) {
  return static_cast<double>(bytes) / 1048576.0;
}
}  // namespace

// What the sequence's lists refused, by kind (stats.json "rejections").
void ReplayRun::count_list_rejections() {
  std::int64_t future = 0, past = 0, repeated = 0, not_finite = 0, steps = 0;
  for (std::size_t i = 0; i < sequence_.frame_count(); ++i) {
    const replay::FrameListEntry& e = sequence_.entry(i);
    future += e.time_verdict == TimeVerdict::kFuture;
    past += e.time_verdict == TimeVerdict::kPast;
    repeated += e.time_verdict == TimeVerdict::kRepeated;
    not_finite += e.time_verdict == TimeVerdict::kNotFinite;
    steps += e.time_verdict == TimeVerdict::kAdopted &&
             (i == 0 || sequence_.entry(i - 1).time_verdict != TimeVerdict::kAdopted);
  }
  const replay::PoseListCounts& p = sequence_.pose_counts();
  stats_.rejections = {{"frames_time_future", future},
                       {"frames_time_past", past},
                       {"frames_time_repeated", repeated},
                       {"frames_time_not_finite", not_finite},
                       {"frames_clock_steps", steps},
                       {"poses_not_finite", p.not_finite},
                       {"poses_quaternion", p.quaternion},
                       {"poses_time_past", p.time_past},
                       {"poses_time_repeated", p.time_repeated},
                       {"poses_time_future", p.time_future},
                       {"poses_jump", p.jump},
                       {"poses_reanchors", p.reanchors},
                       {"poses_clock_steps", p.clock_steps},
                       {"poses_log_malformed", p.log_malformed},
                       {"poses_log_implausible", p.log_implausible}};
}

void ReplayRun::log_rejection(const char* kind, std::int64_t count,
                              const std::string& message) const {
  if (options_.quiet) return;
  if (count <= kLoggedPerKind) {
    // Starts a line of its own only when the progress line holds the cursor.
    std::fprintf(stderr, "%szonemap-replay: %s: %s\n", progress_shown_ ? "\n" : "", kind,
                 message.c_str());
    progress_shown_ = false;
  }
  if (count == kLoggedPerKind) {
    std::fprintf(stderr, "zonemap-replay: further '%s' are counted in stats.json, not logged\n",
                 kind);
  }
}

bool ReplayRun::open(const ReplayOptions& options, std::string* error) {
  options_ = options;
  if (!hal::load_map_config(options.config_path, &config_, error)) return false;
  if (!runtime::load_pipeline_options(options.config_path, &pipeline_options_, error)) return false;
  const ins_log::SequenceInsLogs ins_logs;
  if (!sequence_.open(options.sequence_dir, options.camera_path, config_, error, &ins_logs)) {
    return false;
  }
  if (sequence_.poses().size() == 0) {
    *error = options.sequence_dir + "/groundtruth.txt: no usable pose";
    return false;
  }
  if (!options.quiet) {
    for (const auto& w : sequence_.warnings())
      std::fprintf(stderr, "zonemap-replay: %s\n", w.c_str());
  }
  stats_ = hal::RunStats{};
  stats_.poses_rejected = sequence_.poses_rejected();
  count_list_rejections();
  stats_.cell_size_m = config_.cell_size_m;
  schedule_ = ExtractionSchedule(config_.features.extract_every_frames);

  mapper_ = std::make_unique<Mapper>(config_, sequence_.camera());
  features_ = std::make_unique<FeatureMap>(config_, sequence_.camera().world_z_up);
  features_->set_camera(sequence_.camera());
  mapper_->zones().add_observer(features_.get());
  if (!options.prior_path.empty() && !add_prior_map(options.prior_path, options.quiet, error)) {
    return false;
  }

  // The height profile covers every zone the flight can touch: the trajectory's
  // extent plus one and a half zones on each side.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY);
  Eigen::Vector3d hi = Eigen::Vector3d::Constant(-INFINITY);
  for (const PoseSample& s : sequence_.poses().samples()) {
    lo = lo.cwiseMin(s.position);
    hi = hi.cwiseMax(s.position);
  }
  const CellIndex lo_cell = mapper_->cell_of(lo);
  const CellIndex hi_cell = mapper_->cell_of(hi);
  const auto& dims = config_.zone_cells;
  height_ = std::make_unique<HeightProfile>(
      lo_cell.x - dims[0] * 3 / 2, lo_cell.y - dims[1] * 3 / 2, hi_cell.x + dims[0] * 3 / 2,
      hi_cell.y + dims[1] * 3 / 2, mapper_->occupied_threshold(), sequence_.camera().world_z_up);
  mapper_->zones().add_observer(height_.get());

  const std::size_t n = sequence_.frame_count();
  frame_ms_.reserve(n);
  extract_ms_.reserve(n + 2);
  trajectory_.reserve(n);
  mapped_frames_.reserve(n);
  stats_.zone_pool_bytes = mapper_->zones().reserved_bytes();
  stats_.local_grid_bytes = mapper_->local_grid().reserved_bytes();
  stats_.feature_map_bytes = features_->reserved_bytes();
  stats_.depth_table_bytes = mapper_->depth_table_bytes();
  stats_.static_memory_bytes = mapper_->reserved_bytes() + features_->reserved_bytes();
  if (!options.quiet) {
    const auto& cam = sequence_.camera();
    std::fprintf(stderr,
                 "zonemap-replay: %zu frames %dx%d, cells %.3f m, zones %dx%dx%d, d %.2f..%.2f m\n"
                 "zonemap-replay: reserved %.1f MiB: zone pool %.1f MiB (8 x %zu cells x %zu B), "
                 "local grid %.1f MiB, feature map %.1f MiB (%d features), depth table %.1f MiB\n",
                 n, cam.width, cam.height, config_.cell_size_m, dims[0], dims[1], dims[2],
                 config_.d_min_m, config_.d_max_m, mebibytes(stats_.static_memory_bytes),
                 mebibytes(stats_.zone_pool_bytes), zone_cell_count(config_), sizeof(FusedCell),
                 mebibytes(stats_.local_grid_bytes), mebibytes(stats_.feature_map_bytes),
                 config_.features.capacity, mebibytes(stats_.depth_table_bytes));
  }
  if (!options.links_dir.empty() && !open_links(error)) return false;
  return options.record_path.empty() || open_recorder(error);
}

// The recording's own thread and slots; the replay loop only copies into them.
bool ReplayRun::open_recorder(std::string* error) {
  record::RecorderConfig rc =
      record::recorder_config_for(sequence_.camera(), features_->capacity(), kRecordedRects);
  rc.path = options_.record_path;
  rc.sectors.max_distance_m = std::min(rc.sectors.max_distance_m, config_.d_max_m);
  update_.reserve(rc.max_boxes, rc.max_rects);
  recorder_ = std::make_unique<record::FlightRecorder>();
  return recorder_->open(rc, error);
}

void ReplayRun::record_frame(const hal::CameraFrame& frame, const Eigen::Isometry3d& pose) {
  if (!recorder_) return;
  const double t = frame.time_s;
  frame_mapped(frame, pose);
  if (t - recorded_occupied_s_ >= kRecordedOccupiedPeriodS) {
    recorded_occupied_s_ = t;
    recorder_->record_occupied(t, *mapper_);
  }
  if (boxes_changed_ && t - recorded_boxes_s_ >= kRecordedBoxesPeriodS) {
    record_boxes(t, pose, false);
  }
  if (t - recorded_health_s_ >= 1.0) record_health(t);
}

// The pose and every n-th depth of a mapped frame (on the pipeline's mapping
// thread too: copies into reserved slots); boxes and sectors reach the recorder
// as a sink of the output thread.
void ReplayRun::frame_mapped(const hal::CameraFrame& frame, const Eigen::Isometry3d& pose) {
  if (!recorder_) return;
  recorder_->record_pose(frame.time_s, pose * sequence_.camera().body_T_camera.inverse());
  if (options_.record_depth_every > 0 && depth_offered_++ % options_.record_depth_every == 0) {
    recorder_->record_depth(frame.time_s, frame.depth.data());
  }
}

// The merged boxes with their footprints and the sectors the map has seen around
// the vehicle.
hal::ObstacleUpdate ReplayRun::fill_update(hal::MergedUpdate& storage, bool include_ground,
                                           double time_s, const Eigen::Isometry3d& world_T_camera) {
  const CameraModel& cam = sequence_.camera();
  hal::ObstacleUpdate update =
      storage.fill(*features_, include_ground, time_s, world_T_camera * cam.body_T_camera.inverse(),
                   cam.world_z_up);
  SectorConfig sectors;
  sectors.max_distance_m = std::min(sectors.max_distance_m, config_.d_max_m);
  update.sectors_observed = observed_sectors(mapper_->zones(), config_.cell_size_m,
                                             update.world_T_body, update.world_z_up, sectors);
  return update;
}

// Ground too, as boxes.csv has them.
void ReplayRun::record_boxes(double time_s, const Eigen::Isometry3d& world_T_camera, bool final) {
  const hal::ObstacleUpdate update = fill_update(update_, true, time_s, world_T_camera);
  recorded_boxes_s_ = time_s;
  boxes_changed_ = false;
  if (final) {
    recorder_->record_final_boxes(update);
  } else {
    recorder_->record_boxes(update);
  }
}

// The links as the daemon feeds them: obstacles only, every publish_every_frames
// mapped frames and once at the end.
bool ReplayRun::open_links(std::string* error) {
  SectorConfig sectors;
  sectors.max_distance_m = std::min(sectors.max_distance_m, config_.d_max_m);
  links_update_.reserve(features_->capacity(), kRecordedRects);
  links_every_frames_ = pipeline_options_.publish_every_frames;
  links_ = std::make_unique<LinkCapture>();
  return links_->open(options_.links_dir, sequence_.camera(), sectors, features_->capacity(),
                      error);
}

void ReplayRun::capture_links(double time_s, const Eigen::Isometry3d& world_T_camera) {
  links_->publish(fill_update(links_update_, false, time_s, world_T_camera), time_s);
}

void ReplayRun::record_health(double time_s) {
  recorded_health_s_ = time_s;
  hal::HealthSnapshot h;
  h.time_s = time_s;
  h.frames_in = stats_.frames_in;
  h.frames_mapped = stats_.frames_mapped;
  h.frames_rejected = stats_.frames_rejected;
  h.frames_skipped_no_pose = stats_.frames_skipped_no_pose;
  h.poses_rejected = stats_.poses_rejected;
  h.heap_allocations_after_init = stats_.heap_allocations_after_init;
  h.zones_allocated = static_cast<std::int32_t>(mapper_->zones().zones_allocated());
  h.features = static_cast<std::int32_t>(features_->count());
  h.mapping_ms_p50 = frame_ms_.empty() ? 0.0 : frame_ms_.back();
  h.add("rays_hit", stats_.rays_hit);
  h.add("cells_visited", stats_.cells_visited);
  h.add("pixels_sky", stats_.pixels_sky);
  h.add("pixels_sky_refused", stats_.pixels_sky_refused);
  h.add("sky_last_frame", last_sky_);
  h.add("sky_refused_last_frame", last_sky_refused_);
  recorder_->record_health(h);
}

void ReplayRun::run_frames(std::size_t first, std::size_t last) {
  hal::CameraFrame frame = sequence_.make_frame();
  std::string why;
  const std::size_t n = std::min(last, sequence_.frame_count());
  const bool show_progress = options_.progress && isatty(STDERR_FILENO);
  const auto started = os::Clock::now();
  auto last_progress = started;
  for (std::size_t i = first; i < n; ++i) {
    ++stats_.frames_in;
    // Decoding files is the host HAL's work, outside the mapping path's count.
    if (!sequence_.read(i, &frame, &why)) {
      ++stats_.frames_rejected;
      if (!sequence_.entry(i).time_in_order) {
        log_rejection("frame out of order", ++stats_.frames_rejected_time_order, why);
      } else {
        log_rejection("frame unreadable", ++stats_.frames_rejected_bad_image, why);
      }
      continue;
    }
    if (!frame.left_problem.empty()) {
      ++stats_.left_images_rejected;
      log_rejection("left image unusable (sky filter off for the frame)",
                    stats_.left_images_rejected, frame.left_problem);
    }
    Eigen::Isometry3d pose;
    if (sequence_.poses().lookup(frame.time_s, &pose) == PoseLookup::kNoPose) {
      ++stats_.frames_skipped_no_pose;
      char msg[96];
      std::snprintf(msg, sizeof(msg), "t=%.6f has no pose within tolerance", frame.time_s);
      log_rejection("frame skipped", stats_.frames_skipped_no_pose, msg);
      continue;
    }
    DepthFrameView view;
    view.depth = frame.depth.data();
    view.left = frame.has_left ? frame.left.data() : nullptr;
    view.width = sequence_.camera().width;
    view.height = sequence_.camera().height;

    FrameReport report;
    const auto start = os::Clock::now();
    {
      os::AllocationScope scope;
      features_->set_context(frame.time_s, pose);
      report = mapper_->integrate(view, pose);
      const os::AllocationCounts counted = scope.counted();
      stats_.heap_allocations_after_init += counted.allocations;
      stats_.heap_frees_after_init += counted.frees;
    }
    const double ms = os::ms_between(start, os::Clock::now());
    if (report.status != FrameStatus::kMapped) {
      ++stats_.frames_rejected;
      const bool bad_pose = report.status == FrameStatus::kBadPose;
      const std::int64_t count =
          bad_pose ? ++stats_.frames_rejected_bad_pose : ++stats_.frames_rejected_bad_image;
      log_rejection(bad_pose ? "frame with bad pose" : "frame with bad image", count,
                    sequence_.entry(i).path);
      continue;
    }
    account_mapped_frame(i, pose, report, ms);
    record_frame(frame, pose);
    if (links_ && stats_.frames_mapped % links_every_frames_ == 0)
      capture_links(frame.time_s, pose);
    const auto now = os::Clock::now();
    if (show_progress && (now - last_progress > std::chrono::milliseconds(250) || i + 1 == n)) {
      last_progress = now;
      // Frames done, the rate so far and the time left at that rate.
      const double elapsed_s = os::seconds_since(started);
      const double rate = elapsed_s > 0.0 ? static_cast<double>(i + 1 - first) / elapsed_s : 0.0;
      const double left_s = rate > 0.0 ? static_cast<double>(n - i - 1) / rate : 0.0;
      std::fprintf(stderr,
                   "\rzonemap-replay: frame %zu/%zu, %.1f frames/s, %.0f s left, %.1f ms, %d zones "
                   "live   ",
                   i + 1, n, rate, left_s, ms, mapper_->zones().live_zone_count());
      progress_shown_ = true;
    }
  }
  if (progress_shown_) std::fprintf(stderr, "\n");
  progress_shown_ = false;
}

void ReplayRun::account_mapped_frame(std::size_t frame_index, const Eigen::Isometry3d& pose,
                                     const FrameReport& report, double mapping_ms) {
  // Everything here writes into storage reserved at open(): it runs on the
  // pipeline's mapping thread too.
  ++stats_.frames_mapped;
  last_time_s_ = sequence_.entry(frame_index).time_s;
  last_world_T_camera_ = pose;
  frame_ms_.push_back(mapping_ms);
  // Periodic extraction (ExtractionSchedule); the pipeline does its own on its
  // extraction thread, on the same schedule.
  if (!in_pipeline_) {
    const int pick =
        schedule_.after_frame(stats_.frames_mapped, mapper_->zones().live_zone_count());
    if (pick >= 0) extract_zone(pick);
  }
  if (!in_pipeline_) log_feature_store_events();
  trajectory_.push_back(pose.translation());
  mapped_frames_.push_back(frame_index);
  stats_.rays_hit += report.rays_hit;
  stats_.cells_visited += report.cells_visited;
  stats_.rays_free += report.rays_free;
  stats_.pixels_sky += report.pixels_sky;
  stats_.pixels_sky_refused += report.pixels_sky_refused;
  stats_.sky_refused_max_frame =
      std::max<std::int64_t>(stats_.sky_refused_max_frame, report.pixels_sky_refused);
  last_sky_ = report.pixels_sky;
  last_sky_refused_ = report.pixels_sky_refused;
  stats_.pixels_missing += report.pixels_missing;
  stats_.pixels_too_near += report.pixels_too_near;
  stats_.frames_ground_below_environment += ground_below_environment(report) ? 1 : 0;
}

void ReplayRun::after_frame(std::size_t frame_index, const Eigen::Isometry3d& pose,
                            const FrameReport& report, double mapping_ms) {
  account_mapped_frame(frame_index, pose, report, mapping_ms);
}

void ReplayRun::run_pipelined(const runtime::PipelineOptions& options) {
  in_pipeline_ = true;
  replay::ReplayFrameSource frames(sequence_, options.source_rate_hz);
  hal::ObstacleSink* recorder_sink = recorder_.get();
  const std::span<hal::ObstacleSink* const> sinks(&recorder_sink, recorder_ ? 1 : 0);
  runtime::PipelineOptions with_ground = options;
  // The recording shows every box, as boxes.csv does.
  with_ground.include_ground = options.include_ground || recorder_ != nullptr;
  runtime::Pipeline pipeline(frames, &sequence_.poses(), nullptr, sinks, *mapper_, *features_,
                             *this, with_ground);
  stats_.pipeline_bytes = pipeline.reserved_bytes();
  stats_.static_memory_bytes += stats_.pipeline_bytes;
  if (!options_.quiet) {
    std::fprintf(stderr,
                 "zonemap-replay: pipeline reserved %.1f MiB (frame pool, output buffers)\n",
                 mebibytes(stats_.pipeline_bytes));
  }
  pipeline.run();
  in_pipeline_ = false;
  pipeline_stats_ = pipeline.stats();
  const runtime::PipelineStats& p = pipeline_stats_;
  runtime::add_to_run_stats(p, &stats_);
  if (!options_.quiet) {
    for (const auto& w : p.warnings) std::fprintf(stderr, "zonemap-replay: %s\n", w.c_str());
  }
  log_feature_store_events();
  finish();
  // Extraction timing: the pipeline's extraction thread, one zone snapshot each.
  if (p.extractions > 0) {
    stats_.extract_ms_p50 = p.extraction.percentile(0.50);
    stats_.extract_ms_max = p.extraction.max_ms();
  }
}

void ReplayRun::finish() {
  extract_live_zones();
  // The zones still holding a grid join the height profile too.
  mapper_->zones().for_each_live_zone([this](ZoneView& zone) { height_->fold(zone); });
  stats_.frame_ms_p50 = hal::percentile(frame_ms_, 0.50);
  stats_.frame_ms_p99 = hal::percentile(frame_ms_, 0.99);
  stats_.frame_ms_max =
      frame_ms_.empty() ? 0.0 : *std::max_element(frame_ms_.begin(), frame_ms_.end());
  stats_.zones_allocated = mapper_->zones().zones_allocated();
  stats_.zones_discarded = mapper_->zones().zones_discarded();
  stats_.height_profile_columns_outside = height_->columns_outside();
  stats_.extract_ms_p50 = hal::percentile(extract_ms_, 0.50);
  stats_.extract_ms_max =
      extract_ms_.empty() ? 0.0 : *std::max_element(extract_ms_.begin(), extract_ms_.end());
  stats_.features = static_cast<std::int64_t>(features_->count());
  stats_.feature_counters = features_->counters();
  if (recorder_) close_recording();
  if (links_) {
    capture_links(last_time_s_, last_world_T_camera_);
    links_->close();
  }
  warn_if_ground_out_of_reach();
  finished_ = true;
}

void ReplayRun::warn_if_ground_out_of_reach() const {
  if (options_.quiet || stats_.frames_ground_below_environment == 0) return;
  std::fprintf(stderr,
               "%szonemap-replay: warning: in %lld of %lld frames most of what the camera "
               "measured lies under the environment (map.environment, above_camera_m, "
               "zone_cells): the ground and the lower part of what stands on it are not mapped\n",
               progress_shown_ ? "\n" : "",
               static_cast<long long>(stats_.frames_ground_below_environment),
               static_cast<long long>(stats_.frames_mapped));
  progress_shown_ = false;
}

// The last occupied cells, every feature (as boxes.csv will have them), the last
// health; then the recorder drains its queues and writes the summary.
void ReplayRun::close_recording() {
  const double t = last_time_s_;
  recorder_->record_occupied(t, *mapper_);
  record_boxes(t, last_world_T_camera_, true);
  record_health(t);
  std::string error;
  if (!recorder_->close(&error) && !options_.quiet) {
    std::fprintf(stderr, "zonemap-replay: recording: %s\n", error.c_str());
  }
  const record::RecorderCounts c = recorder_->counts();
  stats_.recording = {{"messages", c.messages},
                      {"bytes", c.bytes},
                      {"bytes_uncompressed", c.bytes_uncompressed},
                      {"chunks", c.chunks},
                      {"boxes_updates", c.boxes_updates},
                      {"occupied_clouds", c.occupied_clouds},
                      {"occupied_truncated", c.occupied_truncated},
                      {"poses", c.poses},
                      {"depth_images", c.depth_images},
                      {"health", c.health},
                      {"dropped", c.dropped},
                      {"reserved_bytes", static_cast<std::int64_t>(recorder_->reserved_bytes())}};
  recorder_.reset();
}

void ReplayRun::extract_live_zones() {
  const auto start = os::Clock::now();
  {
    os::AllocationScope scope;
    mapper_->zones().for_each_live_zone([this](ZoneView& zone) { features_->extract(zone); });
    const os::AllocationCounts counted = scope.counted();
    stats_.heap_allocations_after_init += counted.allocations;
    stats_.heap_frees_after_init += counted.frees;
  }
  extract_ms_.push_back(os::ms_between(start, os::Clock::now()));
  if (!in_pipeline_) log_feature_store_events();
}

void ReplayRun::extract_zone(int pick) {
  const auto start = os::Clock::now();
  {
    os::AllocationScope scope;
    ZoneView zone;
    if (mapper_->zones().nth_live_view(pick, &zone)) features_->extract(zone);
    boxes_changed_ = true;
    const os::AllocationCounts counted = scope.counted();
    stats_.heap_allocations_after_init += counted.allocations;
    stats_.heap_frees_after_init += counted.frees;
  }
  extract_ms_.push_back(os::ms_between(start, os::Clock::now()));
}

void ReplayRun::log_feature_store_events() {
  // The core counts; the edge says it (first few times, then stats.json holds it).
  const FeatureCounters& now = features_->counters();
  auto report = [&](std::int64_t current, std::int64_t* logged, const char* what) {
    if (current == *logged) return;
    *logged = current;
    log_rejection(what, current,
                  std::to_string(current) + " so far (features.capacity / quadtree_groups)");
  };
  report(now.features_evicted, &logged_counters_.features_evicted,
         "feature store full: less relevant feature evicted");
  report(now.features_dropped, &logged_counters_.features_dropped,
         "feature store full: new feature dropped");
  report(now.shapes_truncated, &logged_counters_.shapes_truncated,
         "quadtree pool full: box kept without shape");
  log_removals();
}

// Every feature removal with its id and evidence (the store keeps the last few:
// the single-threaded run drains them after each extraction).
void ReplayRun::log_removals() {
  const std::int64_t recorded = features_->removals_recorded();
  const auto kept = static_cast<std::int64_t>(FeatureMap::kRemovalsKept);
  if (recorded - removals_logged_ > kept) {
    if (!options_.quiet) {
      std::fprintf(stderr,
                   "zonemap-replay: %lld feature removals not listed (counted in stats.json)\n",
                   static_cast<long long>(recorded - removals_logged_ - kept));
    }
    removals_logged_ = recorded - kept;
  }
  for (; removals_logged_ < recorded; ++removals_logged_) {
    if (options_.quiet) continue;
    const FeatureRemoval& r = features_->removal(removals_logged_);
    const double c = config_.cell_size_m;
    std::fprintf(stderr,
                 "%szonemap-replay: feature %u (%s%s, %d cells, x %.1f..%.1f y %.1f..%.1f z "
                 "%.1f..%.1f m) removed at %.2f s: %s (%d of its cells occupied)\n",
                 progress_shown_ ? "\n" : "", r.id,
                 r.kind == FeatureKind::kGround ? "ground" : "obstacle", r.prior ? ", prior" : "",
                 r.cells, r.min.x * c, (r.max.x + 1) * c, r.min.y * c, (r.max.y + 1) * c,
                 r.min.z * c, (r.max.z + 1) * c, r.time_s, to_string(r.cause), r.occupied);
    progress_shown_ = false;
  }
}

std::vector<ObstacleBox> ReplayRun::boxes(bool include_ground) {
  std::vector<ObstacleBox> out(features_->capacity());
  out.resize(features_->merged(out.data(), out.size(), include_ground));
  return out;
}

bool ReplayRun::write_outputs(const std::string& out_dir, std::string* error) {
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  if (ec) {
    *error = out_dir + ": cannot create (" + ec.message() + ")";
    return false;
  }
  const std::int64_t occupied = hal::write_occupied_ply(out_dir + "/occupied.ply", *mapper_, error);
  if (occupied < 0) return false;
  stats_.occupied_cells_final = occupied;
  const std::vector<ObstacleBox> all = boxes(true);
  if (!hal::write_boxes_csv(out_dir + "/boxes.csv", all.data(), all.size(), error)) return false;
  std::vector<Eigen::Vector4d> outlines;
  stats_.obstacle_boxes = 0;
  stats_.ground_boxes = 0;
  for (const ObstacleBox& b : all) {
    if (b.kind == FeatureKind::kGround) {
      ++stats_.ground_boxes;
      continue;
    }
    ++stats_.obstacle_boxes;
    outlines.emplace_back(b.min.x(), b.min.y(), b.max.x(), b.max.y());
  }
  if (!hal::write_height_png(out_dir + "/height.png", *height_, config_.cell_size_m, trajectory_,
                             outlines, error)) {
    return false;
  }
  return hal::write_stats_json(out_dir + "/stats.json", stats_, error) &&
         write_report(out_dir, error);
}

// OUT/report.html from what was just written and the run's own figures; the
// evaluation when the sequence has objects.yaml (as zonemap-eval computes it).
bool ReplayRun::write_report(const std::string& out_dir, std::string* error) {
  ReportInputs in;
  in.title = std::filesystem::path(options_.sequence_dir).lexically_normal().string();
  in.stats_json = read_file(out_dir + "/stats.json");
  in.height_png = read_file(out_dir + "/height.png");
  const std::string objects_path = options_.sequence_dir + "/objects.yaml";
  std::vector<TruthObject> objects;
  std::vector<RunBox> run_boxes;
  std::string eval_error;
  if (std::filesystem::exists(objects_path) &&
      load_objects_yaml(objects_path, &objects, &eval_error) &&
      load_boxes_csv(out_dir + "/boxes.csv", &run_boxes, &eval_error)) {
    in.evaluation_json = to_json(evaluate(objects, run_boxes, config_.cell_size_m));
  }
  hal::MergedUpdate merged;
  merged.reserve(features_->capacity(), kRecordedRects);
  const hal::ObstacleUpdate all =
      merged.fill(*features_, true, last_time_s_, Eigen::Isometry3d::Identity(), true);
  in.boxes.assign(all.boxes, all.boxes + all.count);
  for (std::size_t i = 0; i < all.count; ++i) {
    const FootprintRect* first = all.rects + all.rect_offsets[i];
    in.footprints.emplace_back(first, first + all.rect_counts[i]);
  }
  in.trajectory = trajectory_;
  in.occupied = occupied_sample(kReportOccupiedCells);
  in.frame_ms = frame_ms_;
  const LatencyHistogram& e2e = pipeline_stats_.end_to_end;
  for (int b = 0; b < LatencyHistogram::kBins; ++b) {
    if (e2e.bin_count(b) > 0)
      in.end_to_end_bins.emplace_back(LatencyHistogram::upper_edge(b), e2e.bin_count(b));
  }
  in.world_z_up = sequence_.camera().world_z_up;
  in.cell_size_m = config_.cell_size_m;
  return tools::write_report(out_dir + "/report.html", in, error);
}

// The live zones' occupied cell centres, every n-th when there are more than `most`.
std::vector<float> ReplayRun::occupied_sample(std::size_t most) {
  std::vector<float> all;
  mapper_->for_each_occupied_cell([&](const Eigen::Vector3d& c, FusedCell) {
    all.insert(all.end(),
               {static_cast<float>(c.x()), static_cast<float>(c.y()), static_cast<float>(c.z())});
  });
  const std::size_t cells = all.size() / 3;
  if (cells <= most) return all;
  std::vector<float> sample;
  sample.reserve(most * 3);
  for (std::size_t i = 0; i < most; ++i) {
    const std::size_t pick = i * cells / most;
    sample.insert(sample.end(), all.begin() + 3 * pick, all.begin() + 3 * pick + 3);
  }
  return sample;
}

// A prior map: every box in the feature map before the first frame (the
// paper's a-priori knowledge); a file with one bad row is not used at all.
bool ReplayRun::add_prior_map(const std::string& path, bool quiet, std::string* error) {
  hal::PriorMap prior;
  if (!hal::load_prior_map(path, sequence_.camera().world_z_up, &prior, error)) return false;
  int stored = 0;
  for (const hal::PriorBox& b : prior.boxes) stored += features_->add_prior(b.min, b.max) ? 1 : 0;
  if (!quiet) {
    std::fprintf(stderr,
                 "zonemap-replay: prior map %s: %zu obstacles (%d stored whole, %d ground rows "
                 "skipped)\n",
                 path.c_str(), prior.boxes.size(), stored, prior.ground_rows_skipped);
  }
  return true;
}

}  // namespace zonemap::tools
