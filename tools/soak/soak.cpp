#include "tools/soak/soak.hpp"

#include <chrono>
#include <sstream>
#include <thread>

#include "hal/config/yaml_config.hpp"
#include "hal/os/clock.hpp"
#include "hal/replay/replay_frame_source.hpp"
#include "runtime/runtime_config.hpp"
#include "tools/sim/scenarios.hpp"

namespace zonemap::soak {
namespace {

using os::Clock;
using os::seconds_since;

// The route's frames, rendered once; frame i is loop[i % n] stamped i / rate.
struct Loop {
  CameraModel camera;
  std::vector<std::vector<std::uint16_t>> depth;
  std::vector<std::vector<std::uint8_t>> left;
  std::vector<PoseSample> poses;  // camera poses at loop times (one lap)
  double lap_s = 0.0;
};

class LoopCamera final : public hal::FrameSource {
 public:
  LoopCamera(const Loop& loop, const SoakOptions& options, Clock::time_point start)
      : loop_(loop), options_(options), start_(start) {}
  const CameraModel& camera() const override { return loop_.camera; }
  hal::CameraFrame make_frame() const override {
    hal::CameraFrame f;
    f.depth.assign(loop_.depth[0].size(), 0);
    f.left.assign(loop_.left[0].size(), 0);
    return f;
  }
  hal::FrameRead next(hal::CameraFrame* frame, int, std::string*) override {
    if (next_ >= options_.frames) return hal::FrameRead::kEnd;
    const double t = frame_time(next_);
    if (options_.rate_hz > 0.0) {  // a camera: frame i at start + i / rate
      const double wait = t - seconds_since(start_);
      if (wait > 0) std::this_thread::sleep_for(std::chrono::duration<double>(wait));
    }
    const std::size_t k =
        static_cast<std::size_t>(next_ % static_cast<std::int64_t>(loop_.depth.size()));
    std::copy(loop_.depth[k].begin(), loop_.depth[k].end(), frame->depth.begin());
    std::copy(loop_.left[k].begin(), loop_.left[k].end(), frame->left.begin());
    frame->has_left = true;
    frame->time_s = t;
    ++next_;
    return hal::FrameRead::kFrame;
  }
  double frame_time(std::int64_t i) const {
    const double rate = options_.rate_hz > 0.0 ? options_.rate_hz : 30.0;
    return static_cast<double>(i) / rate;
  }

 private:
  const Loop& loop_;
  const SoakOptions& options_;
  Clock::time_point start_;
  std::int64_t next_ = 0;
};

// The INS: the loop's poses, re-stamped lap after lap, never more than a few
// samples ahead of the camera (a ring buffer holds them).
class LoopIns final : public hal::PoseSource {
 public:
  LoopIns(const Loop& loop, const LoopCamera& camera, const hal::FrameSource& frames)
      : loop_(loop), camera_(camera) {
    (void)frames;
  }
  void set_frames_offered(const runtime::Pipeline* p) { pipeline_ = p; }
  hal::PollResult poll(hal::PoseSink& sink, int) override {
    const std::int64_t offered = pipeline_ != nullptr ? pipeline_->frames_offered() : 0;
    const std::int64_t n = static_cast<std::int64_t>(loop_.poses.size());
    // Up to 8 frames ahead of what the camera has delivered.
    while (next_ <= offered + 8) {
      PoseSample p = loop_.poses[static_cast<std::size_t>(next_ % n)];
      p.time_s = camera_.frame_time(next_);
      sink.push(p);
      ++next_;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));  // an INS at ~500 Hz at most
    return hal::PollResult::kIdle;
  }
  hal::PoseSourceCounters counters() const override {
    hal::PoseSourceCounters c;
    c.poses_out = next_;
    return c;
  }
  const char* name() const override { return "looped INS"; }

 private:
  const Loop& loop_;
  const LoopCamera& camera_;
  const runtime::Pipeline* pipeline_ = nullptr;
  std::int64_t next_ = 0;
};

class SamplingSink final : public hal::ObstacleSink {
 public:
  explicit SamplingSink(std::size_t capacity) { samples.reserve(capacity); }
  const char* name() const override { return "soak sampler"; }
  void publish(const hal::ObstacleUpdate&, double) override {}
  void publish_health(const hal::HealthSnapshot& h, double) override {
    if (samples.size() == samples.capacity()) return;
    SoakSample s;
    s.uptime_s = h.uptime_s;
    s.frames_in = h.frames_in;
    s.frames_mapped = h.frames_mapped;
    s.frames_dropped = h.frames_dropped();
    s.allocations = h.heap_allocations_after_init;
    s.features = h.features;
    s.zones_allocated = h.zones_allocated;
    s.rss_bytes = h.rss_bytes;
    s.end_to_end_ms_p99 = h.end_to_end_ms_p99;
    samples.push_back(s);
  }
  std::vector<SoakSample> samples;
};

// The pipeline extracts on its own thread; nothing to add per frame.
class NoHooks final : public runtime::MappingHooks {
 public:
  void after_frame(std::size_t, const Eigen::Isometry3d&, const FrameReport&, double) override {}
};

}  // namespace

