// What the pipeline's stages share, and only that: the channels between them
// (each ringing the bell of the stage at its other end), the buffers that travel
// through the channels by index, and the counters a stage publishes for another
// stage's health message. A stage's own state is in its own type
// (*_stage.hpp); the pipeline (pipeline.cpp) builds the links and the stages at
// start-up and starts the stages' threads.
//
//   acquisition --filled--> mapping --jobs--> extraction --out_filled--> output
//        ^                  |  ^   <--reintegration--  |                    |
//        +---free_slots-----+  +------snapshot_free----+                    |
//                              ^------------------out_free------------------+
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "hal/os/clock.hpp"
#include "hal/os/doorbell.hpp"
#include "runtime/channel.hpp"
#include "runtime/pipeline.hpp"
#include "zonemap/pose/pose_buffer.hpp"
#include "zonemap/zones/zone_snapshot.hpp"

namespace zonemap::runtime {

using os::Clock;

// A frame slot's facts the mapping stage needs besides the frame.
struct FrameSlotInfo {
  std::size_t frame_index = 0;
  Clock::time_point acquired;
};

// An update on its way from the mapping stage (which takes the buffer) through
// the extraction stage (which merges the boxes into it) to the output stage.
struct OutputBuffer {
  std::vector<ObstacleBox> boxes;
  std::size_t count = 0;
  std::vector<FootprintRect> rects;
  std::vector<std::uint32_t> rect_offsets, rect_counts;
  Clock::time_point acquired;
  double time_s = 0.0;
  Eigen::Isometry3d world_T_body = Eigen::Isometry3d::Identity();
  SectorMask sectors_observed{};  // what the live grid has seen around the vehicle
  hal::HealthSnapshot health;     // the mapping side's counters at this update
  hal::ObstacleUpdate update(bool world_z_up) const;  // what the sinks get of it
};

// Mapping -> extraction, in the order the mapping stage meant them: the
// extraction stage replays the single-threaded sequence of feature-map calls.
struct ExtractionJob {
  enum class Kind : std::uint8_t { kExtract, kAllocated, kPublish, kEnd };
  Kind kind = Kind::kEnd;
  std::uint32_t slot = 0;        // kExtract: snapshot slot; kPublish: output buffer
  ZoneKey zone;                  // kAllocated
  std::uint64_t allocation = 0;  // kAllocated: its number
  double time_s = 0.0;           // the feature map's context (stamps, relevance)
  double camera_rotation[9] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};  // world_T_camera
  double camera_position[3] = {0.0, 0.0, 0.0};  // (copied exactly: stamps equal one thread's)
  Eigen::Isometry3d camera_pose() const;
};

// Extraction -> mapping: the boxes to re-integrate into an allocated zone, then a
// marker saying that allocation is answered.
struct ReintegrationBox {
  ZoneKey zone;
  CellIndex min, max;
  std::uint64_t allocation = 0;
  bool answered = false;  // the marker: no box, every box of `allocation` sent
};

// The acquisition stage's counts as the mapping stage's health message reads
// them; the INS stage's likewise (relaxed: each is a count on its own).
struct SharedFrameCounters {
  std::atomic<std::int64_t> frames_in{0}, rejected{0}, pool_full{0};
  std::atomic<std::int64_t> offered{0};  // handed on or dropped (release: frames_offered())
};
struct SharedInsCounters {
  std::atomic<std::int64_t> messages{0}, malformed{0}, solutions{0}, poses_out{0}, link_errors{0},
      rejected{0}, reanchors{0};
  void store(const hal::PoseSourceCounters& c);
};

struct Links {
  static constexpr int kFrameSlots = Pipeline::kFrameSlots;
  static constexpr int kOutputSlots = Pipeline::kOutputSlots;
  static constexpr int kSnapshotSlots = Pipeline::kSnapshotSlots;

  // Every buffer reserved and every channel connected and filled with its free
  // slots: frames as `source` makes them, outputs for `boxes` boxes and
  // `footprint_rects` rectangles, snapshots of `config`'s zones.
  Links(hal::FrameSource& source, const MapConfig& config, std::size_t boxes,
        std::size_t footprint_rects);
  std::size_t reserved_bytes() const;

  const Clock::time_point started = Clock::now();
  std::size_t static_bytes = 0;  // everything reserved at start-up, for the health message

  // Each stage's bell: rung when there may be work (or room) for it.
  os::Doorbell acquisition_bell, mapping_bell, extraction_bell, output_bell;

  // Frames: acquisition -> mapping, and their slots back.
  std::array<hal::CameraFrame, kFrameSlots> frames;
  std::array<FrameSlotInfo, kFrameSlots> frame_info{};
  Channel<std::uint32_t, 16> filled;
  Channel<std::uint32_t, 16> free_slots;
  PoseBuffer<512> poses;  // acquisition (replay) or INS -> mapping

  // Zone snapshots and the extraction protocol: mapping <-> extraction.
  std::vector<std::unique_ptr<ZoneSnapshot>> snapshots;
  Channel<std::uint32_t, 16> snapshot_free;       // extraction -> mapping
  Channel<ExtractionJob, 64> jobs;                // mapping -> extraction
  Channel<ReintegrationBox, 1024> reintegration;  // extraction -> mapping

  // Updates: extraction -> output, and their buffers back to mapping.
  std::array<OutputBuffer, kOutputSlots> outputs;
  Channel<std::uint32_t, 4> out_filled;
  Channel<std::uint32_t, 4> out_free;

  std::atomic<bool> stop_requested{false};  // stop(): the acquisition ends
  std::atomic<bool> mapping_done{false};    // the INS stage ends
  SharedFrameCounters acquired;
  SharedInsCounters ins;
};

}  // namespace zonemap::runtime
