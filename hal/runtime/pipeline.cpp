#include "hal/runtime/pipeline.hpp"

#include <array>
#include <chrono>
#include <thread>

#include "hal/os/allocation_counter.hpp"
#include "hal/os/doorbell.hpp"
#include "hal/os/realtime.hpp"
#include "zonemap/extraction_schedule.hpp"
#include "zonemap/pose_buffer.hpp"
#include "zonemap/spsc_queue.hpp"
#include "zonemap/zone_snapshot.hpp"

namespace zonemap::runtime {
namespace {

using Clock = std::chrono::steady_clock;
constexpr std::uint32_t kEnd = UINT32_MAX;  // end of stream, through the queues

double ms_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}
double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// A lock-free queue from one thread to another, with both threads' bells: a
// push rings the consumer's (there is work), a pop the producer's (there is room).
template <typename T, std::size_t N>
struct Channel {
  SpscQueue<T, N> queue;
  os::Doorbell* producer = nullptr;
  os::Doorbell* consumer = nullptr;
  void connect(os::Doorbell* from, os::Doorbell* to) {
    producer = from;
    consumer = to;
  }
  bool push(const T& item) {
    if (!queue.push(item)) return false;
    consumer->ring();
    return true;
  }
  bool pop(T* item) {
    if (!queue.pop(item)) return false;
    producer->ring();
    return true;
  }
  std::size_t size_approx() const { return queue.size_approx(); }
};

// The calling thread sleeps on its own bell until `done()` (which may take what
// it waited for): the ticket is taken before the last look, so a ring between
// that look and the sleep is not lost. Never spins, never takes a lock.
template <typename Done>
void wait_on(os::Doorbell& own, Done done) {
  while (!done()) {
    const std::uint32_t ticket = own.ticket();
    if (done()) return;
    own.wait(ticket);
  }
}
template <typename C, typename T>
void pop_waiting(C& channel, T* item, os::Doorbell& own) {
  wait_on(own, [&] { return channel.pop(item); });
}
template <typename C, typename T>
void push_waiting(C& channel, const T& item, os::Doorbell& own) {
  wait_on(own, [&] { return channel.push(item); });
}

// The INS thread's counters as the other threads may read them (relaxed: each
// is a count on its own, no consistency across them is needed).
struct SharedInsCounters {
  std::atomic<std::int64_t> messages{0}, malformed{0}, solutions{0}, poses_out{0}, link_errors{0},
      rejected{0}, reanchors{0};
  void store(const hal::PoseSourceCounters& c) {
    messages.store(c.messages, std::memory_order_relaxed);
    malformed.store(c.malformed, std::memory_order_relaxed);
    solutions.store(c.solutions, std::memory_order_relaxed);
    poses_out.store(c.poses_out, std::memory_order_relaxed);
    link_errors.store(c.link_errors, std::memory_order_relaxed);
    rejected.store(c.gate.rejected_total(), std::memory_order_relaxed);
    reanchors.store(c.gate.reanchors, std::memory_order_relaxed);
  }
};

}  // namespace

PipelineOptions PipelineOptions::from(const RuntimeConfig& runtime) {
  PipelineOptions o;
  o.frame_period_s = runtime.frame_period_s;
  o.pose_wait_s = runtime.pose_wait_s;
  o.publish_every_frames = runtime.publish_every_frames;
  o.lock_memory = runtime.lock_memory;
  o.priority_acquisition = runtime.priority_acquisition;
  o.priority_mapping = runtime.priority_mapping;
  o.priority_output = runtime.priority_output;
  o.cpu_acquisition = runtime.cpu_acquisition;
  o.cpu_mapping = runtime.cpu_mapping;
  o.cpu_output = runtime.cpu_output;
  o.priority_extraction = runtime.priority_extraction;
  o.cpu_extraction = runtime.cpu_extraction;
  return o;
}

struct Pipeline::Impl {
  hal::FrameSource& source;
  const PoseTrack* replay_poses;
  hal::PoseSource* live_poses;
  std::vector<hal::ObstacleSink*> sinks;
  Mapper& mapper;
  FeatureMap& features;
  MappingHooks& hooks;
  PipelineOptions options;
  Clock::time_point started = Clock::now();

