// Start-up (the links and the stages, everything reserved here), the stages'
// threads started and joined in one place, and the figures gathered from each
// stage's counters after the join.
#include "runtime/pipeline.hpp"

#include <optional>
#include <string>

#include "hal/os/realtime.hpp"
#include "hal/os/task.hpp"
#include "hal/os/worker_pool.hpp"
#include "runtime/acquisition_stage.hpp"
#include "runtime/extraction_stage.hpp"
#include "runtime/ins_stage.hpp"
#include "runtime/links.hpp"
#include "runtime/mapping_stage.hpp"
#include "runtime/output_stage.hpp"

namespace zonemap::runtime {

struct Pipeline::Impl {
  Impl(hal::FrameSource& frames, const PoseTrack* replay_poses, hal::PoseSource* live_poses,
       std::span<hal::ObstacleSink* const> sinks, Mapper& mapper, FeatureMap& features,
       MappingHooks& hooks, const PipelineOptions& options);
  std::size_t reserved_bytes() const;
  void run_stages(std::vector<std::string>* warnings);
  PipelineStats gathered_stats() const;  // after the join: each stage's counters in one

  Mapper& mapper;
  FeatureMap& features;
  const PipelineOptions options;
  Links links;
  AcquisitionStage acquisition;
  std::optional<InsStage> ins;  // with a live pose source
  MappingStage mapping;
  ExtractionStage extraction;
  OutputStage output;
};

Pipeline::Impl::Impl(hal::FrameSource& frames, const PoseTrack* replay_poses,
                     hal::PoseSource* live_poses, std::span<hal::ObstacleSink* const> sinks,
                     Mapper& m, FeatureMap& f, MappingHooks& hooks, const PipelineOptions& o)
    : mapper(m),
      features(f),
      options(o),
      links(frames, m.config(), f.capacity(), o.footprint_rects),
      acquisition(links, frames, replay_poses, options, m.config().pose_max_gap_s),
      mapping(links, m, hooks, options, {f.occupied_threshold(), f.reintegration_value()},
              !sinks.empty()),
      extraction(links, f, options),
      output(links, sinks, options) {
  if (live_poses != nullptr) ins.emplace(links, *live_poses);
}

std::size_t Pipeline::Impl::reserved_bytes() const {
  return links.reserved_bytes() + acquisition.reserved_bytes() + mapping.reserved_bytes() +
         sizeof(Impl) - sizeof(Links);
}

// Every stage's thread, started here and only here (the consumers first, so
// that each is waiting when its first item comes), then joined.
void Pipeline::Impl::run_stages(std::vector<std::string>* warnings) {
  const PipelineOptions& o = options;
  os::Task output_task, extraction_task, mapping_task, ins_task, acquisition_task;
  output_task.start({"zonemap-output", o.priority_output, o.cpu_output}, [this] { output.run(); });
  extraction_task.start({"zonemap-extract", o.priority_extraction, o.cpu_extraction},
                        [this] { extraction.run(); });
  mapping_task.start({"zonemap-mapping", o.priority_mapping, o.cpu_mapping},
                     [this] { mapping.run(); });
  if (ins) ins_task.start({"zonemap-ins", o.priority_ins, o.cpu_ins}, [this] { ins->run(); });
  acquisition_task.start({"zonemap-acquire", o.priority_acquisition, o.cpu_acquisition},
                         [this] { acquisition.run(); });
  for (os::Task* task :
       {&acquisition_task, &mapping_task, &output_task, &ins_task, &extraction_task}) {
    task->join();
    if (!task->warning().empty()) warnings->push_back(task->warning());
  }
}

PipelineStats Pipeline::Impl::gathered_stats() const {
  const PipelineStats& a = acquisition.stats();
  const PipelineStats& m = mapping.stats();
  const PipelineStats& o = output.stats();
  const PipelineStats i = ins ? ins->stats() : PipelineStats{};
  const PipelineStats& e = extraction.stats();
  PipelineStats s;
  // Each stage counts its own frames and outputs (the rejected ones on two).
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
  impl_->links.stop_requested.store(true, std::memory_order_release);
}

std::int64_t Pipeline::frames_offered() const {
  return impl_->links.acquired.offered.load(std::memory_order_acquire);
}

std::size_t Pipeline::reserved_bytes() const {
  return impl_->reserved_bytes();
}

void Pipeline::run() {
  Impl& p = *impl_;
  std::vector<std::string> warnings;
  if (p.options.lock_memory) {
    std::string warning;
    if (!os::lock_memory(&warning)) warnings.push_back(warning);
  }
  p.links.static_bytes = reserved_bytes() + p.mapper.reserved_bytes() + p.features.reserved_bytes();
  // The mapping step's other workers, started once with the pipeline.
  std::optional<os::WorkerPool> workers;
  if (p.options.mapping_workers > 1) {
    workers.emplace(os::WorkerOptions{p.options.mapping_workers, p.options.priority_mapping,
                                      p.options.cpu_workers});
    warnings.insert(warnings.end(), workers->warnings().begin(), workers->warnings().end());
    p.mapper.set_work_split(&*workers);
  }
  const long rss_after_start = os::resident_bytes();
  // The extraction stage owns the feature map from here: the mapping stage's
  // zone events go to it as jobs instead.
  ZoneMap& zones = p.mapper.zones();
  const bool fed = zones.replace_observer(&p.features, &p.mapping.zone_events());
  if (!fed) zones.add_observer(&p.mapping.zone_events());
  p.run_stages(&warnings);
  if (fed) zones.replace_observer(&p.mapping.zone_events(), &p.features);
  p.mapper.set_work_split(nullptr);
  p.features.add_cells_reintegrated(p.mapping.stats().reintegration_cells);
  stats_ = p.gathered_stats();
  if (workers) {  // the mapping step's workers count as the mapping stage
    const os::AllocationCounts w = workers->job_allocations();
    stats_.mapping_thread_allocations += w.allocations;
    stats_.mapping_thread_frees += w.frees;
    stats_.heap_allocations_after_init += w.allocations;
    stats_.heap_frees_after_init += w.frees;
  }
  stats_.warnings = std::move(warnings);
  stats_.rss_after_start = rss_after_start;
  stats_.rss_at_end = os::resident_bytes();
}

}  // namespace zonemap::runtime
