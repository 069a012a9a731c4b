// Maps shared by other vehicles, from the thread that receives them to the one
// that owns the feature map: a pool of update slots, each one sender's whole map
// (its obstacles in this map's world metres), handed over by index through two
// fixed-capacity SPSC queues. Reserved at construction; neither side allocates,
// locks or waits: a receiver that finds no free slot drops the map (counted; the
// sender's next one replaces it anyway).
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>

#include <Eigen/Core>

#include "zonemap/containers/spsc_queue.hpp"

namespace zonemap {

struct SharedMapUpdate {
  std::uint8_t source = 0;         // 1..: which sender (the receiver's numbering)
  std::size_t count = 0;           // boxes used
  Eigen::Vector3d* min = nullptr;  // [capacity] world metres, this map's frame
  Eigen::Vector3d* max = nullptr;
};

class SharedMapInbox {
 public:
  static constexpr std::size_t kSlots = 4;

  explicit SharedMapInbox(std::size_t max_boxes_per_map)
      : capacity_(max_boxes_per_map),
        min_(new Eigen::Vector3d[kSlots * max_boxes_per_map]()),
        max_(new Eigen::Vector3d[kSlots * max_boxes_per_map]()) {
    for (std::uint32_t s = 0; s < kSlots; ++s) {
      slots_[s].min = min_.get() + s * capacity_;
      slots_[s].max = max_.get() + s * capacity_;
      free_.push(s);
    }
  }
  SharedMapInbox(const SharedMapInbox&) = delete;
  SharedMapInbox& operator=(const SharedMapInbox&) = delete;

  std::size_t max_boxes() const { return capacity_; }
  std::size_t reserved_bytes() const { return 2 * kSlots * capacity_ * sizeof(Eigen::Vector3d); }

  // Receiver: a slot to fill (count 0), or null when every slot waits (the map
  // is then dropped and counted); hand it over with post().
  SharedMapUpdate* take_free() {
    std::uint32_t s = 0;
    if (!free_.pop(&s)) {
      dropped_.fetch_add(1, std::memory_order_relaxed);
      return nullptr;
    }
    slots_[s].count = 0;
    return &slots_[s];
  }
  void post(SharedMapUpdate* update) { filled_.push(index_of(update)); }

  // Owner of the feature map: the oldest waiting update, or null; give it back
  // with release() once applied.
  SharedMapUpdate* next() {
    std::uint32_t s = 0;
    return filled_.pop(&s) ? &slots_[s] : nullptr;
  }
  void release(SharedMapUpdate* update) { free_.push(index_of(update)); }

  // Maps the receiver had no slot for (any thread).
  std::int64_t dropped() const { return dropped_.load(std::memory_order_relaxed); }

 private:
  std::uint32_t index_of(const SharedMapUpdate* u) const {
    return static_cast<std::uint32_t>(u - slots_);
  }

  std::size_t capacity_;
  std::unique_ptr<Eigen::Vector3d[]> min_, max_;
  SharedMapUpdate slots_[kSlots];
  // Both hold every slot at most once: pushes never fail.
  SpscQueue<std::uint32_t, kSlots> free_;    // owner -> receiver
  SpscQueue<std::uint32_t, kSlots> filled_;  // receiver -> owner
  std::atomic<std::int64_t> dropped_{0};
};

}  // namespace zonemap