  struct SlotInfo {
    std::size_t frame_index = 0;
    Clock::time_point acquired;
  };
  std::array<hal::CameraFrame, kFrameSlots> frames;
  std::array<SlotInfo, kFrameSlots> frame_info{};
  // Each thread's bell: rung when there may be work (or room) for it.
  os::Doorbell acquisition_bell, mapping_bell, extraction_bell, output_bell;
  Channel<std::uint32_t, 16> filled;      // acquisition -> mapping
  Channel<std::uint32_t, 16> free_slots;  // mapping -> acquisition
  PoseBuffer<512> poses;
  PoseTrack mapping_track{0.1, 0.02};

  struct OutputBuffer {
    std::vector<ObstacleBox> boxes;
    std::size_t count = 0;
    std::vector<FootprintRect> rects;
    std::vector<std::uint32_t> rect_offsets, rect_counts;
    Clock::time_point acquired;
    double time_s = 0.0;
    Eigen::Isometry3d world_T_body = Eigen::Isometry3d::Identity();
    SectorMask sectors_observed{};  // what the live grid has seen around the vehicle
    hal::HealthSnapshot health;     // the mapping side's counters at this update
  };
  std::array<OutputBuffer, kOutputSlots> outputs;
  Channel<std::uint32_t, 4> out_filled;  // extraction -> output
  Channel<std::uint32_t, 4> out_free;    // output -> mapping

