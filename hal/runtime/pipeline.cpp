#include "hal/runtime/pipeline.hpp"

#include <array>
#include <chrono>
#include <thread>

#include "hal/os/allocation_counter.hpp"
#include "hal/os/realtime.hpp"
#include "zonemap/pose_buffer.hpp"
#include "zonemap/spsc_queue.hpp"

namespace zonemap::runtime {
namespace {

using Clock = std::chrono::steady_clock;
constexpr std::uint32_t kEnd = UINT32_MAX;  // end of stream, through the queues

double ms_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

// Waiting for work on an idle queue: yield the CPU, never sleep on a lock.
template <typename Queue, typename T>
void pop_waiting(Queue& queue, T* item) {
  while (!queue.pop(item)) std::this_thread::yield();
}
template <typename Queue, typename T>
void push_waiting(Queue& queue, const T& item) {
  while (!queue.push(item)) std::this_thread::yield();
}

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
  return o;
}

struct Pipeline::Impl {
  const hal::ReplaySequence& sequence;
  Mapper& mapper;
  FeatureMap& features;
  MappingHooks& hooks;
  PipelineOptions options;

  struct SlotInfo {
    std::size_t frame_index = 0;
    Clock::time_point acquired;
  };
  std::array<hal::ReplayFrame, kFrameSlots> frames;
  std::array<SlotInfo, kFrameSlots> frame_info{};
  SpscQueue<std::uint32_t, 16> filled;      // acquisition -> mapping
  SpscQueue<std::uint32_t, 16> free_slots;  // mapping -> acquisition
  PoseBuffer<512> poses;
  PoseTrack mapping_track{0.1, 0.02};

  struct OutputBuffer {
    std::vector<ObstacleBox> boxes;
    std::size_t count = 0;
    Clock::time_point acquired;
  };
  std::array<OutputBuffer, kOutputSlots> outputs;
  SpscQueue<std::uint32_t, 4> out_filled;  // mapping -> output
  SpscQueue<std::uint32_t, 4> out_free;    // output -> mapping

  std::atomic<std::int64_t> offered{0};
  // Counters, each written by one thread only and read after join.
  PipelineStats acquisition_stats, mapping_stats, output_stats;

  Impl(const hal::ReplaySequence& seq, Mapper& m, FeatureMap& f, MappingHooks& h,
       const PipelineOptions& o)
      : sequence(seq), mapper(m), features(f), hooks(h), options(o) {
    for (auto& frame : frames) frame = sequence.make_frame();
    for (std::uint32_t i = 0; i < kFrameSlots; ++i) free_slots.push(i);
    for (auto& out : outputs) out.boxes.resize(features.capacity());
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
    const auto& samples = sequence.poses().samples();
    std::size_t next_pose = 0;
    const double gap = mapper.config().pose_max_gap_s;
    const Clock::time_point start = Clock::now();
    std::uint32_t spare = kEnd;  // a slot taken but not sent (rejected frame)
    std::string why;
    for (std::size_t i = 0; i < sequence.frame_count(); ++i) {
      if (options.source_rate_hz > 0.0) {
        std::this_thread::sleep_until(
            start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(
                        static_cast<double>(i) / options.source_rate_hz)));
      }
      ++s.frames_in;
      // The INS: poses reach the buffer as the frames come (up to one gap ahead).
      const double frame_time = sequence.entry(i).time_s;
      while (next_pose < samples.size() && samples[next_pose].time_s <= frame_time + gap) {
        poses.push(samples[next_pose++]);
      }
      std::uint32_t slot = spare;
      spare = kEnd;
      if (slot == kEnd) {
        if (options.lossless) {
          pop_waiting(free_slots, &slot);
        } else if (!free_slots.pop(&slot)) {
          ++s.dropped_pool_full;  // every slot is waiting: this frame is lost, counted
          offered.fetch_add(1, std::memory_order_release);
          continue;
        }
      }
      if (!sequence.read(i, &frames[slot], &why)) {
        ++s.frames_rejected;
        spare = slot;
        offered.fetch_add(1, std::memory_order_release);
        continue;
      }
      frame_info[slot] = {i, Clock::now()};
      push_waiting(filled, slot);  // cannot stay full: it holds all the slots
      offered.fetch_add(1, std::memory_order_release);
    }
    while (next_pose < samples.size()) poses.push(samples[next_pose++]);
    push_waiting(filled, kEnd);
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
    while (Clock::now() < deadline) {
      std::this_thread::yield();
      newest = poses.snapshot(&mapping_track);
      if (mapping_track.lookup(time_s, pose) != PoseLookup::kNoPose) return true;
      if (newest >= time_s) return false;
    }
    return false;
  }

