// Fixed-capacity lock-free single-producer / single-consumer queue (a ring of
// trivially copyable items, e.g. frame-pool indices). One thread pushes, one pops;
// neither blocks, allocates or locks. Capacity is a power of two fixed at compile
// time. The producer publishes an item with a release store of `tail_`; the
// consumer sees it with an acquire load, and hands the slot back the same way
// through `head_`.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <type_traits>

namespace zonemap {

template <typename T, std::size_t Capacity>
class SpscQueue {
  static_assert(Capacity >= 2 && (Capacity & (Capacity - 1)) == 0, "capacity: a power of two");
  static_assert(std::is_trivially_copyable_v<T>, "items are copied by value");

 public:
  // Producer side. False when full (the caller decides: drop, retry, count).
  bool push(const T& item) {
    const std::uint64_t tail = tail_.load(std::memory_order_relaxed);
    if (tail - head_cache_ == Capacity) {
      head_cache_ = head_.load(std::memory_order_acquire);
      if (tail - head_cache_ == Capacity) return false;
    }
    items_[tail & (Capacity - 1)] = item;
    tail_.store(tail + 1, std::memory_order_release);
    return true;
  }

  // Consumer side. False when empty.
  bool pop(T* item) {
    const std::uint64_t head = head_.load(std::memory_order_relaxed);
    if (head == tail_cache_) {
      tail_cache_ = tail_.load(std::memory_order_acquire);
      if (head == tail_cache_) return false;
    }
    *item = items_[head & (Capacity - 1)];
    head_.store(head + 1, std::memory_order_release);
    return true;
  }

  // Either side: a snapshot, exact only when the other side is idle.
  std::size_t size_approx() const {
    return static_cast<std::size_t>(tail_.load(std::memory_order_acquire) -
                                    head_.load(std::memory_order_acquire));
  }
  static constexpr std::size_t capacity() { return Capacity; }

 private:
  // Producer and consumer indices on their own cache lines (no false sharing);
  // each side caches the other's index to touch the shared line only when needed.
  alignas(64) std::atomic<std::uint64_t> tail_{0};
  std::uint64_t head_cache_ = 0;  // producer's view of head_
  alignas(64) std::atomic<std::uint64_t> head_{0};
  std::uint64_t tail_cache_ = 0;  // consumer's view of tail_
  alignas(64) std::array<T, Capacity> items_{};
};

}  // namespace zonemap