  // Mapping -> extraction, in the order the mapping thread meant them: the
  // extraction thread replays the single-threaded sequence of feature-map calls.
  struct ExtractionJob {
    enum class Kind : std::uint8_t { kExtract, kAllocated, kPublish, kEnd };
    Kind kind = Kind::kEnd;
    std::uint32_t slot = 0;        // kExtract: snapshot slot; kPublish: output buffer
    ZoneKey zone;                  // kAllocated
    std::uint64_t allocation = 0;  // kAllocated: its number
    double time_s = 0.0;           // the feature map's context (stamps, relevance)
    double camera_rotation[9] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};  // world_T_camera
    double camera_position[3] = {0.0, 0.0, 0.0};  // (copied exactly: stamps equal one thread's)
  };
  // Extraction -> mapping: the boxes to re-integrate into an allocated zone, then
  // a marker saying that allocation is answered.
  struct ReintegrationBox {
    ZoneKey zone;
    CellIndex min, max;
    std::uint64_t allocation = 0;
    bool answered = false;  // the marker: no box, every box of `allocation` sent
  };
  std::vector<std::unique_ptr<ZoneSnapshot>> snapshots;
  Channel<std::uint32_t, 16> snapshot_free;       // extraction -> mapping
  Channel<ExtractionJob, 64> jobs;                // mapping -> extraction
  Channel<ReintegrationBox, 1024> reintegration;  // extraction -> mapping
  ExtractionSchedule schedule;
  FusedCell snapshot_threshold;

  FusedCell reintegration_value;
  // Mapping-thread state for the feed below.
  double context_time_s = 0.0;
  Eigen::Isometry3d context_pose = Eigen::Isometry3d::Identity();
  std::uint64_t allocations_sent = 0, allocations_answered = 0;

  // Takes the feature map's place among the zone observers during run().
  struct Feed final : ZoneObserver {
    Impl* impl = nullptr;
    void on_zone_allocated(ZoneView& zone) override { impl->zone_allocated(zone); }
    void on_zone_discarding(const ZoneView& zone) override { impl->zone_discarding(zone); }
  } feed;

  std::atomic<std::int64_t> offered{0};
  std::atomic<bool> stop_requested{false};
  std::atomic<bool> mapping_done{false};
  // Acquisition counters the mapping thread reads for the health message.
  std::atomic<std::int64_t> shared_frames_in{0}, shared_rejected{0}, shared_pool_full{0};
  SharedInsCounters ins_counters;
  // Counters, each written by one thread only and read after join.
  PipelineStats acquisition_stats, mapping_stats, output_stats, ins_stats, extraction_stats;

  Impl(hal::FrameSource& frame_source, const PoseTrack* replay, hal::PoseSource* live,
       std::span<hal::ObstacleSink* const> sink_list, Mapper& m, FeatureMap& f, MappingHooks& h,
       const PipelineOptions& o)
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
      snapshots.push_back(std::make_unique<ZoneSnapshot>(m.config().zone_cells));
      snapshot_free.push(i);
    }
    for (auto& frame : frames) frame = source.make_frame();
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

  void realtime(int priority, int cpu, PipelineStats* stats, const char* stage) {
    std::string warning;
    if ((priority > 0 || cpu >= 0) && !os::set_thread_realtime(priority, cpu, &warning)) {
      stats->warnings.push_back(std::string(stage) + ": " + warning);
    }
  }

  void acquisition() {
    PipelineStats& s = acquisition_stats;
    realtime(options.priority_acquisition, options.cpu_acquisition, &s, "acquisition");
    std::size_t next_pose = 0;
    const double gap = mapper.config().pose_max_gap_s;
    std::uint32_t spare = kEnd;  // a slot taken but not sent (rejected or no frame)
    std::size_t frame_index = 0;
    std::string why;
    why.reserve(512);
    while (!stop_requested.load(std::memory_order_acquire)) {
      std::uint32_t slot = spare;
      spare = kEnd;
      if (slot == kEnd) {
        if (options.lossless) {
          pop_waiting(free_slots, &slot, acquisition_bell);
        } else if (!free_slots.pop(&slot)) {
          slot = kEnd;  // every slot waits for the mapper: this frame will be dropped
        }
      }
      hal::CameraFrame* target = slot == kEnd ? &drop_frame : &frames[slot];
      const hal::FrameRead read = source.next(target, 100, &why);
      if (read == hal::FrameRead::kEnd) {
        spare = slot;
        break;
      }
      if (read == hal::FrameRead::kNone) {
        spare = slot;
        continue;
      }
      ++s.frames_in;
      shared_frames_in.fetch_add(1, std::memory_order_relaxed);
      const std::size_t index = frame_index++;
      // A corrupt frame counts as rejected even when there was no slot for it.
      if (read == hal::FrameRead::kRejected) {
        ++s.frames_rejected;
        shared_rejected.fetch_add(1, std::memory_order_relaxed);
        spare = slot;
        offered.fetch_add(1, std::memory_order_release);
        continue;
      }
      if (slot == kEnd) {
        ++s.dropped_pool_full;  // counted, never mapped
        shared_pool_full.fetch_add(1, std::memory_order_relaxed);
        offered.fetch_add(1, std::memory_order_release);
        continue;
      }
      // Replay poses reach the buffer as the frames come (up to one gap ahead).
      if (replay_poses != nullptr) {
        const auto& samples = replay_poses->samples();
        const double frame_time = frames[slot].time_s;
        while (next_pose < samples.size() && samples[next_pose].time_s <= frame_time + gap) {
          poses.push(samples[next_pose++]);
        }
        mapping_bell.ring();  // a mapper waiting for a late pose looks again
      }
      frame_info[slot] = {index, Clock::now()};
      push_waiting(filled, slot, acquisition_bell);  // cannot stay full: it holds all the slots
      offered.fetch_add(1, std::memory_order_release);
    }
    if (stop_requested.load(std::memory_order_acquire)) s.stopped = true;
    if (replay_poses != nullptr) {
      const auto& samples = replay_poses->samples();
      while (next_pose < samples.size()) poses.push(samples[next_pose++]);
    }
    s.frames_lost = source.frames_lost();
    push_waiting(filled, kEnd, acquisition_bell);
  }

  // Newest wins with every slot waiting: the next frame is read into this spare
  // buffer and dropped (a live source must be drained, not left to queue up).
  hal::CameraFrame drop_frame;

  struct BufferSink final : hal::PoseSink {
    PoseBuffer<512>* buffer;
    os::Doorbell* mapping_bell;
    void push(const PoseSample& p) override {
      buffer->push(p);
      mapping_bell->ring();  // a mapper waiting for this pose looks again
    }
  };

  void ins() {
    PipelineStats& s = ins_stats;
    realtime(options.priority_ins, options.cpu_ins, &s, "ins");
    BufferSink sink;
    sink.buffer = &poses;
    sink.mapping_bell = &mapping_bell;
    os::AllocationScope scope;
    while (!mapping_done.load(std::memory_order_acquire)) {
      const hal::PollResult r = live_poses->poll(sink, 20);
      ins_counters.store(live_poses->counters());
      if (r == hal::PollResult::kEnd) break;
    }
    const os::AllocationCounts counted = scope.counted();
    s.ins_thread_allocations = counted.allocations;
    s.ins_thread_frees = counted.frees;
  }

  bool pose_for(double time_s, Eigen::Isometry3d* pose, PipelineStats* s) {
    double newest = poses.snapshot(&mapping_track);
    if (mapping_track.lookup(time_s, pose) != PoseLookup::kNoPose) return true;
    if (newest >= time_s) return false;  // the poses are there, none fits
    // The pose is late: wait a bounded time for it, then give up on the frame.
    ++s->pose_waits;
    const Clock::time_point deadline =
        Clock::now() + std::chrono::duration_cast<Clock::duration>(
                           std::chrono::duration<double>(options.pose_wait_s));
    while (true) {
      const std::uint32_t ticket = mapping_bell.ticket();
      newest = poses.snapshot(&mapping_track);
      if (mapping_track.lookup(time_s, pose) != PoseLookup::kNoPose) return true;
      if (newest >= time_s) return false;
      if (!mapping_bell.wait_until(ticket, deadline)) return false;  // rung by every pose
    }
  }

  void fill_health(hal::HealthSnapshot* h, const PipelineStats& s,
                   const os::AllocationCounts& allocations) {
    *h = hal::HealthSnapshot{};
    h->uptime_s = seconds_since(started);
    h->frames_in = shared_frames_in.load(std::memory_order_relaxed);
    h->frames_mapped = s.frames_mapped;
    h->frames_rejected = shared_rejected.load(std::memory_order_relaxed) + s.frames_rejected;
    h->frames_skipped_no_pose = s.frames_skipped_no_pose;
    h->frames_dropped = s.dropped_mapper_behind + shared_pool_full.load(std::memory_order_relaxed);
    h->poses_in = ins_counters.poses_out.load(std::memory_order_relaxed);
    h->poses_rejected = ins_counters.rejected.load(std::memory_order_relaxed) +
                        ins_counters.malformed.load(std::memory_order_relaxed);
    h->heap_allocations_after_init = allocations.allocations;
    h->mapping_ms_p50 = s.mapping.percentile(0.50);
    h->mapping_ms_p99 = s.mapping.percentile(0.99);
    h->zones_allocated = static_cast<std::int32_t>(mapper.zones().zones_allocated());
    h->add("pose_waits", s.pose_waits);
    h->add("frames_ground_below_environment", s.frames_ground_below_environment);
    h->add("outputs_skipped", s.outputs_skipped);
    h->add("ins_messages", ins_counters.messages.load(std::memory_order_relaxed));
    h->add("ins_malformed", ins_counters.malformed.load(std::memory_order_relaxed));
    h->add("ins_link_errors", ins_counters.link_errors.load(std::memory_order_relaxed));
    h->add("ins_reanchors", ins_counters.reanchors.load(std::memory_order_relaxed));
    h->add("dropped_mapper_behind", s.dropped_mapper_behind);
    h->add("dropped_pool_full", shared_pool_full.load(std::memory_order_relaxed));
    h->add("extractions_deferred", s.extractions_deferred);
    h->add("reintegration_zone_gone", s.reintegration_zone_gone);
  }

  // The feature map's part, on the extraction thread (which owns it).
  void fill_feature_health(hal::HealthSnapshot* h) {
    h->features = static_cast<std::int32_t>(features.count());
    const FeatureCounters& fc = features.counters();
    h->add("features_evicted", fc.features_evicted);
    h->add("features_dropped", fc.features_dropped);
    h->add("feature_shapes_truncated", fc.shapes_truncated);
  }

  // --- the mapping thread's side of the feature map ---------------------------

  // The mapping thread waits for the extraction thread until `done()` (which
  // may take what it waited for). Each round also writes the re-integration
  // boxes that have come: the extraction thread may itself be waiting for room
  // in that queue (newest wins; lossless has none pending then).
  template <typename Done>
  void wait_for_extraction(Done done) {
    wait_on(mapping_bell, [&] {
      if (done()) return true;
      if (!options.lossless) apply_reintegration(0, nullptr);
      return done();
    });
  }

  void push_job(const ExtractionJob& job) {
    // Holds 64; a frame sends at most ~18.
    wait_for_extraction([&] { return jobs.push(job); });
  }

  ExtractionJob context_job(ExtractionJob::Kind kind) const {
    ExtractionJob job;
    job.kind = kind;
    job.time_s = context_time_s;
    Eigen::Map<Eigen::Matrix3d>(job.camera_rotation) = context_pose.linear();
    Eigen::Map<Eigen::Vector3d>(job.camera_position) = context_pose.translation();
    return job;
  }

  // Snapshot `zone` into a free slot and hand it over. A discard always gets a
  // slot (kZonesHeld are kept for discards); `periodic` only takes a spare one.
  bool send_snapshot(const ZoneView& zone, bool periodic) {
    PipelineStats& s = mapping_stats;
    std::uint32_t slot = kEnd;
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
    snapshots[slot]->capture(zone, snapshot_threshold);
    ExtractionJob job = context_job(ExtractionJob::Kind::kExtract);
    job.slot = slot;
    push_job(job);
    return true;
  }

  void zone_discarding(const ZoneView& zone) { send_snapshot(zone, false); }

  void zone_allocated(ZoneView& zone) {
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
  void apply_reintegration(std::uint64_t until, ZoneView* allocating) {
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

  // --- the extraction thread ---------------------------------------------------

  static Eigen::Isometry3d job_camera_pose(const ExtractionJob& job) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = Eigen::Map<const Eigen::Matrix3d>(job.camera_rotation);
    pose.translation() = Eigen::Map<const Eigen::Vector3d>(job.camera_position);
    return pose;
  }

  void extraction() {
    PipelineStats& s = extraction_stats;
    realtime(options.priority_extraction, options.cpu_extraction, &s, "extraction");
    os::AllocationScope scope;
    while (true) {
      ExtractionJob job;
      pop_waiting(jobs, &job, extraction_bell);
      if (job.kind == ExtractionJob::Kind::kEnd) break;
      features.set_context(job.time_s, job_camera_pose(job));
      switch (job.kind) {
        case ExtractionJob::Kind::kExtract: {
          const Clock::time_point start = Clock::now();
          features.extract(*snapshots[job.slot]);
          s.extraction.record(ms_between(start, Clock::now()));
          ++s.extractions;
          push_waiting(snapshot_free, job.slot, extraction_bell);
          break;
        }
        case ExtractionJob::Kind::kAllocated: {
          features.for_each_reintegration_box(job.zone, [&](const CellIndex& min,
                                                            const CellIndex& max) {
            push_waiting(reintegration, ReintegrationBox{job.zone, min, max, job.allocation, false},
                         extraction_bell);
          });
          push_waiting(reintegration, ReintegrationBox{job.zone, {}, {}, job.allocation, true},
                       extraction_bell);
          break;
        }
        case ExtractionJob::Kind::kPublish: {
          OutputBuffer& buffer = outputs[job.slot];
          FootprintOutput shapes;
          shapes.rects = buffer.rects.data();
          shapes.capacity = buffer.rects.size();
          shapes.offsets = buffer.rect_offsets.data();
          shapes.counts = buffer.rect_counts.data();
          buffer.count = features.merged(buffer.boxes.data(), buffer.boxes.size(),
                                         options.include_ground, &shapes);
          fill_feature_health(&buffer.health);
          buffer.health.heap_allocations_after_init += scope.counted().allocations;
          push_waiting(out_filled, job.slot, extraction_bell);
          break;
        }
        case ExtractionJob::Kind::kEnd:
          break;
      }
    }
    const os::AllocationCounts counted = scope.counted();
    s.extraction_thread_allocations = counted.allocations;
    s.extraction_thread_frees = counted.frees;
    push_waiting(out_filled, kEnd, extraction_bell);
  }

  void mapping() {
    PipelineStats& s = mapping_stats;
    realtime(options.priority_mapping, options.cpu_mapping, &s, "mapping");
    os::AllocationScope scope;  // from here on the mapping thread must not allocate
    bool end = false;
    while (!end) {
      std::uint32_t slot = kEnd;
      pop_waiting(filled, &slot, mapping_bell);
      if (slot == kEnd) break;
      if (!options.lossless) {
        // Newest wins: skip to the newest waiting frame.
        std::uint32_t newer = kEnd;
        while (filled.pop(&newer)) {
          if (newer == kEnd) {
            end = true;
            break;
          }
          ++s.dropped_mapper_behind;
          push_waiting(free_slots, slot, mapping_bell);
          slot = newer;
        }
      }
      const Clock::time_point start = Clock::now();
      // Newest wins: re-integration boxes that have come since (lossless writes
      // them while the zone is allocated).
      if (!options.lossless) apply_reintegration(0, nullptr);
      const SlotInfo info = frame_info[slot];
      s.acquire_to_map_start.record(ms_between(info.acquired, start));
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
      // Periodic extraction (the single-threaded replay's schedule).
      const int pick = schedule.after_frame(s.frames_mapped, mapper.zones().live_zone_count());
      ZoneView periodic;
      if (pick >= 0 && mapper.zones().nth_live_view(pick, &periodic)) send_snapshot(periodic, true);
      const double ms = ms_between(start, Clock::now());
      hooks.after_frame(info.frame_index, pose, report, ms);
      s.mapping.record(ms_between(start, Clock::now()));
      if (s.frames_mapped % options.publish_every_frames == 0) {
        std::uint32_t out = kEnd;
        if (!out_free.pop(&out)) {
          ++s.outputs_skipped;
        } else {
          // The merged boxes come from the extraction thread, after every job so far.
          OutputBuffer& buffer = outputs[out];
          buffer.acquired = info.acquired;
          buffer.time_s = frame_time;
          buffer.world_T_body = pose * options.body_T_camera.inverse();
          if (!sinks.empty()) {
            buffer.sectors_observed =
                observed_sectors(mapper.zones(), mapper.config().cell_size_m, buffer.world_T_body,
                                 options.world_z_up, options.sectors);
          }
          fill_health(&buffer.health, s, scope.counted());
          ExtractionJob job = context_job(ExtractionJob::Kind::kPublish);
          job.slot = out;
          push_job(job);
        }
      }
    }
    // Every allocation answered before the end, so that no box is left behind.
    apply_reintegration(allocations_sent, nullptr);
    const os::AllocationCounts counted = scope.counted();
    s.mapping_thread_allocations = counted.allocations;
    s.mapping_thread_frees = counted.frees;
    mapping_done.store(true, std::memory_order_release);
    push_job(ExtractionJob{});  // kEnd: the extraction thread passes it on to the output
  }

  // The next filled output buffer (or kEnd); while none comes the sinks get their
  // tick every ObstacleSink::kTickPeriodS (asleep in between, woken by a push).
  std::uint32_t next_output() {
    std::uint32_t out = kEnd;
    while (!out_filled.pop(&out)) {
      const std::uint32_t ticket = output_bell.ticket();
      if (out_filled.pop(&out)) break;
      for (hal::ObstacleSink* sink : sinks) sink->tick(seconds_since(started));
      if (sinks.empty()) {
        output_bell.wait(ticket);
      } else {
        output_bell.wait_until(ticket, Clock::now() + std::chrono::microseconds(static_cast<long>(
                                                          hal::ObstacleSink::kTickPeriodS * 1e6)));
      }
    }
    for (hal::ObstacleSink* sink : sinks) sink->tick(seconds_since(started));
    return out;
  }

  void output() {
    PipelineStats& s = output_stats;
    realtime(options.priority_output, options.cpu_output, &s, "output");
    os::AllocationScope scope;
    double last_health_s = -1e300;
    while (true) {
      const std::uint32_t out = next_output();
      if (out == kEnd) break;
      OutputBuffer& buffer = outputs[out];
      const double now = seconds_since(started);
      hal::ObstacleUpdate update;
      update.time_s = buffer.time_s;
      update.world_T_body = buffer.world_T_body;
      update.world_z_up = options.world_z_up;
      update.boxes = buffer.boxes.data();
      update.count = buffer.count;
      update.rects = buffer.rects.data();
      update.rect_offsets = buffer.rect_offsets.data();
      update.rect_counts = buffer.rect_counts.data();
      update.sectors_observed = buffer.sectors_observed;
      for (hal::ObstacleSink* sink : sinks) sink->publish(update, now);
      const double ms = ms_between(buffer.acquired, Clock::now());
      s.end_to_end.record(ms);
      if (ms > options.frame_period_s * 1000.0) ++s.deadline_misses;
      ++s.outputs_published;
      if (!sinks.empty() && now - last_health_s >= options.health_period_s) {
        last_health_s = now;
        hal::HealthSnapshot& h = buffer.health;
        h.time_s = buffer.time_s;
        h.deadline_misses = s.deadline_misses;
        h.end_to_end_ms_p50 = s.end_to_end.percentile(0.50);
        h.end_to_end_ms_p99 = s.end_to_end.percentile(0.99);
        h.end_to_end_ms_p999 = s.end_to_end.percentile(0.999);
        h.heap_allocations_after_init += scope.counted().allocations;
        h.static_memory_bytes = static_cast<std::int64_t>(static_bytes);
        h.rss_bytes = os::resident_bytes();
        for (hal::ObstacleSink* sink : sinks) sink->report(&h);
        for (hal::ObstacleSink* sink : sinks) sink->publish_health(h, now);
        ++s.health_published;
      }
      push_waiting(out_free, out, output_bell);
    }
    const os::AllocationCounts counted = scope.counted();
    s.output_thread_allocations = counted.allocations;
    s.output_thread_frees = counted.frees;
  }
  std::size_t static_bytes = 0;
};

