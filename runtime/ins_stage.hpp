// The INS stage: a live pose source polled on its own thread into the pose
// buffer, its counters shared for the health message, until mapping is done.
#pragma once

#include "runtime/links.hpp"

namespace zonemap::runtime {

class InsStage {
 public:
  InsStage(Links& links, hal::PoseSource& source);
  void run();
  const PipelineStats& stats() const { return stats_; }

 private:
  Links& links_;
  hal::PoseSource& source_;
  PipelineStats stats_;
};

}  // namespace zonemap::runtime
