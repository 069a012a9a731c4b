// The extraction stage's loop: the mapping stage's jobs in the order it sent
// them, each a feature-map call the single-threaded replay makes at that point.
#include "runtime/extraction_stage.hpp"

namespace zonemap::runtime {

ExtractionStage::ExtractionStage(Links& links, FeatureMap& features, const PipelineOptions& options)
    : links_(links), features_(features), options_(options) {}

void ExtractionStage::run() {
  os::AllocationScope scope;
  while (true) {
    ExtractionJob job;
    pop_waiting(links_.jobs, &job, links_.extraction_bell);
    if (job.kind == ExtractionJob::Kind::kEnd) break;
    features_.set_context(job.time_s, job.camera_pose());
    switch (job.kind) {
      case ExtractionJob::Kind::kExtract:
        extract(job);
        break;
      case ExtractionJob::Kind::kAllocated:
        answer_allocation(job);
        break;
      case ExtractionJob::Kind::kPublish:
        merge_for_output(job, scope);
        break;
      case ExtractionJob::Kind::kEnd:
        break;
    }
  }
  const os::AllocationCounts counted = scope.counted();
  stats_.extraction_thread_allocations = counted.allocations;
  stats_.extraction_thread_frees = counted.frees;
  push_waiting(links_.out_filled, kEndOfStream, links_.extraction_bell);
}

// A zone snapshot into the feature map; its slot back to the mapping stage.
void ExtractionStage::extract(const ExtractionJob& job) {
  const Clock::time_point start = Clock::now();
  features_.extract(*links_.snapshots[job.slot]);
  stats_.extraction.record(os::ms_between(start, Clock::now()));
  ++stats_.extractions;
  push_waiting(links_.snapshot_free, job.slot, links_.extraction_bell);
}

// The stored boxes that fall into an allocated zone, then the marker.
void ExtractionStage::answer_allocation(const ExtractionJob& job) {
  features_.for_each_reintegration_box(job.zone, [&](const CellIndex& min, const CellIndex& max) {
    push_waiting(links_.reintegration, ReintegrationBox{job.zone, min, max, job.allocation, false},
                 links_.extraction_bell);
  });
  push_waiting(links_.reintegration, ReintegrationBox{job.zone, {}, {}, job.allocation, true},
               links_.extraction_bell);
}

// Other vehicles' maps that have come, each replacing its sender's last (at most
// the inbox's slots a call: bounded however fast they come).
void ExtractionStage::take_shared_maps() {
  SharedMapInbox* inbox = options_.shared_maps;
  if (inbox == nullptr) return;
  for (std::size_t i = 0; i < SharedMapInbox::kSlots; ++i) {
    SharedMapUpdate* update = inbox->next();
    if (update == nullptr) return;
    features_.replace_shared(update->source, update->min, update->max, update->count);
    inbox->release(update);
  }
}

// The merged boxes and footprints into the output buffer the mapping stage took.
void ExtractionStage::merge_for_output(const ExtractionJob& job, const os::AllocationScope& scope) {
  take_shared_maps();
  OutputBuffer& buffer = links_.outputs[job.slot];
  FootprintOutput shapes;
  shapes.rects = buffer.rects.data();
  shapes.capacity = buffer.rects.size();
  shapes.offsets = buffer.rect_offsets.data();
  shapes.counts = buffer.rect_counts.data();
  buffer.count =
      features_.merged(buffer.boxes.data(), buffer.boxes.size(), options_.include_ground, &shapes);
  fill_feature_health(&buffer.health);
  buffer.health.heap_allocations_after_init += scope.counted().allocations;
  push_waiting(links_.out_filled, job.slot, links_.extraction_bell);
}

}  // namespace zonemap::runtime
