#include "runtime/output_stage.hpp"

#include "hal/os/realtime.hpp"

namespace zonemap::runtime {

OutputStage::OutputStage(Links& links, std::span<hal::ObstacleSink* const> sinks,
                         const PipelineOptions& options)
    : links_(links), sinks_(sinks.begin(), sinks.end()), options_(options) {}

void OutputStage::run() {
  os::AllocationScope scope;
  while (true) {
    const std::uint32_t out = next_output();
    if (out == kEndOfStream) break;
    publish(links_.outputs[out], scope);
    push_waiting(links_.out_free, out, links_.output_bell);
  }
  const os::AllocationCounts counted = scope.counted();
  stats_.output_thread_allocations = counted.allocations;
  stats_.output_thread_frees = counted.frees;
}

// The next filled output buffer (or kEndOfStream); while none comes the sinks get
// their tick every ObstacleSink::kTickPeriodS (asleep in between, woken by a push).
std::uint32_t OutputStage::next_output() {
  std::uint32_t out = kEndOfStream;
  while (!links_.out_filled.pop(&out)) {
    const std::uint32_t ticket = links_.output_bell.ticket();
    if (links_.out_filled.pop(&out)) break;
    for (hal::ObstacleSink* sink : sinks_) sink->tick(os::seconds_since(links_.started));
    if (sinks_.empty()) {
      links_.output_bell.wait(ticket);
    } else {
      links_.output_bell.wait_until(ticket, os::after_seconds(hal::ObstacleSink::kTickPeriodS));
    }
  }
  for (hal::ObstacleSink* sink : sinks_) sink->tick(os::seconds_since(links_.started));
  return out;
}

// An update to every sink, its latency against the deadline, and the health
// message when a health period has passed.
void OutputStage::publish(OutputBuffer& buffer, const os::AllocationScope& scope) {
  PipelineStats& s = stats_;
  const double now = os::seconds_since(links_.started);
  const hal::ObstacleUpdate update = buffer.update(options_.world_z_up);
  for (hal::ObstacleSink* sink : sinks_) sink->publish(update, now);
  const double ms = os::ms_between(buffer.acquired, Clock::now());
  s.end_to_end.record(ms);
  if (ms > options_.frame_period_s * 1000.0) ++s.deadline_misses;
  ++s.outputs_published;
  if (!sinks_.empty() && now - last_health_s_ >= options_.health_period_s) {
    last_health_s_ = now;
    publish_health(buffer, scope, now);
    ++s.health_published;
  }
}

// The output side's figures added to the mapping side's counters in the buffer.
void OutputStage::publish_health(OutputBuffer& buffer, const os::AllocationScope& scope,
                                 double now) {
  const PipelineStats& s = stats_;
  hal::HealthSnapshot& h = buffer.health;
  h.time_s = buffer.time_s;
  h.deadline_misses = s.deadline_misses;
  h.end_to_end_ms_p50 = s.end_to_end.percentile(0.50);
  h.end_to_end_ms_p99 = s.end_to_end.percentile(0.99);
  h.end_to_end_ms_p999 = s.end_to_end.percentile(0.999);
  h.heap_allocations_after_init += scope.counted().allocations;
  h.static_memory_bytes = static_cast<std::int64_t>(links_.static_bytes);
  h.rss_bytes = os::resident_bytes();
  for (hal::ObstacleSink* sink : sinks_) sink->report(&h);
  for (hal::ObstacleSink* sink : sinks_) sink->publish_health(h, now);
}

}  // namespace zonemap::runtime
