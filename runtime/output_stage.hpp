// The output stage: each merged update to every sink, the end-to-end latency
// against the frame's deadline, the health message once a health period, and
// the sinks' ticks (heartbeats) while no update comes.
#pragma once

#include <span>
#include <vector>

#include "hal/os/allocation_counter.hpp"
#include "runtime/links.hpp"

namespace zonemap::runtime {

class OutputStage {
 public:
  OutputStage(Links& links, std::span<hal::ObstacleSink* const> sinks,
              const PipelineOptions& options);
  void run();  // until the end of the stream
  const PipelineStats& stats() const { return stats_; }

 private:
  std::uint32_t next_output();
  void publish(OutputBuffer& buffer, const os::AllocationScope& scope);
  void publish_health(OutputBuffer& buffer, const os::AllocationScope& scope, double now);

  Links& links_;
  const std::vector<hal::ObstacleSink*> sinks_;
  const PipelineOptions& options_;
  double last_health_s_ = -1e300;
  PipelineStats stats_;
};

}  // namespace zonemap::runtime
