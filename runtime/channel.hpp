// How the pipeline's threads hand each other work: a fixed-capacity lock-free
// queue from one thread to another, with both threads' doorbells, and the waits
// built on them. No lock, no spinning, no allocation.
#pragma once

#include <cstddef>
#include <cstdint>

#include "hal/os/doorbell.hpp"
#include "zonemap/containers/spsc_queue.hpp"

namespace zonemap::runtime {

// End of stream, sent through the queues of slot indices.
constexpr std::uint32_t kEndOfStream = UINT32_MAX;

// A push rings the consumer's bell (there is work), a pop the producer's (there
// is room).
template <typename T, std::size_t N>
struct Channel {
  SpscQueue<T, N> queue;
  os::Doorbell* producer = nullptr;
  os::Doorbell* consumer = nullptr;
  void connect(os::Doorbell* from, os::Doorbell* to) {
    producer = from;
    consumer = to;
  }
  bool push(const T& item) {
    if (!queue.push(item)) return false;
    consumer->ring();
    return true;
  }
  bool pop(T* item) {
    if (!queue.pop(item)) return false;
    producer->ring();
    return true;
  }
  std::size_t size_approx() const { return queue.size_approx(); }
};

// The calling thread sleeps on its own bell until `done()` (which may take what
// it waited for): the ticket is taken before the last look, so a ring between
// that look and the sleep is not lost.
template <typename Done>
void wait_on(os::Doorbell& own, Done done) {
  while (!done()) {
    const std::uint32_t ticket = own.ticket();
    if (done()) return;
    own.wait(ticket);
  }
}
template <typename C, typename T>
void pop_waiting(C& channel, T* item, os::Doorbell& own) {
  wait_on(own, [&] { return channel.pop(item); });
}
template <typename C, typename T>
void push_waiting(C& channel, const T& item, os::Doorbell& own) {
  wait_on(own, [&] { return channel.push(item); });
}

}  // namespace zonemap::runtime
