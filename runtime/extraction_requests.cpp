// The mapping stage's side of the extraction protocol. The extraction stage owns
// the feature map; the mapping stage tells it, in the order the single-threaded
// replay would call the feature map, what happened to the zones (a snapshot to
// extract, a zone allocated, a publish due) and writes back the boxes it answers
// with. Lossless runs wait where the single-threaded replay would, so the map is
// the same.
#include "runtime/mapping_stage.hpp"

namespace zonemap::runtime {

// The mapping stage waits for the extraction stage until `done()` (which may
// take what it waited for). Each round also writes the re-integration boxes that
// have come: the extraction stage may itself be waiting for room in that queue
// (newest wins; lossless has none pending then).
template <typename Done>
void MappingStage::wait_for_extraction(Done done) {
  wait_on(links_.mapping_bell, [&] {
    if (done()) return true;
    if (!options_.lossless) apply_reintegration(0, nullptr);
    return done();
  });
}

void MappingStage::push_job(const ExtractionJob& job) {
  // Holds 64; a frame sends at most ~18.
  wait_for_extraction([&] { return links_.jobs.push(job); });
}

ExtractionJob MappingStage::context_job(ExtractionJob::Kind kind) const {
  ExtractionJob job;
  job.kind = kind;
  job.time_s = context_time_s_;
  Eigen::Map<Eigen::Matrix3d>(job.camera_rotation) = context_pose_.linear();
  Eigen::Map<Eigen::Vector3d>(job.camera_position) = context_pose_.translation();
  return job;
}

// Snapshot `zone` into a free slot and hand it over. A discard always gets a
// slot (kZonesHeld are kept for discards); `periodic` only takes a spare one.
bool MappingStage::send_snapshot(const ZoneView& zone, bool periodic) {
  std::uint32_t slot = kEndOfStream;
  if (periodic) {
    // Newest wins: skip this round when the extraction stage is behind; lossless
    // waits, so that the map stays the single-threaded one.
    const auto spare = [&] {
      return links_.snapshot_free.size_approx() > static_cast<std::size_t>(kZonesHeld);
    };
    if (!spare()) {
      if (!options_.lossless) {
        ++stats_.extractions_deferred;
        return false;
      }
      wait_for_extraction(spare);
    }
    links_.snapshot_free.pop(&slot);
  } else if (!links_.snapshot_free.pop(&slot)) {
    ++stats_.snapshot_waits;
    wait_for_extraction([&] { return links_.snapshot_free.pop(&slot); });
  }
  links_.snapshots[slot]->capture(zone, snapshot_threshold_, &snapshot_trim_);
  ExtractionJob job = context_job(ExtractionJob::Kind::kExtract);
  job.slot = slot;
  push_job(job);
  return true;
}

void MappingStage::zone_allocated(ZoneView& zone) {
  ExtractionJob job = context_job(ExtractionJob::Kind::kAllocated);
  job.zone = zone.key;
  job.allocation = ++allocations_sent_;
  push_job(job);
  // Lossless: wait for the boxes now, as the single-threaded replay writes them
  // here. Newest wins: they are written when they come (next frames).
  if (options_.lossless) apply_reintegration(job.allocation, &zone);
}

// Writes the re-integration boxes that have come; with `until` > 0 waits until
// that allocation is answered. `allocating` is the zone being allocated right
// now (the ZoneMap is mid-update: it is not looked up there).
void MappingStage::apply_reintegration(std::uint64_t until, ZoneView* allocating) {
  PipelineStats& s = stats_;
  ReintegrationBox box;
  while (true) {
    const std::uint32_t ticket = links_.mapping_bell.ticket();
    if (!links_.reintegration.pop(&box)) {
      if (allocations_answered_ >= until) return;
      links_.mapping_bell.wait(ticket);
      continue;
    }
    if (box.answered) {
      allocations_answered_ = box.allocation;
      continue;
    }
    ZoneView view;
    ZoneView* target = nullptr;
    if (allocating != nullptr && allocating->key == box.zone) {
      target = allocating;
    } else if (allocating == nullptr && mapper_.zones().live_view(box.zone, &view)) {
      target = &view;
    }
    if (target == nullptr) {
      ++s.reintegration_zone_gone;
      continue;
    }
    ++s.reintegration_boxes;
    s.reintegration_cells +=
        FeatureMap::reintegrate_box(*target, box.min, box.max, reintegration_value_);
  }
}

}  // namespace zonemap::runtime
