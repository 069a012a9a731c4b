// Start-up (everything reserved here), the threads' start and join, and the
// figures gathered from each thread's counters after the join.
#include "runtime/pipeline.hpp"

#include <optional>
#include <string>
#include <thread>

#include "hal/os/realtime.hpp"
#include "hal/os/worker_pool.hpp"
#include "runtime/pipeline_impl.hpp"

namespace zonemap::runtime {

Pipeline::Impl::Impl(hal::FrameSource& frame_source, const PoseTrack* replay, hal::PoseSource* live,
                     std::span<hal::ObstacleSink* const> sink_list, Mapper& m, FeatureMap& f,
                     MappingHooks& h, const PipelineOptions& o)
    : source(frame_source),
      replay_poses(replay),
      live_poses(live),
      sinks(sink_list.begin(), sink_list.end()),
      mapper(m),
      features(f),
      hooks(h),
      options(o),
      schedule(m.config().features.extract_every_frames),
      snapshot_threshold(f.occupied_threshold()),
      snapshot_trim(make_peak_trim(m.config())),
      reintegration_value(f.reintegration_value()) {
  feed.impl = this;
  filled.connect(&acquisition_bell, &mapping_bell);
  free_slots.connect(&mapping_bell, &acquisition_bell);
  out_filled.connect(&extraction_bell, &output_bell);
  out_free.connect(&output_bell, &mapping_bell);
  snapshot_free.connect(&extraction_bell, &mapping_bell);
  jobs.connect(&mapping_bell, &extraction_bell);
  reintegration.connect(&extraction_bell, &mapping_bell);
  for (std::uint32_t i = 0; i < kSnapshotSlots; ++i) {
    snapshots.push_back(
        std::make_unique<ZoneSnapshot>(m.config().zone_cells, coarse_level_step(m.config())));
    snapshot_free.push(i);
  }
  for (auto& frame : frames) frame = source.make_frame();
  drop_frame = source.make_frame();
  for (std::uint32_t i = 0; i < kFrameSlots; ++i) free_slots.push(i);
  for (auto& out : outputs) {
    out.boxes.resize(features.capacity());
    out.rects.resize(options.footprint_rects);
    out.rect_offsets.resize(features.capacity());
    out.rect_counts.resize(features.capacity());
  }
  for (std::uint32_t i = 0; i < kOutputSlots; ++i) out_free.push(i);
  mapping_track = PoseTrack(m.config().pose_max_gap_s, m.config().pose_tolerance_s);
  mapping_track.reserve(512);
}

void Pipeline::Impl::realtime(int priority, int cpu, PipelineStats* stats, const char* stage) {
  std::string warning;
  if ((priority > 0 || cpu >= 0) && !os::set_thread_realtime(priority, cpu, &warning)) {
    stats->warnings.push_back(std::string(stage) + ": " + warning);
  }
}

std::size_t Pipeline::Impl::reserved_bytes() const {
  const std::size_t pixels = static_cast<std::size_t>(mapper.camera().width) *
                             static_cast<std::size_t>(mapper.camera().height);
  const std::size_t boxes = features.capacity();
  return (kFrameSlots + 1) * pixels * 3 +
         kOutputSlots * (boxes * (sizeof(ObstacleBox) + 2 * sizeof(std::uint32_t)) +
                         options.footprint_rects * sizeof(FootprintRect)) +
         kSnapshotSlots * snapshots.front()->reserved_bytes() + snapshot_trim.reserved_bytes() +
         sizeof(Impl);
}

PipelineStats Pipeline::Impl::gathered_stats() const {
  const PipelineStats& a = acquisition_stats;
  const PipelineStats& m = mapping_stats;
  const PipelineStats& o = output_stats;
  const PipelineStats& i = ins_stats;
  const PipelineStats& e = extraction_stats;
  PipelineStats s;
  // Each thread counts its own frames and outputs (the rejected ones on two).
  for (const auto* part : {&a, &m, &o, &i, &e}) {
    static_cast<hal::FrameCounters&>(s) += *part;
  }
  s.extraction_thread_allocations = e.extraction_thread_allocations;
  s.extraction_thread_frees = e.extraction_thread_frees;
  s.extractions = e.extractions;
  s.extraction = e.extraction;
  s.extractions_deferred = m.extractions_deferred;
  s.snapshot_waits = m.snapshot_waits;
  s.reintegration_boxes = m.reintegration_boxes;
  s.reintegration_cells = m.reintegration_cells;
  s.reintegration_zone_gone = m.reintegration_zone_gone;
  s.pixels_sky = m.pixels_sky;
  s.pixels_sky_refused = m.pixels_sky_refused;
  s.sky_last_frame = m.sky_last_frame;
  s.sky_refused_last_frame = m.sky_refused_last_frame;
  s.sky_refused_max_frame = m.sky_refused_max_frame;
  s.frames_lost = a.frames_lost;
  s.stopped = a.stopped;
  s.mapping_thread_allocations = m.mapping_thread_allocations;
  s.mapping_thread_frees = m.mapping_thread_frees;
  s.acquire_to_map_start = m.acquire_to_map_start;
  s.mapping = m.mapping;
  s.health_published = o.health_published;
  s.end_to_end = o.end_to_end;
  s.output_thread_allocations = o.output_thread_allocations;
  s.output_thread_frees = o.output_thread_frees;
  s.ins_thread_allocations = i.ins_thread_allocations;
  s.ins_thread_frees = i.ins_thread_frees;
  s.heap_allocations_after_init = s.mapping_thread_allocations + s.output_thread_allocations +
                                  s.ins_thread_allocations + s.extraction_thread_allocations;
  s.heap_frees_after_init = s.mapping_thread_frees + s.output_thread_frees + s.ins_thread_frees +
                            s.extraction_thread_frees;
  for (const auto* part : {&a, &m, &o, &i, &e}) {
    s.warnings.insert(s.warnings.end(), part->warnings.begin(), part->warnings.end());
  }
  return s;
}

Pipeline::Pipeline(hal::FrameSource& frames, const PoseTrack* replay_poses,
                   hal::PoseSource* live_poses, std::span<hal::ObstacleSink* const> sinks,
                   Mapper& mapper, FeatureMap& features, MappingHooks& hooks,
                   const PipelineOptions& options)
    : impl_(std::make_unique<Impl>(frames, replay_poses, live_poses, sinks, mapper, features, hooks,
                                   options)) {}

Pipeline::~Pipeline() = default;

void Pipeline::stop() {
  impl_->stop_requested.store(true, std::memory_order_release);
}

std::int64_t Pipeline::frames_offered() const {
  return impl_->offered.load(std::memory_order_acquire);
}

std::size_t Pipeline::reserved_bytes() const {
  return impl_->reserved_bytes();
}

void Pipeline::run() {
  std::vector<std::string> warnings;
  if (impl_->options.lock_memory) {
    std::string warning;
    if (!os::lock_memory(&warning)) warnings.push_back(warning);
  }
  impl_->static_bytes =
      reserved_bytes() + impl_->mapper.reserved_bytes() + impl_->features.reserved_bytes();
  // The mapping step's other workers, started once with the pipeline.
  std::optional<os::WorkerPool> workers;
  if (impl_->options.mapping_workers > 1) {
    workers.emplace(os::WorkerOptions{impl_->options.mapping_workers,
                                      impl_->options.priority_mapping, impl_->options.cpu_workers});
    warnings.insert(warnings.end(), workers->warnings().begin(), workers->warnings().end());
    impl_->mapper.set_work_split(&*workers);
  }
  const long rss_after_start = os::resident_bytes();
  // The extraction thread owns the feature map from here: the mapping thread's
  // zone events go to the feed instead.
  ZoneMap& zones = impl_->mapper.zones();
  const bool fed = zones.replace_observer(&impl_->features, &impl_->feed);
  if (!fed) zones.add_observer(&impl_->feed);
  std::thread output([this] { impl_->output(); });
  std::thread extraction([this] { impl_->extraction(); });
  std::thread mapping([this] { impl_->mapping(); });
  std::thread ins;
  if (impl_->live_poses != nullptr) ins = std::thread([this] { impl_->ins(); });
  std::thread acquisition([this] { impl_->acquisition(); });
  acquisition.join();
  mapping.join();
  if (ins.joinable()) ins.join();
  extraction.join();
  output.join();
  if (fed) zones.replace_observer(&impl_->feed, &impl_->features);
  impl_->mapper.set_work_split(nullptr);
  impl_->features.add_cells_reintegrated(impl_->mapping_stats.reintegration_cells);
  stats_ = impl_->gathered_stats();
  if (workers) {  // the mapping step's workers count as the mapping thread
    const os::AllocationCounts w = workers->job_allocations();
    stats_.mapping_thread_allocations += w.allocations;
    stats_.mapping_thread_frees += w.frees;
    stats_.heap_allocations_after_init += w.allocations;
    stats_.heap_frees_after_init += w.frees;
  }
  stats_.warnings.insert(stats_.warnings.begin(), warnings.begin(), warnings.end());
  stats_.rss_after_start = rss_after_start;
  stats_.rss_at_end = os::resident_bytes();
}

}  // namespace zonemap::runtime
