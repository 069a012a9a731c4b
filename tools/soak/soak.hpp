// The soak: a generated flight looped for as long as asked (the out-and-back
// route, pre-rendered once, frames re-stamped as they come round), through the
// threaded pipeline with a live INS thread and a sink, sampling memory and every
// counter as it goes. `zonemap-soak` runs the 30-minute version; a test runs a
// short one.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "hal/output/obstacle_sink.hpp"
#include "runtime/pipeline.hpp"

namespace zonemap::soak {

struct SoakOptions {
  std::int64_t frames = 54'000;  // 30 minutes at 30 Hz
  double rate_hz = 30.0;         // 0: as fast as the mapper goes (lossless)
  int width = 640;
  int pixel_step = 1;
  std::int64_t max_loop_frames = 0;  // 0: the whole route; else its first N frames
  double health_period_s = 10.0;
  bool quiet = false;
};

struct SoakSample {  // one health snapshot, as the sink saw it
  double uptime_s = 0.0;
  std::int64_t frames_in = 0, frames_mapped = 0, frames_dropped = 0, allocations = 0;
  std::int32_t features = 0, zones_allocated = 0;
  std::int64_t rss_bytes = 0;
  double end_to_end_ms_p99 = 0.0;
};

struct SoakResult {
  runtime::PipelineStats stats;
  std::vector<SoakSample> samples;  // every health period
  std::int64_t loop_frames = 0;
  double render_ms_per_frame = 0.0;
  std::size_t features_capacity = 0;
  std::int64_t features_at_end = 0;
  std::uint64_t static_memory_bytes = 0;
};

bool run_soak(const SoakOptions& options, SoakResult* result, std::string* error);
std::string to_json(const SoakOptions& options, const SoakResult& result);

}  // namespace zonemap::soak
