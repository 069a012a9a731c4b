// The mapping stage: each frame's pose, the mapping step, and the mapping side
// of the extraction protocol (extraction_requests.cpp): zone snapshots to
// extract, allocated zones' boxes to write back, the merged boxes to publish.
// Allocates nothing from its first loop on.
#pragma once

#include "hal/os/allocation_counter.hpp"
#include "runtime/links.hpp"
#include "zonemap/features/extraction_schedule.hpp"

namespace zonemap::runtime {

class MappingStage {
 public:
  // The feature map's values the mapping stage needs (the map itself is the
  // extraction stage's from start-up on).
  struct FeatureValues {
    FusedCell snapshot_threshold;   // what a snapshot keeps
    FusedCell reintegration_value;  // what a box writes back
  };
  // `observe_sectors`: some sink wants the sectors the live grid has seen.
  MappingStage(Links& links, Mapper& mapper, MappingHooks& hooks, const PipelineOptions& options,
               const FeatureValues& values, bool observe_sectors);
  void run();
  // Takes the feature map's place among the zone map's observers while run()
  // goes: zone events become extraction jobs.
  ZoneObserver& zone_events() { return feed_; }
  const PipelineStats& stats() const { return stats_; }
  std::size_t reserved_bytes() const { return snapshot_trim_.reserved_bytes(); }

 private:
  // mapping_stage.cpp
  std::uint32_t newest_filled(std::uint32_t slot, bool* end);
  void map_frame(std::uint32_t slot, const os::AllocationScope& scope);
  bool pose_for(double time_s, Eigen::Isometry3d* pose);
  void after_mapped(const FrameSlotInfo& info, double frame_time_s, const Eigen::Isometry3d& pose,
                    const FrameReport& report, Clock::time_point start,
                    const os::AllocationScope& scope);
  void request_publish(const FrameSlotInfo& info, double frame_time_s,
                       const Eigen::Isometry3d& pose, const os::AllocationCounts& allocations);
  // health.cpp
  void fill_health(hal::HealthSnapshot* h, const os::AllocationCounts& allocations) const;
  // extraction_requests.cpp
  template <typename Done>
  void wait_for_extraction(Done done);
  void push_job(const ExtractionJob& job);
  ExtractionJob context_job(ExtractionJob::Kind kind) const;
  bool send_snapshot(const ZoneView& zone, bool periodic);
  void zone_allocated(ZoneView& zone);
  void apply_reintegration(std::uint64_t until, ZoneView* allocating);

  struct Feed final : ZoneObserver {
    MappingStage* stage = nullptr;
    void on_zone_allocated(ZoneView& zone) override { stage->zone_allocated(zone); }
    void on_zone_discarding(const ZoneView& zone) override { stage->send_snapshot(zone, false); }
  };

  Links& links_;
  Mapper& mapper_;
  MappingHooks& hooks_;
  const PipelineOptions& options_;
  PoseTrack track_{0.1, 0.02};  // the pose buffer's newest poses, looked up per frame
  ExtractionSchedule schedule_;
  const FusedCell snapshot_threshold_;
  PeakTrim snapshot_trim_;  // applied as the snapshots are captured
  const FusedCell reintegration_value_;
  const bool observe_sectors_;
  // The feature map's context at the last frame: sent with every job.
  double context_time_s_ = 0.0;
  Eigen::Isometry3d context_pose_ = Eigen::Isometry3d::Identity();
  std::uint64_t allocations_sent_ = 0, allocations_answered_ = 0;
  Feed feed_;
  PipelineStats stats_;
};

}  // namespace zonemap::runtime
