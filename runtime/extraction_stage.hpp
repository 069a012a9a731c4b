// The extraction stage owns the feature map: it extracts the zone snapshots the
// mapping stage sends, answers an allocated zone with the boxes to write back,
// takes other vehicles' maps in, and merges the boxes of each update.
#pragma once

#include "hal/os/allocation_counter.hpp"
#include "runtime/links.hpp"

namespace zonemap::runtime {

class ExtractionStage {
 public:
  ExtractionStage(Links& links, FeatureMap& features, const PipelineOptions& options);
  void run();  // until the mapping stage's end job; then the end of the stream
  const PipelineStats& stats() const { return stats_; }

 private:
  void extract(const ExtractionJob& job);
  void answer_allocation(const ExtractionJob& job);
  void take_shared_maps();
  void merge_for_output(const ExtractionJob& job, const os::AllocationScope& scope);
  void fill_feature_health(hal::HealthSnapshot* h) const;  // health.cpp

  Links& links_;
  FeatureMap& features_;
  const PipelineOptions& options_;
  PipelineStats stats_;
};

}  // namespace zonemap::runtime
