// The extraction protocol. The extraction thread owns the feature map; the
// mapping thread tells it, in the order the single-threaded replay would call
// the feature map, what happened to the zones (a snapshot to extract, a zone
// allocated, a publish due) and writes back the boxes it answers with. Lossless
// runs wait where the single-threaded replay would, so the map is the same.
#include "runtime/pipeline_impl.hpp"

namespace zonemap::runtime {

Eigen::Isometry3d Pipeline::Impl::ExtractionJob::camera_pose() const {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::Map<const Eigen::Matrix3d>(camera_rotation);
  pose.translation() = Eigen::Map<const Eigen::Vector3d>(camera_position);
  return pose;
}

// --- the mapping thread's side ------------------------------------------------------

// The mapping thread waits for the extraction thread until `done()` (which may
// take what it waited for). Each round also writes the re-integration boxes that
// have come: the extraction thread may itself be waiting for room in that queue
// (newest wins; lossless has none pending then).
template <typename Done>
void Pipeline::Impl::wait_for_extraction(Done done) {
  wait_on(mapping_bell, [&] {
    if (done()) return true;
    if (!options.lossless) apply_reintegration(0, nullptr);
    return done();
  });
}

void Pipeline::Impl::push_job(const ExtractionJob& job) {
  // Holds 64; a frame sends at most ~18.
  wait_for_extraction([&] { return jobs.push(job); });
}

Pipeline::Impl::ExtractionJob Pipeline::Impl::context_job(ExtractionJob::Kind kind) const {
  ExtractionJob job;
  job.kind = kind;
  job.time_s = context_time_s;
  Eigen::Map<Eigen::Matrix3d>(job.camera_rotation) = context_pose.linear();
  Eigen::Map<Eigen::Vector3d>(job.camera_position) = context_pose.translation();
  return job;
}

// Snapshot `zone` into a free slot and hand it over. A discard always gets a
// slot (kZonesHeld are kept for discards); `periodic` only takes a spare one.
bool Pipeline::Impl::send_snapshot(const ZoneView& zone, bool periodic) {
  PipelineStats& s = mapping_stats;
  std::uint32_t slot = kEndOfStream;
  if (periodic) {
    // Newest wins: skip this round when the extraction thread is behind; lossless
    // waits, so that the map stays the single-threaded one.
    const auto spare = [&] {
      return snapshot_free.size_approx() > static_cast<std::size_t>(kZonesHeld);
    };
    if (!spare()) {
      if (!options.lossless) {
        ++s.extractions_deferred;
        return false;
      }
      wait_for_extraction(spare);
    }
    snapshot_free.pop(&slot);
  } else if (!snapshot_free.pop(&slot)) {
    ++s.snapshot_waits;
    wait_for_extraction([&] { return snapshot_free.pop(&slot); });
  }
  snapshots[slot]->capture(zone, snapshot_threshold, &snapshot_trim);
  ExtractionJob job = context_job(ExtractionJob::Kind::kExtract);
  job.slot = slot;
  push_job(job);
  return true;
}

void Pipeline::Impl::zone_discarding(const ZoneView& zone) {
  send_snapshot(zone, false);
}

void Pipeline::Impl::zone_allocated(ZoneView& zone) {
  ExtractionJob job = context_job(ExtractionJob::Kind::kAllocated);
  job.zone = zone.key;
  job.allocation = ++allocations_sent;
  push_job(job);
  // Lossless: wait for the boxes now, as the single-threaded replay writes them
  // here. Newest wins: they are written when they come (next frames).
  if (options.lossless) apply_reintegration(job.allocation, &zone);
}

// Writes the re-integration boxes that have come; with `until` > 0 waits until
// that allocation is answered. `allocating` is the zone being allocated right
// now (the ZoneMap is mid-update: it is not looked up there).
void Pipeline::Impl::apply_reintegration(std::uint64_t until, ZoneView* allocating) {
  PipelineStats& s = mapping_stats;
  ReintegrationBox box;
  while (true) {
    const std::uint32_t ticket = mapping_bell.ticket();
    if (!reintegration.pop(&box)) {
      if (allocations_answered >= until) return;
      mapping_bell.wait(ticket);
      continue;
    }
    if (box.answered) {
      allocations_answered = box.allocation;
      continue;
    }
    ZoneView view;
    ZoneView* target = nullptr;
    if (allocating != nullptr && allocating->key == box.zone) {
      target = allocating;
    } else if (allocating == nullptr && mapper.zones().live_view(box.zone, &view)) {
      target = &view;
    }
    if (target == nullptr) {
      ++s.reintegration_zone_gone;
      continue;
    }
    ++s.reintegration_boxes;
    s.reintegration_cells +=
        FeatureMap::reintegrate_box(*target, box.min, box.max, reintegration_value);
  }
}

// --- the extraction thread ------------------------------------------------------------

// The stored boxes that fall into an allocated zone, then the marker.
void Pipeline::Impl::answer_allocation(const ExtractionJob& job) {
  features.for_each_reintegration_box(job.zone, [&](const CellIndex& min, const CellIndex& max) {
    push_waiting(reintegration, ReintegrationBox{job.zone, min, max, job.allocation, false},
                 extraction_bell);
  });
  push_waiting(reintegration, ReintegrationBox{job.zone, {}, {}, job.allocation, true},
               extraction_bell);
}

// Other vehicles' maps that have come, each replacing its sender's last (at most
// the inbox's slots a call: bounded however fast they come).
void Pipeline::Impl::take_shared_maps() {
  SharedMapInbox* inbox = options.shared_maps;
  if (inbox == nullptr) return;
  for (std::size_t i = 0; i < SharedMapInbox::kSlots; ++i) {
    SharedMapUpdate* update = inbox->next();
    if (update == nullptr) return;
    features.replace_shared(update->source, update->min, update->max, update->count);
    inbox->release(update);
  }
}

// The merged boxes and footprints into the output buffer the mapping thread took.
void Pipeline::Impl::merge_for_output(const ExtractionJob& job, const os::AllocationScope& scope) {
  take_shared_maps();
  OutputBuffer& buffer = outputs[job.slot];
  FootprintOutput shapes;
  shapes.rects = buffer.rects.data();
  shapes.capacity = buffer.rects.size();
  shapes.offsets = buffer.rect_offsets.data();
  shapes.counts = buffer.rect_counts.data();
  buffer.count =
      features.merged(buffer.boxes.data(), buffer.boxes.size(), options.include_ground, &shapes);
  fill_feature_health(&buffer.health);
  buffer.health.heap_allocations_after_init += scope.counted().allocations;
  push_waiting(out_filled, job.slot, extraction_bell);
}

void Pipeline::Impl::extraction() {
  PipelineStats& s = extraction_stats;
  realtime(options.priority_extraction, options.cpu_extraction, &s, "extraction");
  os::AllocationScope scope;
  while (true) {
    ExtractionJob job;
    pop_waiting(jobs, &job, extraction_bell);
    if (job.kind == ExtractionJob::Kind::kEnd) break;
    features.set_context(job.time_s, job.camera_pose());
    switch (job.kind) {
      case ExtractionJob::Kind::kExtract: {
        const Clock::time_point start = Clock::now();
        features.extract(*snapshots[job.slot]);
        s.extraction.record(os::ms_between(start, Clock::now()));
        ++s.extractions;
        push_waiting(snapshot_free, job.slot, extraction_bell);
        break;
      }
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
  s.extraction_thread_allocations = counted.allocations;
  s.extraction_thread_frees = counted.frees;
  push_waiting(out_filled, kEndOfStream, extraction_bell);
}

}  // namespace zonemap::runtime
