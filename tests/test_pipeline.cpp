// The threaded runtime: the pipeline's determinism, static memory and overload
// policy (its queues and pose buffer: tests/core; its doorbells: test_doorbell.cpp).
#include <gtest/gtest.h>

#include "hal/can/obstacle_can_sink.hpp"
#include "hal/mavlink/mavlink_udp_sink.hpp"
#include "hal/replay/replay_frame_source.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <thread>

#include "hal/config/yaml_config.hpp"
#include "pipeline_support.hpp"
#include "replay_support.hpp"
#include "runtime/pipeline.hpp"
#include "test_support.hpp"
#include "tools/replay/replay_run.hpp"

namespace zonemap {
namespace {

std::string test_sequence(const testing::TempDir& dir, const std::string& name, double rate,
                          std::size_t frames) {
  return testing::write_test_scenario(name, dir / "seq", rate, testing::kRuntimePixelStep, frames);
}

// The threaded pipeline (lossless) against the single-threaded replay: the same
// map cell for cell, the same boxes.csv, the same re-integrated cells.
void expect_threaded_equals_single(const char* scenario, double rate_hz, int frames,
                                   int min_box_lines, int mapping_workers = 1) {
  testing::TempDir dir;
  const std::string config =
      test_sequence(dir, scenario, rate_hz, static_cast<std::size_t>(frames));
  ASSERT_FALSE(config.empty());
  tools::ReplayOptions options = testing::quiet_replay(dir / "seq", config);
  std::string error;
  tools::ReplayRun single;
  ASSERT_TRUE(single.open(options, &error)) << error;
  single.run();
  tools::ReplayRun threaded;
  ASSERT_TRUE(threaded.open(options, &error)) << error;
  runtime::PipelineOptions pipeline;  // lossless
  pipeline.mapping_workers = mapping_workers;
  threaded.run_pipelined(pipeline);
  EXPECT_EQ(threaded.stats().frames_mapped, single.stats().frames_mapped);
  if (frames > 0) {
    EXPECT_EQ(threaded.stats().frames_mapped, frames);
  }
  std::int64_t cells = 0, different = 0;
  single.mapper().zones().for_each_live_zone([&](ZoneView& zone) {
    for (int z = 0; z < zone.dims[2]; ++z)
      for (int y = 0; y < zone.dims[1]; ++y)
        for (int x = 0; x < zone.dims[0]; ++x) {
          FusedCell other = 0;
          ASSERT_TRUE(threaded.mapper().zones().value_at(
              {zone.origin.x + x, zone.origin.y + y, zone.origin.z + z}, &other));
          ++cells;
          different += other != zone.cells[zone.index(x, y, z)];
        }
  });
  EXPECT_GT(cells, 0);
  EXPECT_EQ(different, 0) << scenario;
  EXPECT_EQ(threaded.features().counters().cells_reintegrated,
            single.features().counters().cells_reintegrated)
      << scenario;
  EXPECT_EQ(threaded.features().counters().extractions, single.features().counters().extractions)
      << scenario;
  ASSERT_TRUE(single.write_outputs(dir / "single", &error)) << error;
  ASSERT_TRUE(threaded.write_outputs(dir / "threaded", &error)) << error;
  std::ifstream a(dir / "single/boxes.csv"), b(dir / "threaded/boxes.csv");
  std::stringstream sa, sb;
  sa << a.rdbuf();
  sb << b.rdbuf();
  const std::string single_boxes = sa.str();
  EXPECT_EQ(single_boxes, sb.str()) << scenario;
  EXPECT_GE(std::count(single_boxes.begin(), single_boxes.end(), '\n'), min_box_lines) << scenario;
  std::printf(
      "[ %s ] %lld frames, %lld cells compared, %lld re-integrated, boxes.csv %zu bytes\n",
      scenario, static_cast<long long>(single.stats().frames_mapped), static_cast<long long>(cells),
      static_cast<long long>(single.features().counters().cells_reintegrated), single_boxes.size());
}

TEST(Pipeline, ThreadedRunEqualsSingleThreadedRun) {
  // The threaded run's mapping step shared with a worker thread: the same map.
  expect_threaded_equals_single("posts-through", 4.0, 40, 3, 2);  // header, two posts, ground
}

TEST(Pipeline, ThreadedRunEqualsSingleThreadedRunWithZonesComingBack) {
  // Out and back: zones discarded (extracted on the extraction thread) and
  // allocated again (its re-integration boxes written by the mapping thread).
  expect_threaded_equals_single("out-and-back", 1.5, 0, 2);
}

TEST(Pipeline, NoAllocationInTheMappingExtractionAndOutputThreads) {
  testing::TempDir dir;
  const std::string config = test_sequence(dir, "out-and-back", 1.5, 0);  // zones come and go
  tools::ReplayOptions options = testing::quiet_replay(dir / "seq", config);
  std::string error;
  tools::ReplayRun run;
  ASSERT_TRUE(run.open(options, &error)) << error;
  runtime::PipelineOptions pipeline;
  pipeline.publish_every_frames = 1;
  pipeline.mapping_workers = 2;  // the worker's allocations count as the mapping thread's
  run.run_pipelined(pipeline);
  const runtime::PipelineStats& p = run.pipeline_stats();
  std::printf(
      "[ pipeline ] %lld frames mapped, %lld outputs, zones allocated %lld, %lld extractions "
      "on the extraction thread, %lld boxes / %lld cells re-integrated; mapping thread "
      "%lld allocations / %lld frees, extraction thread %lld / %lld, output thread %lld / %lld; "
      "RSS %ld -> %ld bytes\n",
      static_cast<long long>(p.frames_mapped), static_cast<long long>(p.outputs_published),
      static_cast<long long>(run.stats().zones_allocated), static_cast<long long>(p.extractions),
      static_cast<long long>(p.reintegration_boxes), static_cast<long long>(p.reintegration_cells),
      static_cast<long long>(p.mapping_thread_allocations),
      static_cast<long long>(p.mapping_thread_frees),
      static_cast<long long>(p.extraction_thread_allocations),
      static_cast<long long>(p.extraction_thread_frees),
      static_cast<long long>(p.output_thread_allocations),
      static_cast<long long>(p.output_thread_frees), p.rss_after_start, p.rss_at_end);
  EXPECT_GT(p.frames_mapped, 50);
  EXPECT_GT(run.stats().zones_allocated, 8);
  // An update the output thread has no free buffer for is skipped (the next one
  // carries the whole map again); each is counted.
  EXPECT_EQ(p.outputs_published + p.outputs_skipped, p.frames_mapped);
  EXPECT_GT(p.outputs_published, p.frames_mapped / 2);
  EXPECT_EQ(p.mapping_thread_allocations, 0);
  EXPECT_EQ(p.mapping_thread_frees, 0);
  EXPECT_EQ(p.output_thread_allocations, 0);
  EXPECT_EQ(p.output_thread_frees, 0);
  EXPECT_GT(p.extractions, run.stats().zones_discarded);  // discards and periodic ones
  EXPECT_GT(p.reintegration_cells, 0);  // out and back: the outbound obstacles came back
  EXPECT_EQ(p.extraction_thread_allocations, 0);
  EXPECT_EQ(p.extraction_thread_frees, 0);
  EXPECT_EQ(run.stats().heap_allocations_after_init, 0);
}

// Newest wins, paced by state: the source hands out its next frame only once the
// mapping thread has mapped the last one (kNone until then), so every frame is
// mapped however slow the machine, and only the mapping / extraction interplay
// is left to the threads.
class MapperPacedSource final : public hal::FrameSource {
 public:
  MapperPacedSource(hal::FrameSource& inner, const std::atomic<std::int64_t>& mapped)
      : inner_(inner), mapped_(mapped) {}
  const CameraModel& camera() const override { return inner_.camera(); }
  hal::CameraFrame make_frame() const override { return inner_.make_frame(); }
  hal::FrameRead next(hal::CameraFrame* frame, int wait_ms, std::string* why) override {
    if (mapped_.load(std::memory_order_acquire) < delivered_) {
      std::this_thread::yield();
      return hal::FrameRead::kNone;
    }
    const hal::FrameRead read = inner_.next(frame, wait_ms, why);
    if (read == hal::FrameRead::kFrame) ++delivered_;
    return read;
  }