void add_to_run_stats(const PipelineStats& p, hal::RunStats* s) {
  s->frames_in += p.frames_in;
  s->frames_rejected += p.frames_rejected;
  s->frames_skipped_no_pose += p.frames_skipped_no_pose;
  s->heap_allocations_after_init += p.mapping_thread_allocations + p.output_thread_allocations +
                                    p.ins_thread_allocations + p.extraction_thread_allocations;
  s->heap_frees_after_init += p.mapping_thread_frees + p.output_thread_frees + p.ins_thread_frees +
                              p.extraction_thread_frees;
  s->pipeline = true;
  s->dropped_mapper_behind += p.dropped_mapper_behind;
  s->dropped_pool_full += p.dropped_pool_full;
  s->pose_waits += p.pose_waits;
  s->outputs_published += p.outputs_published;
  s->outputs_skipped += p.outputs_skipped;
  s->deadline_misses += p.deadline_misses;
  s->end_to_end_ms_p50 = p.end_to_end.percentile(0.50);
  s->end_to_end_ms_p99 = p.end_to_end.percentile(0.99);
  s->end_to_end_ms_p999 = p.end_to_end.percentile(0.999);
  s->end_to_end_ms_max = p.end_to_end.max_ms();
  s->queue_ms_p99 = p.acquire_to_map_start.percentile(0.99);
  s->rss_after_start = p.rss_after_start;
  s->rss_at_end = p.rss_at_end;
}

