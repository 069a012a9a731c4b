// A flight as Foxglove plays it back: an MCAP file written by a thread of its own.
// Producers (the replay loop, the pipeline's mapping and output threads) copy what
// they have into slots reserved at start-up and push them on fixed-capacity
// lock-free queues; when no slot is free the item is dropped and counted. They
// never wait and never allocate. The recorder thread turns the slots into
// Foxglove JSON messages (hal/record/foxglove_json.hpp) and writes them.
//
// Channels (docs/FORMATS.md §8), message times are sensor times:
//   /zonemap/boxes       foxglove.SceneUpdate    one entity per merged box, deletions
//   /zonemap/sectors     foxglove.SceneUpdate    the 72 sectors the flight controller gets
//   /zonemap/occupied    foxglove.PointCloud     the live zones' occupied cells
//   /zonemap/pose        foxglove.FrameTransform world -> body, body -> camera
//   /zonemap/trajectory  foxglove.SceneUpdate    the path flown so far
//   /zonemap/depth       foxglove.RawImage       decimated depth frames (16UC1)
//   /zonemap/health      zonemap.Health          counters and latencies
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "hal/os/doorbell.hpp"
#include "hal/os/task.hpp"
#include "hal/output/obstacle_sink.hpp"
#include "hal/record/mcap_writer.hpp"
#include "zonemap/common/camera.hpp"
#include "zonemap/containers/spsc_queue.hpp"
#include "zonemap/outputs/obstacle_distance.hpp"

namespace zonemap {
class Mapper;
}

namespace zonemap::record {

struct RecorderConfig {
  std::string path;                       // OUT/run.mcap
  std::size_t max_boxes = 4096;           // per update (features.capacity)
  std::size_t max_rects = 16384;          // footprint rectangles per update
  std::size_t max_occupied = 262144;      // occupied cells per cloud
  int depth_width = 0, depth_height = 0;  // the camera's image
  int depth_decimation = 4;               // every n-th row and column
  bool world_z_up = true;
  Eigen::Isometry3d body_T_camera = Eigen::Isometry3d::Identity();
  SectorConfig sectors;  // as the MAVLink sink draws them
  McapOptions mcap;
};

// The settings that follow from the camera: image size, depth decimation (every
// 2nd pixel from 320 wide), the world's up axis and the mount.
RecorderConfig recorder_config_for(const CameraModel& camera, std::size_t max_boxes,
                                   std::size_t max_rects);

// What the recorder did, for stats.json "recording".
struct RecorderCounts {
  std::int64_t messages = 0, bytes = 0, chunks = 0;
  std::int64_t bytes_uncompressed = 0;  // chunk records before compression
  std::int64_t boxes_updates = 0, sectors = 0, occupied_clouds = 0, poses = 0, depth_images = 0;
  std::int64_t health = 0;
  std::int64_t dropped = 0;             // queue full: an item the recorder never saw
  std::int64_t occupied_truncated = 0;  // clouds cut at max_occupied
};

class FlightRecorder final : public hal::ObstacleSink {
 public:
  FlightRecorder();
  ~FlightRecorder() override;
  FlightRecorder(const FlightRecorder&) = delete;
  FlightRecorder& operator=(const FlightRecorder&) = delete;

  // Reserves every slot, opens the file, starts the thread. False with a message.
  bool open(const RecorderConfig& config, std::string* error);
  // Drains every queue, writes the summary and closes the file; idempotent.
  bool close(std::string* error);
  bool is_open() const { return thread_.started(); }

  // Producer side: never blocks, never allocates; false (and counted) when full.
  bool record_pose(double time_s, const Eigen::Isometry3d& world_T_body);
  bool record_depth(double time_s, const std::uint16_t* depth);
  bool record_occupied(double time_s, Mapper& mapper);
  bool record_boxes(const hal::ObstacleUpdate& update);
  bool record_health(const hal::HealthSnapshot& health);
  // The last update of a run (every feature): waits for a slot, for it must not be lost.
  void record_final_boxes(const hal::ObstacleUpdate& update);

  // As a sink of the pipeline or the daemon (on their output thread).
  const char* name() const override { return "mcap"; }
  void publish(const hal::ObstacleUpdate& update, double now_s) override;
  void publish_health(const hal::HealthSnapshot& health, double now_s) override;
  void report(hal::HealthSnapshot* health) const override;
  // Poses from the sink's updates too (the daemon has no other pose feed).
  void take_poses_from_updates(bool on) { poses_from_updates_ = on; }

  RecorderCounts counts() const;
  std::size_t reserved_bytes() const { return reserved_bytes_; }

 private:
  struct Impl;
  void run();
  std::unique_ptr<Impl> impl_;
  os::Task thread_;
  std::atomic<bool> stopping_{false};
  std::atomic<std::int64_t> dropped_{0};
  os::Doorbell work_, room_;
  bool poses_from_updates_ = false;
  std::size_t reserved_bytes_ = 0;
};

}  // namespace zonemap::record
