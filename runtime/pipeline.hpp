// The onboard runtime around the single-threaded mapping core: acquisition,
// mapping, feature extraction and output stages, each its own thread, joined by
// fixed-capacity lock-free SPSC queues. Frames live in a pool reserved at start-up
// and travel through the queues by index; poses reach the mapper through a
// lock-free PoseBuffer. The extraction thread owns the feature map: the mapping
// thread hands it zone snapshots (periodic, and before a zone's grid goes), asks
// it for the boxes to re-integrate when a zone is allocated, and asks it for the
// merged boxes of each update. Every thread counts its heap allocations from its
// first loop on (they must stay at zero).
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <span>

#include "hal/frames/frame_source.hpp"
#include "hal/ins/pose_source.hpp"
#include "hal/output/obstacle_sink.hpp"
#include "hal/output/run_outputs.hpp"
#include "zonemap/common/config.hpp"
#include "zonemap/containers/latency_histogram.hpp"
#include "zonemap/features/feature_map.hpp"
#include "zonemap/features/shared_map_inbox.hpp"
#include "zonemap/mapping/mapper.hpp"

namespace zonemap::runtime {

struct PipelineOptions {
  // The configuration's `pipeline:` section sets the timing and real-time fields
  // (runtime_config.hpp); the command line may then change lossless /
  // source_rate_hz / lock_memory, the program the rest.
  // Lossless: the source waits for a free frame slot, every frame is mapped (replay,
  // determinism). Otherwise newest wins: a mapper that falls behind skips to the
  // newest waiting frame; the skipped ones are dropped and counted.
  bool lossless = true;
  double source_rate_hz = 0.0;         // 0: as fast as the source can; else paced like a camera
  double frame_period_s = 1.0 / 30.0;  // deadline for end-to-end latency
  double pose_wait_s = 0.05;           // how long a frame waits for a late pose
  int publish_every_frames = 3;        // merged boxes to the output stage
  bool lock_memory = false;
  int priority_acquisition = 0, priority_mapping = 0, priority_output = 0;  // SCHED_FIFO, 0 = off
  int cpu_acquisition = -1, cpu_mapping = -1, cpu_output = -1;              // -1 = any
  int priority_ins = 0, cpu_ins = -1;                                       // the live INS thread
  int priority_extraction = 0, cpu_extraction = -1;                         // feature extraction
  // Threads sharing the mapping step's frustum walk, the mapping thread one of
  // them (the others at priority_mapping); the map is the same for any count.
  int mapping_workers = 1;
  std::vector<int> cpu_workers;  // worker w (1..) pinned to cpu_workers[w - 1]; absent: any
  double health_period_s = 1.0;  // health to the sinks
  bool include_ground = false;   // ground boxes to the sinks too
  Eigen::Isometry3d body_T_camera = Eigen::Isometry3d::Identity();  // for body-frame outputs
  bool world_z_up = true;
  SectorConfig sectors;                 // the band and range in which sectors count as observed
  std::size_t footprint_rects = 16384;  // footprint rectangles per output buffer
  // Maps other vehicles share (a receiver thread fills it): taken into the feature
  // map on the extraction thread before each update is merged. Null: none.
  SharedMapInbox* shared_maps = nullptr;
};

// The shared counters (hal::FrameCounters; heap_* the threads' sum) plus each
// thread's allocations, the extraction protocol's figures and the latencies.
struct PipelineStats : hal::FrameCounters {
  std::int64_t mapping_thread_allocations = 0, mapping_thread_frees = 0;
  std::int64_t output_thread_allocations = 0, output_thread_frees = 0;
  std::int64_t ins_thread_allocations = 0, ins_thread_frees = 0;
  std::int64_t extraction_thread_allocations = 0, extraction_thread_frees = 0;
  std::int64_t extractions = 0;           // zone snapshots extracted on the extraction thread
  std::int64_t extractions_deferred = 0;  // newest wins: no spare snapshot slot, next round
  std::int64_t snapshot_waits = 0;        // a discarded zone waited for a snapshot slot
  std::int64_t reintegration_boxes = 0;   // boxes re-integrated by the mapping thread
  std::int64_t reintegration_cells = 0;
  std::int64_t reintegration_zone_gone = 0;  // the zone was discarded before its boxes came
  LatencyHistogram extraction;               // one zone snapshot extracted
  std::int64_t frames_lost = 0;              // the frame source's sequence gaps
  // The sky filter's pixels (SkyFilter): taken for sky, refused (bright, flat, no
  // depth, but not where sky can be), and the last mapped frame's of each.
  std::int64_t pixels_sky = 0, pixels_sky_refused = 0;
  std::int64_t sky_last_frame = 0, sky_refused_last_frame = 0, sky_refused_max_frame = 0;
  std::int64_t health_published = 0;
  bool stopped = false;                   // stop() ended the run before the source did
  LatencyHistogram acquire_to_map_start;  // queueing
  LatencyHistogram mapping;               // the mapping step (+ extraction when due)
  LatencyHistogram end_to_end;            // acquisition done -> boxes out
  std::vector<std::string> warnings;      // real-time set-up refused, etc.
  long rss_after_start = 0, rss_at_end = 0;
};

// Hooks into the replay job, called on the mapping thread (must not allocate, and
// must not touch the feature map: the extraction thread owns it during run()).
class MappingHooks {
 public:
  virtual ~MappingHooks() = default;
  // After each mapped frame: trajectory, timings, etc.
  virtual void after_frame(std::size_t frame_index, const Eigen::Isometry3d& pose,
                           const FrameReport& report, double mapping_ms) = 0;
  // A mapped frame and the camera pose it was mapped with, before its buffer goes
  // back to the pool (to copy what is needed of it, e.g. into a recording's
  // slot); nothing by default.
  virtual void frame_mapped(const hal::CameraFrame& /*frame*/,
                            const Eigen::Isometry3d& /*world_T_camera*/) {}
};

// Adds a pipeline run's figures to stats.json's (frames, drops, latency, memory,
// allocations of every thread). Counts are added, so single-threaded figures stay.
void add_to_run_stats(const PipelineStats& pipeline, hal::RunStats* stats);

// A mapped frame's sky pixels into the pipeline's figures (health, stats.json).
void count_sky(const FrameReport& report, PipelineStats* stats);

class Pipeline {
 public:
  static constexpr int kFrameSlots = 6;
  static constexpr int kOutputSlots = 3;
  // Zone snapshots: one per zone that can be discarded at once, plus two for the
  // periodic extraction in flight.
  static constexpr int kSnapshotSlots = kZonesHeld + 2;

  // Any frame source. Poses: either `replay_poses` (pushed as the frames come) or a
  // live source polled on its own INS thread. Sinks get every published update.
  Pipeline(hal::FrameSource& frames, const PoseTrack* replay_poses, hal::PoseSource* live_poses,
           std::span<hal::ObstacleSink* const> sinks, Mapper& mapper, FeatureMap& features,
           MappingHooks& hooks, const PipelineOptions& options);
  ~Pipeline();

  // Runs until the frame source ends (or stop()) through the threads, joins them.
  void run();
  // Any thread, e.g. a signal: the acquisition ends after its current frame and
  // everything already acquired is mapped and published.
  void stop();
  const PipelineStats& stats() const { return stats_; }
  // Frames the acquisition stage has dealt with so far, handed on or dropped
  // (any thread may read).
  std::int64_t frames_offered() const;
  std::size_t reserved_bytes() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  PipelineStats stats_;
};

}  // namespace zonemap::runtime