  void mapping() {
    PipelineStats& s = mapping_stats;
    realtime(options.priority_mapping, options.cpu_mapping, &s, "mapping");
    os::AllocationScope scope;  // from here on the mapping thread must not allocate
    bool end = false;
    while (!end) {
      std::uint32_t slot = kEnd;
      pop_waiting(filled, &slot);
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
          push_waiting(free_slots, slot);
          slot = newer;
        }
      }
      const Clock::time_point start = Clock::now();
      const SlotInfo info = frame_info[slot];
      s.acquire_to_map_start.record(ms_between(info.acquired, start));
      const hal::ReplayFrame& frame = frames[slot];
      Eigen::Isometry3d pose;
      if (!pose_for(frame.time_s, &pose, &s)) {
        ++s.frames_skipped_no_pose;
        push_waiting(free_slots, slot);
        continue;
      }
      DepthFrameView view{frame.depth.data(), frame.has_left ? frame.left.data() : nullptr,
                          mapper.camera().width, mapper.camera().height};
      features.set_context(frame.time_s, pose.translation());
      const FrameReport report = mapper.integrate(view, pose);
      push_waiting(free_slots, slot);
      if (report.status != FrameStatus::kMapped) {
        ++s.frames_rejected;
        continue;
      }
      ++s.frames_mapped;
      const double ms = ms_between(start, Clock::now());
      hooks.after_frame(info.frame_index, pose, report, ms);
      s.mapping.record(ms_between(start, Clock::now()));
      if (s.frames_mapped % options.publish_every_frames == 0) {
        std::uint32_t out = kEnd;
        if (!out_free.pop(&out)) {
          ++s.outputs_skipped;
        } else {
          OutputBuffer& buffer = outputs[out];
          buffer.count = features.merged(buffer.boxes.data(), buffer.boxes.size(), false);
          buffer.acquired = info.acquired;
          push_waiting(out_filled, out);
        }
      }
    }
    const os::AllocationCounts counted = scope.counted();
    s.mapping_thread_allocations = counted.allocations;
    s.mapping_thread_frees = counted.frees;
    push_waiting(out_filled, kEnd);
  }

  void output() {
    PipelineStats& s = output_stats;
    realtime(options.priority_output, options.cpu_output, &s, "output");
    os::AllocationScope scope;
    while (true) {
      std::uint32_t out = kEnd;
      pop_waiting(out_filled, &out);
      if (out == kEnd) break;
      // The vehicle links send outputs[out] here (CAN, LCM); the replay keeps count.
      const double ms = ms_between(outputs[out].acquired, Clock::now());
      s.end_to_end.record(ms);
      if (ms > options.frame_period_s * 1000.0) ++s.deadline_misses;
      ++s.outputs_published;
      push_waiting(out_free, out);
    }
    const os::AllocationCounts counted = scope.counted();
    s.output_thread_allocations = counted.allocations;
    s.output_thread_frees = counted.frees;
  }
};

Pipeline::Pipeline(const hal::ReplaySequence& sequence, Mapper& mapper, FeatureMap& features,
                   MappingHooks& hooks, const PipelineOptions& options)
    : impl_(std::make_unique<Impl>(sequence, mapper, features, hooks, options)) {}

Pipeline::~Pipeline() = default;

std::int64_t Pipeline::frames_offered() const {
  return impl_->offered.load(std::memory_order_acquire);
}

std::size_t Pipeline::reserved_bytes() const {
  const std::size_t pixels = static_cast<std::size_t>(impl_->mapper.camera().width) *
                             static_cast<std::size_t>(impl_->mapper.camera().height);
  return kFrameSlots * pixels * 3 +
         kOutputSlots * impl_->features.capacity() * sizeof(ObstacleBox) + sizeof(Impl);
}

void Pipeline::run() {
  stats_ = PipelineStats{};
  if (impl_->options.lock_memory) {
    std::string warning;
    if (!os::lock_memory(&warning)) stats_.warnings.push_back(warning);
  }
  stats_.rss_after_start = os::resident_bytes();
  std::thread output([this] { impl_->output(); });
  std::thread mapping([this] { impl_->mapping(); });
  std::thread acquisition([this] { impl_->acquisition(); });
  acquisition.join();
  mapping.join();
  output.join();
  stats_.rss_at_end = os::resident_bytes();
  const PipelineStats& a = impl_->acquisition_stats;
  const PipelineStats& m = impl_->mapping_stats;
  const PipelineStats& o = impl_->output_stats;
  stats_.frames_in = a.frames_in;
  stats_.frames_rejected = a.frames_rejected + m.frames_rejected;
  stats_.dropped_pool_full = a.dropped_pool_full;
  stats_.frames_mapped = m.frames_mapped;
  stats_.frames_skipped_no_pose = m.frames_skipped_no_pose;
  stats_.dropped_mapper_behind = m.dropped_mapper_behind;
  stats_.pose_waits = m.pose_waits;
  stats_.outputs_skipped = m.outputs_skipped;
  stats_.mapping_thread_allocations = m.mapping_thread_allocations;
  stats_.mapping_thread_frees = m.mapping_thread_frees;
  stats_.acquire_to_map_start = m.acquire_to_map_start;
  stats_.mapping = m.mapping;
  stats_.outputs_published = o.outputs_published;
  stats_.deadline_misses = o.deadline_misses;
  stats_.end_to_end = o.end_to_end;
  stats_.output_thread_allocations = o.output_thread_allocations;
  stats_.output_thread_frees = o.output_thread_frees;
  for (const auto* part : {&a, &m, &o}) {
    stats_.warnings.insert(stats_.warnings.end(), part->warnings.begin(), part->warnings.end());
  }
}

}  // namespace zonemap::runtime
