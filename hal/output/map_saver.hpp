// The feature map kept on disk while the vehicle flies, so that a power cut loses
// at most the last `every_s` seconds of it and the next flight starts from it (its
// prior). A sink of the output thread: every `every_s` the newest update's boxes
// are copied into a buffer reserved at start-up, only when the writer is idle
// (else skipped and counted: the next one goes), and a thread of its own writes
// them whole or not at all (write_boxes_csv: temporary, fsync, rename). The
// output thread never waits, never allocates, never writes a file.
#pragma once

#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include "hal/os/doorbell.hpp"
#include "hal/os/task.hpp"
#include "hal/output/obstacle_sink.hpp"

namespace zonemap::hal {

class MapSaver final : public ObstacleSink {
 public:
  MapSaver(std::string path, double every_s, std::size_t capacity);
  ~MapSaver() override;
  MapSaver(const MapSaver&) = delete;
  MapSaver& operator=(const MapSaver&) = delete;

  void start();  // the writer thread
  // Waits for a write in progress, then stops the thread (before the final save).
  void stop();
  const char* name() const override { return "map file (boxes.csv, the next flight's prior)"; }
  void publish(const ObstacleUpdate& update, double now_s) override;
  void report(HealthSnapshot* health) const override;
  std::int64_t saves() const { return saves_.load(std::memory_order_relaxed); }
  std::size_t reserved_bytes() const { return boxes_.size() * sizeof(ObstacleBox); }

 private:
  void run();

  std::string path_;
  double every_s_;
  std::vector<ObstacleBox> boxes_;  // reserved at construction
  std::size_t count_ = 0;
  double next_s_ = -1e300;
  std::atomic<bool> full_{false};  // boxes_ holds a copy the writer has not written yet
  std::atomic<bool> stopping_{false};
  os::Doorbell work_;
  os::Task thread_;
  std::atomic<std::int64_t> saves_{0}, busy_{0}, failed_{0};
};

}  // namespace zonemap::hal