Pipeline::Pipeline(hal::FrameSource& frames, const PoseTrack* replay_poses,
                   hal::PoseSource* live_poses, std::span<hal::ObstacleSink* const> sinks,
                   Mapper& mapper, FeatureMap& features, MappingHooks& hooks,
                   const PipelineOptions& options)
    : impl_(std::make_unique<Impl>(frames, replay_poses, live_poses, sinks, mapper, features, hooks,
                                   options)) {
  impl_->drop_frame = impl_->source.make_frame();
}

Pipeline::~Pipeline() = default;

void Pipeline::stop() {
  impl_->stop_requested.store(true, std::memory_order_release);
}

std::int64_t Pipeline::frames_offered() const {
  return impl_->offered.load(std::memory_order_acquire);
}

std::size_t Pipeline::reserved_bytes() const {
  const std::size_t pixels = static_cast<std::size_t>(impl_->mapper.camera().width) *
                             static_cast<std::size_t>(impl_->mapper.camera().height);
  const std::size_t boxes = impl_->features.capacity();
  return (kFrameSlots + 1) * pixels * 3 +
         kOutputSlots * (boxes * (sizeof(ObstacleBox) + 2 * sizeof(std::uint32_t)) +
                         impl_->options.footprint_rects * sizeof(FootprintRect)) +
         kSnapshotSlots * impl_->snapshots.front()->reserved_bytes() + sizeof(Impl);
}