 private:
  hal::FrameSource& inner_;
  const std::atomic<std::int64_t>& mapped_;
  std::int64_t delivered_ = 0;
};

class CountingHooks final : public runtime::MappingHooks {
 public:
  std::atomic<std::int64_t> mapped{0};
  void after_frame(std::size_t, const Eigen::Isometry3d&, const FrameReport&, double) override {
    mapped.fetch_add(1, std::memory_order_release);
  }
};

TEST(Pipeline, NewestWinsWritesReintegrationBoxesWhenTheyCome) {
  // Live mode: the mapping thread does not wait for the extraction thread's
  // re-integration boxes; it writes them at the next frames. Zones still come
  // back on the out-and-back flight and get their stored obstacles.
  // Every frame is mapped here (the other runtime flights' pixel step would cost
  // this one four times the rays of its 5 Hz predecessor): half the rays suffice.
  testing::MappedSequence flight("out-and-back", 1.5, 2 * testing::kRuntimePixelStep, 0);
  ASSERT_FALSE(HasFailure());
  const replay::ReplaySequence& sequence = flight.sequence;
  CountingHooks hooks;
  runtime::PipelineOptions options;
  options.lossless = false;  // newest wins
  replay::ReplayFrameSource replay_frames(sequence, 0.0);
  MapperPacedSource frames(replay_frames, hooks.mapped);
  runtime::Pipeline pipeline(frames, &sequence.poses(), nullptr, {}, *flight.mapper,
                             *flight.features, hooks, options);
  pipeline.run();
  const runtime::PipelineStats& p = pipeline.stats();
  std::printf(
      "[ newest wins ] %lld of %zu mapped, %lld extractions (%lld deferred), %lld boxes / %lld "
      "cells re-integrated, %lld for zones already gone\n",
      static_cast<long long>(p.frames_mapped), sequence.frame_count(),
      static_cast<long long>(p.extractions), static_cast<long long>(p.extractions_deferred),
      static_cast<long long>(p.reintegration_boxes), static_cast<long long>(p.reintegration_cells),
      static_cast<long long>(p.reintegration_zone_gone));
  EXPECT_EQ(p.frames_mapped, static_cast<std::int64_t>(sequence.frame_count()));
  EXPECT_GT(p.reintegration_cells, 0);
  EXPECT_EQ(flight.features->counters().cells_reintegrated, p.reintegration_cells);
  EXPECT_EQ(
      p.mapping_thread_allocations + p.extraction_thread_allocations + p.output_thread_allocations,
      0);
}

// A mapper slower than the source, made so deterministically: each mapped frame
// waits until the source has dealt with three more frames (state, not time).
class SlowMapper : public runtime::MappingHooks {
 public:
  const runtime::Pipeline* pipeline = nullptr;
  std::int64_t total = 0;
  void after_frame(std::size_t frame_index, const Eigen::Isometry3d&, const FrameReport&,
                   double) override {
    const std::int64_t want =
        std::min<std::int64_t>(static_cast<std::int64_t>(frame_index) + 4, total);
    while (pipeline->frames_offered() < want) std::this_thread::yield();
  }
};

TEST(Pipeline, OverloadDropsTheOldestAndCountsThem) {
  testing::MappedSequence flight("posts-through", 4.0, testing::kRuntimePixelStep, 60);
  ASSERT_FALSE(HasFailure());
  const replay::ReplaySequence& sequence = flight.sequence;
  SlowMapper hooks;
  hooks.total = static_cast<std::int64_t>(sequence.frame_count());
  runtime::PipelineOptions options;
  options.lossless = false;  // newest wins
  replay::ReplayFrameSource frames(sequence, options.source_rate_hz);
  runtime::Pipeline pipeline(frames, &sequence.poses(), nullptr, {}, *flight.mapper,
                             *flight.features, hooks, options);
  hooks.pipeline = &pipeline;
  pipeline.run();
  const runtime::PipelineStats& s = pipeline.stats();
  std::printf(
      "[ overload ] in %lld, mapped %lld, dropped (mapper behind) %lld, (pool full) %lld; "
      "end-to-end p99 %.1f ms\n",
      static_cast<long long>(s.frames_in), static_cast<long long>(s.frames_mapped),
      static_cast<long long>(s.dropped_mapper_behind), static_cast<long long>(s.dropped_pool_full),
      s.end_to_end.percentile(0.99));
  EXPECT_EQ(s.frames_in, static_cast<std::int64_t>(sequence.frame_count()));
  // Which reason drops depends on how much slower the mapper is (under a sanitizer
  // the pool fills); some frames are dropped and each is counted.
  EXPECT_GT(s.dropped_mapper_behind + s.dropped_pool_full, 0);
  EXPECT_EQ(s.frames_in, s.frames_mapped + s.frames_rejected + s.frames_skipped_no_pose +
                             s.dropped_mapper_behind + s.dropped_pool_full)
      << "every frame accounted for";
  EXPECT_GE(s.frames_mapped, 1);
  EXPECT_EQ(s.mapping_thread_allocations, 0);
}

// The INS as a live source: every pose of the sequence on the first poll.
class ListPoseSource final : public hal::PoseSource {
 public:
  explicit ListPoseSource(const std::vector<PoseSample>& samples) : samples_(samples) {}
  hal::PollResult poll(hal::PoseSink& sink, int) override {
    for (; next_ < samples_.size(); ++next_) sink.push(samples_[next_]);
    return hal::PollResult::kIdle;  // a live source never ends
  }
  hal::PoseSourceCounters counters() const override {
    hal::PoseSourceCounters c;
    c.poses_out = static_cast<std::int64_t>(next_);
    return c;
  }
  const char* name() const override { return "list"; }

