// The counters the pipeline reports: the health message's (filled on the mapping
// and extraction stages, completed on the output stage) and stats.json's.
#include <algorithm>

#include "runtime/extraction_stage.hpp"
#include "runtime/mapping_stage.hpp"

namespace zonemap::runtime {

// The mapping stage's part, with the acquisition's and the INS stage's counts.
void MappingStage::fill_health(hal::HealthSnapshot* h,
                               const os::AllocationCounts& allocations) const {
  const PipelineStats& s = stats_;
  const SharedInsCounters& ins = links_.ins;
  *h = hal::HealthSnapshot{};
  h->uptime_s = os::seconds_since(links_.started);
  h->frames_in = links_.acquired.frames_in.load(std::memory_order_relaxed);
  h->frames_mapped = s.frames_mapped;
  h->frames_rejected = links_.acquired.rejected.load(std::memory_order_relaxed) + s.frames_rejected;
  h->frames_skipped_no_pose = s.frames_skipped_no_pose;
  h->dropped_mapper_behind = s.dropped_mapper_behind;
  h->dropped_pool_full = links_.acquired.pool_full.load(std::memory_order_relaxed);
  h->pose_waits = s.pose_waits;
  h->frames_ground_below_environment = s.frames_ground_below_environment;
  h->outputs_skipped = s.outputs_skipped;
  h->poses_in = ins.poses_out.load(std::memory_order_relaxed);
  h->poses_rejected =
      ins.rejected.load(std::memory_order_relaxed) + ins.malformed.load(std::memory_order_relaxed);
  h->heap_allocations_after_init = allocations.allocations;
  h->mapping_ms_p50 = s.mapping.percentile(0.50);
  h->mapping_ms_p99 = s.mapping.percentile(0.99);
  h->zones_allocated = static_cast<std::int32_t>(mapper_.zones().zones_allocated());
  // The wire carries these by name (health_t's named list, zonemap.Health).
  h->add("pose_waits", h->pose_waits);
  h->add("frames_ground_below_environment", h->frames_ground_below_environment);
  h->add("outputs_skipped", h->outputs_skipped);
  h->add("ins_messages", ins.messages.load(std::memory_order_relaxed));
  h->add("ins_malformed", ins.malformed.load(std::memory_order_relaxed));
  h->add("ins_link_errors", ins.link_errors.load(std::memory_order_relaxed));
  h->add("ins_reanchors", ins.reanchors.load(std::memory_order_relaxed));
  h->add("dropped_mapper_behind", h->dropped_mapper_behind);
  h->add("dropped_pool_full", h->dropped_pool_full);
  h->add("extractions_deferred", s.extractions_deferred);
  h->add("reintegration_zone_gone", s.reintegration_zone_gone);
  h->add("pixels_sky", s.pixels_sky);
  h->add("pixels_sky_refused", s.pixels_sky_refused);
  h->add("sky_last_frame", s.sky_last_frame);
  h->add("sky_refused_last_frame", s.sky_refused_last_frame);
}

void count_sky(const FrameReport& report, PipelineStats* s) {
  s->pixels_sky += report.pixels_sky;
  s->pixels_sky_refused += report.pixels_sky_refused;
  s->sky_last_frame = report.pixels_sky;
  s->sky_refused_last_frame = report.pixels_sky_refused;
  s->sky_refused_max_frame =
      std::max<std::int64_t>(s->sky_refused_max_frame, report.pixels_sky_refused);
}

// The feature map's part, on the extraction stage (which owns it).
void ExtractionStage::fill_feature_health(hal::HealthSnapshot* h) const {
  h->features = static_cast<std::int32_t>(features_.count());
  const FeatureCounters& fc = features_.counters();
  h->add("features_evicted", fc.features_evicted);
  h->add("features_dropped", fc.features_dropped);
  h->add("feature_shapes_truncated", fc.shapes_truncated);
  if (options_.shared_maps != nullptr) {
    h->add("shared_updates", fc.shared_updates);
    h->add("shared_boxes_added", fc.shared_added);
    h->add("shared_boxes_removed", fc.shared_removed);
    h->add("shared_boxes_dropped", fc.shared_dropped);
    h->add("shared_maps_no_slot", options_.shared_maps->dropped());
  }
}

void add_to_run_stats(const PipelineStats& p, hal::RunStats* s) {
  hal::FrameCounters counts = p;
  // The mapping hooks count these into the run's own figures, frame by frame.
  counts.frames_mapped = 0;
  counts.frames_ground_below_environment = 0;
  *s += counts;
  s->pipeline = true;
  s->end_to_end_ms_p50 = p.end_to_end.percentile(0.50);
  s->end_to_end_ms_p99 = p.end_to_end.percentile(0.99);
  s->end_to_end_ms_p999 = p.end_to_end.percentile(0.999);
  s->end_to_end_ms_max = p.end_to_end.max_ms();
  s->queue_ms_p99 = p.acquire_to_map_start.percentile(0.99);
  s->rss_after_start = p.rss_after_start;
  s->rss_at_end = p.rss_at_end;
}

}  // namespace zonemap::runtime