bool run_soak(const SoakOptions& options, SoakResult* result, std::string* error) {
  sim::Scenario scenario;
  sim::ScenarioOptions so;
  so.width = options.width;
  so.frame_rate_hz = options.rate_hz > 0.0 ? options.rate_hz : 30.0;
  if (!sim::make_scenario("out-and-back", so, &scenario, error)) return false;
  MapConfig config;
  const std::string config_path = std::string(ZONEMAP_SOURCE_DIR) + "/" + scenario.config;
  runtime::PipelineOptions pipeline_options;
  if (!hal::load_map_config(config_path, &config, error) ||
      !runtime::load_pipeline_options(config_path, &pipeline_options, error)) {
    return false;
  }
  config.pixel_step = options.pixel_step;
  Loop loop;
  loop.camera = scenario.camera;
  const std::size_t pixels = static_cast<std::size_t>(loop.camera.width) * loop.camera.height;
  const auto render_start = Clock::now();
  sim::Rng rng(7);
  if (options.max_loop_frames > 0 &&
      scenario.trajectory.size() > static_cast<std::size_t>(options.max_loop_frames)) {
    scenario.trajectory.resize(static_cast<std::size_t>(options.max_loop_frames));
  }
  for (const sim::TimedPose& p : scenario.trajectory) {
    loop.depth.emplace_back(pixels);
    loop.left.emplace_back(pixels);
    sim::render(scenario.scene, loop.camera, p.world_T_camera, sim::RenderOptions{}, rng,
                loop.depth.back().data(), loop.left.back().data());
    PoseSample s;
    s.position = p.world_T_camera.translation();
    s.attitude = Eigen::Quaterniond(p.world_T_camera.linear()).normalized();
    loop.poses.push_back(s);
  }
  result->loop_frames = static_cast<std::int64_t>(loop.depth.size());
  result->render_ms_per_frame =
      seconds_since(render_start) * 1000.0 / static_cast<double>(loop.depth.size());

  Mapper mapper(config, loop.camera);
  FeatureMap features(config, true);
  mapper.zones().add_observer(&features);
  NoHooks hooks;
  SamplingSink sink(4096);
  hal::ObstacleSink* sinks[] = {&sink};
  const auto start = Clock::now();
  LoopCamera camera(loop, options, start);
  LoopIns ins(loop, camera, camera);
  pipeline_options.lossless = options.rate_hz <= 0.0;
  pipeline_options.health_period_s = options.health_period_s;
  pipeline_options.publish_every_frames = 3;
  runtime::Pipeline pipeline(camera, nullptr, &ins, sinks, mapper, features, hooks,
                             pipeline_options);
  ins.set_frames_offered(&pipeline);
  result->static_memory_bytes =
      mapper.reserved_bytes() + features.reserved_bytes() + pipeline.reserved_bytes();
  pipeline.run();
  result->stats = pipeline.stats();
  result->samples = sink.samples;
  result->features_capacity = features.capacity();
  result->features_at_end = static_cast<std::int64_t>(features.count());
  return true;
}

std::string to_json(const SoakOptions& o, const SoakResult& r) {
  const runtime::PipelineStats& s = r.stats;
  std::ostringstream j;
  j << "{\"frames_requested\": " << o.frames << ", \"rate_hz\": " << o.rate_hz
    << ", \"loop_frames\": " << r.loop_frames
    << ", \"render_ms_per_frame\": " << r.render_ms_per_frame
    << ",\n \"frames_in\": " << s.frames_in << ", \"frames_mapped\": " << s.frames_mapped
    << ", \"frames_skipped_no_pose\": " << s.frames_skipped_no_pose
    << ", \"frames_rejected\": " << s.frames_rejected
    << ", \"dropped_mapper_behind\": " << s.dropped_mapper_behind
    << ", \"dropped_pool_full\": " << s.dropped_pool_full
    << ", \"deadline_misses\": " << s.deadline_misses
    << ",\n \"allocations_after_init\": {\"mapping\": " << s.mapping_thread_allocations
    << ", \"output\": " << s.output_thread_allocations << ", \"ins\": " << s.ins_thread_allocations
    << ", \"extraction\": " << s.extraction_thread_allocations
    << "}, \"frees_after_init\": {\"mapping\": " << s.mapping_thread_frees
    << ", \"output\": " << s.output_thread_frees << ", \"ins\": " << s.ins_thread_frees
    << ", \"extraction\": " << s.extraction_thread_frees << "}"
    << ",\n \"extractions\": " << s.extractions
    << ", \"extractions_deferred\": " << s.extractions_deferred
    << ",\n \"rss_bytes\": {\"after_start\": " << s.rss_after_start
    << ", \"at_end\": " << s.rss_at_end << "}, \"static_memory_bytes\": " << r.static_memory_bytes
    << ",\n \"features_at_end\": " << r.features_at_end
    << ", \"features_capacity\": " << r.features_capacity
    << ",\n \"end_to_end_ms\": {\"p50\": " << s.end_to_end.percentile(0.5)
    << ", \"p99\": " << s.end_to_end.percentile(0.99)
    << ", \"p99.9\": " << s.end_to_end.percentile(0.999) << ", \"max\": " << s.end_to_end.max_ms()
    << "}"
    << ",\n \"mapping_ms\": {\"p50\": " << s.mapping.percentile(0.5)
    << ", \"p99\": " << s.mapping.percentile(0.99) << "},\n \"samples\": [";
  for (std::size_t i = 0; i < r.samples.size(); ++i) {
    const SoakSample& x = r.samples[i];
    j << (i ? ",\n  " : "\n  ") << "{\"t\": " << x.uptime_s << ", \"in\": " << x.frames_in
      << ", \"mapped\": " << x.frames_mapped << ", \"dropped\": " << x.frames_dropped
      << ", \"allocations\": " << x.allocations << ", \"features\": " << x.features
      << ", \"zones_allocated\": " << x.zones_allocated << ", \"rss\": " << x.rss_bytes
      << ", \"e2e_p99_ms\": " << x.end_to_end_ms_p99 << "}";
  }
  j << "]}\n";
  return j.str();
}

}  // namespace zonemap::soak
