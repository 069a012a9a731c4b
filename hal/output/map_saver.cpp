#include "hal/output/map_saver.hpp"

#include <algorithm>
#include <cstdio>

#include "hal/output/run_outputs.hpp"

namespace zonemap::hal {

MapSaver::MapSaver(std::string path, double every_s, std::size_t capacity)
    : path_(std::move(path)), every_s_(every_s), boxes_(capacity) {}

MapSaver::~MapSaver() {
  stop();
}

void MapSaver::start() {
  if (!thread_.started()) thread_.start({"zonemap-saver"}, [this] { run(); });
}

void MapSaver::stop() {
  if (!thread_.started()) return;
  stopping_.store(true, std::memory_order_seq_cst);
  work_.ring();
  thread_.join();
}

void MapSaver::publish(const ObstacleUpdate& update, double now_s) {
  if (now_s < next_s_) return;
  next_s_ = now_s + every_s_;
  if (full_.load(std::memory_order_acquire)) {
    busy_.fetch_add(1, std::memory_order_relaxed);  // the last one is still being written
    return;
  }
  count_ = std::min(update.count, boxes_.size());
  std::copy_n(update.boxes, count_, boxes_.begin());
  full_.store(true, std::memory_order_release);
  work_.ring();
}

void MapSaver::run() {
  for (;;) {
    const std::uint32_t ticket = work_.ticket();
    if (full_.load(std::memory_order_acquire)) {
      std::string error;
      if (write_boxes_csv(path_, boxes_.data(), count_, &error)) {
        saves_.fetch_add(1, std::memory_order_relaxed);
      } else {
        failed_.fetch_add(1, std::memory_order_relaxed);
        std::fprintf(stderr, "zonemap: saving the map: %s\n", error.c_str());
      }
      full_.store(false, std::memory_order_release);
      continue;
    }
    if (stopping_.load(std::memory_order_seq_cst)) return;
    work_.wait(ticket);
  }
}

void MapSaver::report(HealthSnapshot* h) const {
  h->add("map_saves", saves_.load(std::memory_order_relaxed));
  h->add("map_saves_skipped_busy", busy_.load(std::memory_order_relaxed));
  h->add("map_saves_failed", failed_.load(std::memory_order_relaxed));
}

}  // namespace zonemap::hal