 private:
  const std::vector<PoseSample>& samples_;
  std::size_t next_ = 0;
};

class RecordingSink final : public hal::ObstacleSink {
 public:
  const char* name() const override { return "recording"; }
  void publish(const hal::ObstacleUpdate& u, double) override {
    ++updates;
    last_count = u.count;
    std::size_t rects = 0;
    for (std::size_t i = 0; i < u.count; ++i) rects += u.rect_counts[i];
    last_rects = rects;
  }
  void publish_health(const hal::HealthSnapshot& h, double) override {
    ++healths;
    last_health = h;
  }
  std::int64_t updates = 0, healths = 0;
  std::size_t last_count = 0, last_rects = 0;
  hal::HealthSnapshot last_health;
};

TEST(Pipeline, LiveInsThreadAndSinksGetUpdatesAndHealthWithoutAllocating) {
  testing::TempDir dir;
  const std::string config_path = test_sequence(dir, "posts-through", 4.0, 40);
  MapConfig config;
  std::string error;
  replay::ReplaySequence sequence;
  ASSERT_TRUE(hal::load_map_config(config_path, &config, &error)) << error;
  ASSERT_TRUE(sequence.open(dir / "seq", "", config, &error)) << error;
  Mapper mapper(config, sequence.camera());
  FeatureMap features(config, true);
  mapper.zones().add_observer(&features);
  struct NoHooks : runtime::MappingHooks {  // extraction: the pipeline's own thread
    void after_frame(std::size_t, const Eigen::Isometry3d&, const FrameReport&, double) override {}
  } hooks;
  replay::ReplayFrameSource frames(sequence, 0.0);
  ListPoseSource ins(sequence.poses().samples());
  RecordingSink recording;
  // Real sinks too: MAVLink to a loopback socket of ours (a port nobody reads answers
  // with ICMP, and the next send fails now and then), CAN on a host without CAN
  // (every open fails: the failure path must not allocate either).
  const int receiver = socket(AF_INET, SOCK_DGRAM, 0);
  ASSERT_GE(receiver, 0);
  sockaddr_in bound{};
  bound.sin_family = AF_INET;
  bound.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t bound_size = sizeof(bound);
  ASSERT_EQ(bind(receiver, reinterpret_cast<sockaddr*>(&bound), sizeof(bound)), 0);
  ASSERT_EQ(getsockname(receiver, reinterpret_cast<sockaddr*>(&bound), &bound_size), 0);
  mavlink::MavlinkUdpConfig mavlink_config;
  mavlink_config.autopilot = "ardupilot";
  mavlink_config.port = ntohs(bound.sin_port);
  mavlink_config.rate_hz = 50;
  mavlink::MavlinkUdpSink mavlink(mavlink_config);
  ASSERT_TRUE(mavlink.open(&error)) << error;
  can::CanObstacleSink can_out("vcan0", {}, features.capacity());
  hal::ObstacleSink* sinks[] = {&recording, &mavlink, &can_out};
  runtime::PipelineOptions options;
  options.publish_every_frames = 1;
  options.health_period_s = 0.0;  // health with every update
  runtime::Pipeline pipeline(frames, nullptr, &ins, sinks, mapper, features, hooks, options);
  pipeline.run();
  const runtime::PipelineStats& s = pipeline.stats();
  EXPECT_EQ(s.frames_mapped, 40);
  EXPECT_EQ(recording.updates, s.outputs_published);
  EXPECT_EQ(recording.healths, s.outputs_published);
  EXPECT_EQ(s.health_published, s.outputs_published);
  EXPECT_GE(recording.last_count, 2u);  // the two posts
  EXPECT_GE(recording.last_rects, recording.last_count);
  EXPECT_EQ(recording.last_health.frames_mapped, s.frames_mapped);
  EXPECT_EQ(recording.last_health.poses_in, static_cast<std::int64_t>(sequence.poses().size()));
  EXPECT_GT(recording.last_health.end_to_end_ms_p50, 0.0);
  EXPECT_GT(recording.last_health.static_memory_bytes, 0);
  EXPECT_GT(recording.last_health.named, 5);
  // Every update reached the sink; it sent some (sectors, 3-D obstacles, heartbeat).
  EXPECT_EQ(mavlink.updates(), s.outputs_published);
  EXPECT_GT(mavlink.sent(), 0);
  EXPECT_GE(mavlink.heartbeats(), 1);
  EXPECT_EQ(mavlink.failed(), 0);
  close(receiver);
  EXPECT_EQ(s.mapping_thread_allocations, 0);
  EXPECT_EQ(s.output_thread_allocations, 0);
  EXPECT_EQ(s.output_thread_frees, 0);
  EXPECT_EQ(s.ins_thread_allocations, 0);
  EXPECT_GT(s.extractions, 0);
  EXPECT_EQ(s.extraction_thread_allocations, 0);
  EXPECT_EQ(s.extraction_thread_frees, 0);
}

// Another vehicle's maps come on a thread of their own while the flight is
// mapped (a receiver's), each naming a mast 200 m ahead, the later ones a second
// mast too: the extraction thread takes each whole map before an update, without
// allocating, and the final map holds the posts seen and the masts shared, prior.
TEST(Pipeline, SharedMapsFromAnotherThreadReachTheUpdatesWithoutAllocating) {
  testing::Flight flight(24);
  SharedMapInbox inbox(4);
  std::atomic<bool> done{false};
  std::atomic<int> posted{0};
  std::thread receiver([&] {
    while (!done.load()) {
      SharedMapUpdate* u = inbox.take_free();
      if (u == nullptr) {
        std::this_thread::yield();  // every slot waits: the next map wins
        continue;
      }
      u->source = 1;
      u->min[0] = Eigen::Vector3d(200, 0, 0);
      u->max[0] = Eigen::Vector3d(201, 1, 30);
      u->min[1] = Eigen::Vector3d(200, 20, 0);
      u->max[1] = Eigen::Vector3d(201, 21, 30);
      u->count = posted.fetch_add(1) < 3 ? 1 : 2;
      inbox.post(u);
    }
  });
  replay::ReplayFrameSource frames(flight.sequence, 0.0);
  RecordingSink recording;
  hal::ObstacleSink* sinks[] = {&recording};
  const runtime::PipelineStats s = flight.run(frames, nullptr, sinks, true, &inbox);
  done.store(true);
  receiver.join();
  EXPECT_EQ(s.extraction_thread_allocations, 0);
  EXPECT_EQ(s.extraction_thread_frees, 0);
  const FeatureCounters& c = flight.features->counters();
  EXPECT_GT(c.shared_updates, 0);
  // Each mast's pieces (cut at zone faces) stored once, then kept map after map.
  std::int64_t shared_pieces = 0;
  for (const Feature& f : *flight.features) shared_pieces += f.in_use && f.shared_source == 1;
  EXPECT_EQ(c.shared_added, shared_pieces);
  EXPECT_GT(c.shared_kept, 0);
  EXPECT_EQ(c.shared_removed, 0);
  int masts = 0, posts = 0;
  for (const ObstacleBox& b : flight.boxes()) {
    if (b.kind != FeatureKind::kObstacle) continue;
    if (b.min.x() >= 199.0) {
      ++masts;
      EXPECT_TRUE(b.prior);
    } else {
      ++posts;
    }
  }
  EXPECT_EQ(masts, 2);
  EXPECT_GE(posts, 2);
}

// The design card's budget: flight 2 (the paper's camera, 640x480) in all, through
// the onboard runtime, at most 64 MiB, with the outdoor default as shipped and
// the paper's flight-2 config.
TEST(MemoryBudget, FlightTwoInAllHoldsIn64MiBWithTheShippedConfigs) {
  testing::TempDir dir;
  ASSERT_FALSE(test_sequence(dir, "treeline-dense", 10.0, 3).empty());
  for (const char* name : {"outdoor-0.5m", "paper-flight2"}) {
    tools::ReplayOptions options = testing::quiet_replay(
        dir / "seq", testing::source_path(std::string("config/") + name + ".yaml"));
    std::string error;
    tools::ReplayRun run;
    ASSERT_TRUE(run.open(options, &error)) << error;
    run.run_pipelined(runtime::PipelineOptions{});
    const std::uint64_t bytes = run.stats().static_memory_bytes;
    std::printf("%s: %llu bytes reserved in all (%.2f MiB)\n", name,
                static_cast<unsigned long long>(bytes), static_cast<double>(bytes) / 1048576.0);
    EXPECT_GT(bytes, 60u << 20) << name << ": the whole of it counted";
    EXPECT_LE(bytes, 64u << 20) << name;
  }
}

}  // namespace
}  // namespace zonemap