void Pipeline::run() {
  stats_ = PipelineStats{};
  if (impl_->options.lock_memory) {
    std::string warning;
    if (!os::lock_memory(&warning)) stats_.warnings.push_back(warning);
  }
  impl_->static_bytes =
      reserved_bytes() + impl_->mapper.reserved_bytes() + impl_->features.reserved_bytes();
  stats_.rss_after_start = os::resident_bytes();
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
  stats_.rss_at_end = os::resident_bytes();
  const PipelineStats& a = impl_->acquisition_stats;
  const PipelineStats& m = impl_->mapping_stats;
  const PipelineStats& o = impl_->output_stats;
  const PipelineStats& i = impl_->ins_stats;
  const PipelineStats& e = impl_->extraction_stats;
  impl_->features.add_cells_reintegrated(m.reintegration_cells);
  stats_.extraction_thread_allocations = e.extraction_thread_allocations;
  stats_.extraction_thread_frees = e.extraction_thread_frees;
  stats_.extractions = e.extractions;
  stats_.extraction = e.extraction;
  stats_.extractions_deferred = m.extractions_deferred;
  stats_.snapshot_waits = m.snapshot_waits;
  stats_.reintegration_boxes = m.reintegration_boxes;
  stats_.reintegration_cells = m.reintegration_cells;
  stats_.reintegration_zone_gone = m.reintegration_zone_gone;
  stats_.frames_in = a.frames_in;
  stats_.frames_rejected = a.frames_rejected + m.frames_rejected;
  stats_.dropped_pool_full = a.dropped_pool_full;
  stats_.frames_lost = a.frames_lost;
  stats_.stopped = a.stopped;
  stats_.frames_mapped = m.frames_mapped;
  stats_.frames_skipped_no_pose = m.frames_skipped_no_pose;
  stats_.dropped_mapper_behind = m.dropped_mapper_behind;
  stats_.pose_waits = m.pose_waits;
  stats_.frames_ground_below_environment = m.frames_ground_below_environment;
  stats_.outputs_skipped = m.outputs_skipped;
  stats_.mapping_thread_allocations = m.mapping_thread_allocations;
  stats_.mapping_thread_frees = m.mapping_thread_frees;
  stats_.acquire_to_map_start = m.acquire_to_map_start;
  stats_.mapping = m.mapping;
  stats_.outputs_published = o.outputs_published;
  stats_.health_published = o.health_published;
  stats_.deadline_misses = o.deadline_misses;
  stats_.end_to_end = o.end_to_end;
  stats_.output_thread_allocations = o.output_thread_allocations;
  stats_.output_thread_frees = o.output_thread_frees;
  stats_.ins_thread_allocations = i.ins_thread_allocations;
  stats_.ins_thread_frees = i.ins_thread_frees;
  for (const auto* part : {&a, &m, &o, &i, &e}) {
    stats_.warnings.insert(stats_.warnings.end(), part->warnings.begin(), part->warnings.end());
  }
}

}  // namespace zonemap::runtime
