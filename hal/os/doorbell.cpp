#include "hal/os/doorbell.hpp"

#include <linux/futex.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <ctime>

namespace zonemap::os {
namespace {

static_assert(sizeof(std::atomic<std::uint32_t>) == sizeof(std::uint32_t) &&
                  std::atomic<std::uint32_t>::is_always_lock_free,
              "the futex word is the atomic's own storage");

std::uint32_t* word(std::atomic<std::uint32_t>* a) {
  return reinterpret_cast<std::uint32_t*>(a);
}

// Sleeps while *address == expected (checked atomically by the kernel), at most
// `timeout` (relative, CLOCK_MONOTONIC) when not null. Spurious returns (a signal,
// the value already changed) are fine: callers look again.
void futex_wait(std::atomic<std::uint32_t>* address, std::uint32_t expected,
                const timespec* timeout) {
  syscall(SYS_futex, word(address), FUTEX_WAIT_PRIVATE, expected, timeout, nullptr, 0);
}

void futex_wake_all(std::atomic<std::uint32_t>* address) {
  syscall(SYS_futex, word(address), FUTEX_WAKE_PRIVATE, INT32_MAX, nullptr, nullptr, 0);
}

}  // namespace

// Sequentially consistent on both sides: either the ringing thread sees the
// sleeper count, or the sleeper sees the new ring count (and the kernel's own
// check covers a ring between that look and the sleep).
void Doorbell::ring() {
  rings_.fetch_add(1, std::memory_order_seq_cst);
  if (sleepers_.load(std::memory_order_seq_cst) != 0) futex_wake_all(&rings_);
}

void Doorbell::wait(std::uint32_t ticket) {
  sleepers_.fetch_add(1, std::memory_order_seq_cst);
  while (rings_.load(std::memory_order_seq_cst) == ticket) futex_wait(&rings_, ticket, nullptr);
  sleepers_.fetch_sub(1, std::memory_order_seq_cst);
}

bool Doorbell::wait_until(std::uint32_t ticket, std::chrono::steady_clock::time_point deadline) {
  sleepers_.fetch_add(1, std::memory_order_seq_cst);
  bool rung = true;
  while (rings_.load(std::memory_order_seq_cst) == ticket) {
    const auto left = deadline - std::chrono::steady_clock::now();
    if (left <= std::chrono::steady_clock::duration::zero()) {
      rung = false;
      break;
    }
    const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(left).count();
    const timespec timeout{static_cast<time_t>(ns / 1000000000),
                           static_cast<long>(ns % 1000000000)};
    futex_wait(&rings_, ticket, &timeout);
  }
  sleepers_.fetch_sub(1, std::memory_order_seq_cst);
  return rung;
}

}  // namespace zonemap::os
