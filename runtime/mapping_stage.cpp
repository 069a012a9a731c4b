// The mapping loop: a frame, its pose (waited for a bounded time when late), the
// mapping step, the periodic zone snapshot for extraction, and every
// publish_every_frames frames a request for the merged boxes.
#include "runtime/mapping_stage.hpp"

namespace zonemap::runtime {

MappingStage::MappingStage(Links& links, Mapper& mapper, MappingHooks& hooks,
                           const PipelineOptions& options, const FeatureValues& values,
                           bool observe_sectors)
    : links_(links),
      mapper_(mapper),
      hooks_(hooks),
      options_(options),
      track_(mapper.config().pose_max_gap_s, mapper.config().pose_tolerance_s),
      schedule_(mapper.config().features.extract_every_frames),
      snapshot_threshold_(values.snapshot_threshold),
      snapshot_trim_(make_peak_trim(mapper.config())),
      reintegration_value_(values.reintegration_value),
      observe_sectors_(observe_sectors) {
  feed_.stage = this;
  track_.reserve(512);
}

void MappingStage::run() {
  os::AllocationScope scope;  // from here on the mapping stage must not allocate
  bool end = false;
  while (!end) {
    std::uint32_t slot = kEndOfStream;
    pop_waiting(links_.filled, &slot, links_.mapping_bell);
    if (slot == kEndOfStream) break;
    if (!options_.lossless) slot = newest_filled(slot, &end);
    map_frame(slot, scope);
  }
  // Every allocation answered before the end, so that no box is left behind.
  apply_reintegration(allocations_sent_, nullptr);
  const os::AllocationCounts counted = scope.counted();
  stats_.mapping_thread_allocations = counted.allocations;
  stats_.mapping_thread_frees = counted.frees;
  links_.mapping_done.store(true, std::memory_order_release);
  push_job(ExtractionJob{});  // the end: the extraction stage passes it on to the output
}

// Newest wins: skips to the newest waiting frame, handing the older ones back
// (dropped, counted); *end when the end of the stream came among them.
std::uint32_t MappingStage::newest_filled(std::uint32_t slot, bool* end) {
  std::uint32_t newer = kEndOfStream;
  while (links_.filled.pop(&newer)) {
    if (newer == kEndOfStream) {
      *end = true;
      break;
    }
    ++stats_.dropped_mapper_behind;
    push_waiting(links_.free_slots, slot, links_.mapping_bell);
    slot = newer;
  }
  return slot;
}

void MappingStage::map_frame(std::uint32_t slot, const os::AllocationScope& scope) {
  PipelineStats& s = stats_;
  const Clock::time_point start = Clock::now();
  // Newest wins: re-integration boxes that have come since (lossless writes them
  // while the zone is allocated).
  if (!options_.lossless) apply_reintegration(0, nullptr);
  const FrameSlotInfo info = links_.frame_info[slot];
  s.acquire_to_map_start.record(os::ms_between(info.acquired, start));
  const hal::CameraFrame& frame = links_.frames[slot];
  Eigen::Isometry3d pose;
  if (!pose_for(frame.time_s, &pose)) {
    ++s.frames_skipped_no_pose;
    push_waiting(links_.free_slots, slot, links_.mapping_bell);
    return;
  }
  DepthFrameView view{frame.depth.data(), frame.has_left ? frame.left.data() : nullptr,
                      mapper_.camera().width, mapper_.camera().height};
  context_time_s_ = frame.time_s;
  context_pose_ = pose;
  const double frame_time_s = frame.time_s;
  const FrameReport report = mapper_.integrate(view, pose);
  if (report.status == FrameStatus::kMapped) hooks_.frame_mapped(frame, pose);
  push_waiting(links_.free_slots, slot, links_.mapping_bell);  // the frame is not read after
  if (report.status != FrameStatus::kMapped) {
    ++s.frames_rejected;
    return;
  }
  after_mapped(info, frame_time_s, pose, report, start, scope);
}

// The pose at a frame's time from the pose buffer; when it is late, waited for
// a bounded time (pose_wait_s), never longer.
bool MappingStage::pose_for(double time_s, Eigen::Isometry3d* pose) {
  double newest = links_.poses.snapshot(&track_);
  if (track_.lookup(time_s, pose) != PoseLookup::kNoPose) return true;
  if (newest >= time_s) return false;  // the poses are there, none fits
  ++stats_.pose_waits;
  const Clock::time_point deadline = os::after_seconds(options_.pose_wait_s);
  while (true) {
    const std::uint32_t ticket = links_.mapping_bell.ticket();
    newest = links_.poses.snapshot(&track_);
    if (track_.lookup(time_s, pose) != PoseLookup::kNoPose) return true;
    if (newest >= time_s) return false;
    if (!links_.mapping_bell.wait_until(ticket, deadline)) return false;  // rung by every pose
  }
}

// A mapped frame's counts, the periodic extraction (the single-threaded replay's
// schedule), the hooks and, when due, a publish request.
void MappingStage::after_mapped(const FrameSlotInfo& info, double frame_time_s,
                                const Eigen::Isometry3d& pose, const FrameReport& report,
                                Clock::time_point start, const os::AllocationScope& scope) {
  PipelineStats& s = stats_;
  ++s.frames_mapped;
  s.frames_ground_below_environment += ground_below_environment(report) ? 1 : 0;
  count_sky(report, &s);
  const int pick = schedule_.after_frame(s.frames_mapped, mapper_.zones().live_zone_count());
  ZoneView periodic;
  if (pick >= 0 && mapper_.zones().nth_live_view(pick, &periodic)) send_snapshot(periodic, true);
  hooks_.after_frame(info.frame_index, pose, report, os::ms_between(start, Clock::now()));
  s.mapping.record(os::ms_between(start, Clock::now()));
  if (s.frames_mapped % options_.publish_every_frames == 0) {
    request_publish(info, frame_time_s, pose, scope.counted());
  }
}

// An output buffer for this frame's update, filled by the extraction stage after
// every job so far; skipped (counted) when the output stage holds them all.
void MappingStage::request_publish(const FrameSlotInfo& info, double frame_time_s,
                                   const Eigen::Isometry3d& pose,
                                   const os::AllocationCounts& allocations) {
  std::uint32_t out = kEndOfStream;
  if (!links_.out_free.pop(&out)) {
    ++stats_.outputs_skipped;
    return;
  }
  OutputBuffer& buffer = links_.outputs[out];
  buffer.acquired = info.acquired;
  buffer.time_s = frame_time_s;
  buffer.world_T_body = pose * options_.body_T_camera.inverse();
  if (observe_sectors_) {
    buffer.sectors_observed =
        observed_sectors(mapper_.zones(), mapper_.config().cell_size_m, buffer.world_T_body,
                         options_.world_z_up, options_.sectors);
  }
  fill_health(&buffer.health, allocations);
  ExtractionJob job = context_job(ExtractionJob::Kind::kPublish);
  job.slot = out;
  push_job(job);
}

}  // namespace zonemap::runtime
