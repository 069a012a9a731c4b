// The pipeline's shared state, private to runtime/: the frame pool, the output
// buffers, the zone snapshots, the channels between the threads and each
// thread's counters. Each thread body lives in a file of its own:
//   acquisition.cpp          frames in, into the pool
//   ins_stage.cpp            live poses in; a frame's pose, waited for a bounded time
//   mapping_stage.cpp        the mapping step, the periodic snapshot, publish requests
//   extraction_protocol.cpp  the feature map's jobs: snapshots, re-integration, merged boxes
//   output_stage.cpp         updates and health to the sinks
//   health.cpp               the health message's and stats.json's counters
//   pipeline.cpp             start-up reservation, the threads' start and join
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "hal/os/allocation_counter.hpp"
#include "hal/os/clock.hpp"
#include "hal/os/doorbell.hpp"
#include "runtime/channel.hpp"
#include "runtime/pipeline.hpp"
#include "zonemap/features/extraction_schedule.hpp"
#include "zonemap/pose/pose_buffer.hpp"
#include "zonemap/zones/zone_snapshot.hpp"

namespace zonemap::runtime {

using os::Clock;

// The INS thread's counters as the other threads may read them (relaxed: each
// is a count on its own, no consistency across them is needed).
struct SharedInsCounters {
  std::atomic<std::int64_t> messages{0}, malformed{0}, solutions{0}, poses_out{0}, link_errors{0},
      rejected{0}, reanchors{0};
  void store(const hal::PoseSourceCounters& c);
};

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
  std::size_t static_bytes = 0;  // reported in the health message

  // --- frames: acquisition -> mapping ---------------------------------------------
  struct SlotInfo {
    std::size_t frame_index = 0;
    Clock::time_point acquired;
  };
  std::array<hal::CameraFrame, kFrameSlots> frames;
  std::array<SlotInfo, kFrameSlots> frame_info{};
  // Newest wins with every slot waiting: the next frame is read into this spare
  // buffer and dropped (a live source must be drained, not left to queue up).
  hal::CameraFrame drop_frame;
  // Each thread's bell: rung when there may be work (or room) for it.
  os::Doorbell acquisition_bell, mapping_bell, extraction_bell, output_bell;
  Channel<std::uint32_t, 16> filled;      // acquisition -> mapping
  Channel<std::uint32_t, 16> free_slots;  // mapping -> acquisition
  PoseBuffer<512> poses;
  PoseTrack mapping_track{0.1, 0.02};

  // --- updates: mapping -> extraction -> output -----------------------------------
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
    hal::ObstacleUpdate update(bool world_z_up) const;  // what the sinks get of it
  };
  std::array<OutputBuffer, kOutputSlots> outputs;
  Channel<std::uint32_t, 4> out_filled;  // extraction -> output
  Channel<std::uint32_t, 4> out_free;    // output -> mapping

  // --- the extraction protocol (extraction_protocol.cpp) -------------------------
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
    Eigen::Isometry3d camera_pose() const;
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
  PeakTrim snapshot_trim;  // the mapping thread's: it captures the snapshots
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

  // --- what the threads share besides the channels ------------------------------
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
       const PipelineOptions& o);
  std::size_t reserved_bytes() const;
  // stats() after join: each thread's counters in one PipelineStats.
  PipelineStats gathered_stats() const;

  // SCHED_FIFO and CPU for the calling thread; a refusal becomes a warning.
  void realtime(int priority, int cpu, PipelineStats* stats, const char* stage);

  // acquisition.cpp
  void acquisition();
  void push_replay_poses_until(double time_s, std::size_t* next_pose);

  // ins_stage.cpp
  void ins();
  bool pose_for(double time_s, Eigen::Isometry3d* pose, PipelineStats* s);

  // mapping_stage.cpp
  void mapping();
  std::uint32_t newest_filled(std::uint32_t slot, bool* end);
  void request_publish(const SlotInfo& info, double frame_time_s, const Eigen::Isometry3d& pose,
                       const os::AllocationCounts& allocations);

  // extraction_protocol.cpp: the mapping thread's side
  template <typename Done>
  void wait_for_extraction(Done done);
  void push_job(const ExtractionJob& job);
  ExtractionJob context_job(ExtractionJob::Kind kind) const;
  bool send_snapshot(const ZoneView& zone, bool periodic);
  void zone_discarding(const ZoneView& zone);
  void zone_allocated(ZoneView& zone);
  void apply_reintegration(std::uint64_t until, ZoneView* allocating);
  // extraction_protocol.cpp: the extraction thread
  void extraction();
  void answer_allocation(const ExtractionJob& job);
  void merge_for_output(const ExtractionJob& job, const os::AllocationScope& scope);
  void take_shared_maps();

  // output_stage.cpp
  void output();
  std::uint32_t next_output();
  void publish_health(OutputBuffer& buffer, const PipelineStats& s,
                      const os::AllocationScope& scope, double now);

  // health.cpp
  void fill_health(hal::HealthSnapshot* h, const PipelineStats& s,
                   const os::AllocationCounts& allocations);
  void fill_feature_health(hal::HealthSnapshot* h);
};

}  // namespace zonemap::runtime
