// The output thread: each filled output buffer to every sink, the end-to-end
// latency against the frame's deadline, the health message once a health period,
// and the sinks' ticks (heartbeats) while no update comes.
#include "hal/os/realtime.hpp"
#include "runtime/pipeline_impl.hpp"

namespace zonemap::runtime {

hal::ObstacleUpdate Pipeline::Impl::OutputBuffer::update(bool world_z_up) const {
  hal::ObstacleUpdate u;
  u.time_s = time_s;
  u.world_T_body = world_T_body;
  u.world_z_up = world_z_up;
  u.boxes = boxes.data();
  u.count = count;
  u.rects = rects.data();
  u.rect_offsets = rect_offsets.data();
  u.rect_counts = rect_counts.data();
  u.sectors_observed = sectors_observed;
  return u;
}

// The next filled output buffer (or kEndOfStream); while none comes the sinks get their
// tick every ObstacleSink::kTickPeriodS (asleep in between, woken by a push).
std::uint32_t Pipeline::Impl::next_output() {
  std::uint32_t out = kEndOfStream;
  while (!out_filled.pop(&out)) {
    const std::uint32_t ticket = output_bell.ticket();
    if (out_filled.pop(&out)) break;
    for (hal::ObstacleSink* sink : sinks) sink->tick(os::seconds_since(started));
    if (sinks.empty()) {
      output_bell.wait(ticket);
    } else {
      output_bell.wait_until(ticket, os::after_seconds(hal::ObstacleSink::kTickPeriodS));
    }
  }
  for (hal::ObstacleSink* sink : sinks) sink->tick(os::seconds_since(started));
  return out;
}

// The output side's figures added to the mapping side's counters in the buffer.
void Pipeline::Impl::publish_health(OutputBuffer& buffer, const PipelineStats& s,
                                    const os::AllocationScope& scope, double now) {
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
}

void Pipeline::Impl::output() {
  PipelineStats& s = output_stats;
  realtime(options.priority_output, options.cpu_output, &s, "output");
  os::AllocationScope scope;
  double last_health_s = -1e300;
  while (true) {
    const std::uint32_t out = next_output();
    if (out == kEndOfStream) break;
    OutputBuffer& buffer = outputs[out];
    const double now = os::seconds_since(started);
    const hal::ObstacleUpdate update = buffer.update(options.world_z_up);
    for (hal::ObstacleSink* sink : sinks) sink->publish(update, now);
    const double ms = os::ms_between(buffer.acquired, Clock::now());
    s.end_to_end.record(ms);
    if (ms > options.frame_period_s * 1000.0) ++s.deadline_misses;
    ++s.outputs_published;
    if (!sinks.empty() && now - last_health_s >= options.health_period_s) {
      last_health_s = now;
      publish_health(buffer, s, scope, now);
      ++s.health_published;
    }
    push_waiting(out_free, out, output_bell);
  }
  const os::AllocationCounts counted = scope.counted();
  s.output_thread_allocations = counted.allocations;
  s.output_thread_frees = counted.frees;
}

}  // namespace zonemap::runtime
