// The mapping thread: each frame's pose, the mapping step, the periodic zone
// snapshot for extraction, and every publish_every_frames frames a request for
// the merged boxes. Allocates nothing from its first loop on.
#include "runtime/pipeline_impl.hpp"

namespace zonemap::runtime {

// Newest wins: skips to the newest waiting frame, handing the older ones back
// (dropped, counted); *end when the end of the stream came among them.
std::uint32_t Pipeline::Impl::newest_filled(std::uint32_t slot, bool* end) {
  std::uint32_t newer = kEndOfStream;
  while (filled.pop(&newer)) {
    if (newer == kEndOfStream) {
      *end = true;
      break;
    }
    ++mapping_stats.dropped_mapper_behind;
    push_waiting(free_slots, slot, mapping_bell);
    slot = newer;
  }
  return slot;
}

// An output buffer for this frame's update, filled by the extraction thread after
// every job so far; skipped (counted) when the output stage holds them all.
void Pipeline::Impl::request_publish(const SlotInfo& info, double frame_time_s,
                                     const Eigen::Isometry3d& pose,
                                     const os::AllocationCounts& allocations) {
  PipelineStats& s = mapping_stats;
  std::uint32_t out = kEndOfStream;
  if (!out_free.pop(&out)) {
    ++s.outputs_skipped;
    return;
  }
  OutputBuffer& buffer = outputs[out];
  buffer.acquired = info.acquired;
  buffer.time_s = frame_time_s;
  buffer.world_T_body = pose * options.body_T_camera.inverse();
  if (!sinks.empty()) {
    buffer.sectors_observed =
        observed_sectors(mapper.zones(), mapper.config().cell_size_m, buffer.world_T_body,
                         options.world_z_up, options.sectors);
  }
  fill_health(&buffer.health, s, allocations);
  ExtractionJob job = context_job(ExtractionJob::Kind::kPublish);
  job.slot = out;
  push_job(job);
}

void Pipeline::Impl::mapping() {
  PipelineStats& s = mapping_stats;
  realtime(options.priority_mapping, options.cpu_mapping, &s, "mapping");
  os::AllocationScope scope;  // from here on the mapping thread must not allocate
  bool end = false;
  while (!end) {
    std::uint32_t slot = kEndOfStream;
    pop_waiting(filled, &slot, mapping_bell);
    if (slot == kEndOfStream) break;
    if (!options.lossless) slot = newest_filled(slot, &end);
    const Clock::time_point start = Clock::now();
    // Newest wins: re-integration boxes that have come since (lossless writes
    // them while the zone is allocated).
    if (!options.lossless) apply_reintegration(0, nullptr);
    const SlotInfo info = frame_info[slot];
    s.acquire_to_map_start.record(os::ms_between(info.acquired, start));
    const hal::CameraFrame& frame = frames[slot];
    Eigen::Isometry3d pose;
    if (!pose_for(frame.time_s, &pose, &s)) {
      ++s.frames_skipped_no_pose;
      push_waiting(free_slots, slot, mapping_bell);
      continue;
    }
    DepthFrameView view{frame.depth.data(), frame.has_left ? frame.left.data() : nullptr,
                        mapper.camera().width, mapper.camera().height};
    context_time_s = frame.time_s;
    context_pose = pose;
    const double frame_time = frame.time_s;
    const FrameReport report = mapper.integrate(view, pose);
    if (report.status == FrameStatus::kMapped) hooks.frame_mapped(frame, pose);
    push_waiting(free_slots, slot, mapping_bell);
    if (report.status != FrameStatus::kMapped) {
      ++s.frames_rejected;
      continue;
    }
    ++s.frames_mapped;
    s.frames_ground_below_environment += ground_below_environment(report) ? 1 : 0;
    count_sky(report, &s);
    // Periodic extraction (the single-threaded replay's schedule).
    const int pick = schedule.after_frame(s.frames_mapped, mapper.zones().live_zone_count());
    ZoneView periodic;
    if (pick >= 0 && mapper.zones().nth_live_view(pick, &periodic)) send_snapshot(periodic, true);
    hooks.after_frame(info.frame_index, pose, report, os::ms_between(start, Clock::now()));
    s.mapping.record(os::ms_between(start, Clock::now()));
    if (s.frames_mapped % options.publish_every_frames == 0) {
      request_publish(info, frame_time, pose, scope.counted());
    }
  }
  // Every allocation answered before the end, so that no box is left behind.
  apply_reintegration(allocations_sent, nullptr);
  const os::AllocationCounts counted = scope.counted();
  s.mapping_thread_allocations = counted.allocations;
  s.mapping_thread_frees = counted.frees;
  mapping_done.store(true, std::memory_order_release);
  push_job(ExtractionJob{});  // kEndOfStream: the extraction thread passes it on to the output
}

}  // namespace zonemap::runtime
