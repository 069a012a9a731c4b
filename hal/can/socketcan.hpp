// SocketCAN (Linux): a raw CAN socket (CAN_RAW) on one interface, non-blocking,
// with the kernel's receive timestamps and filters for the IDs a profile uses.
// No allocation after open; each call does one system call at most.
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "hal/can/can_frame.hpp"

namespace zonemap::can {

enum class CanIo {
  kOk,
  kWouldBlock,  // nothing to read / transmit queue full (ENOBUFS, EAGAIN)
  kDown,        // interface down or gone: close and reopen later
};

class SocketCan {
 public:
  SocketCan() = default;
  ~SocketCan();
  SocketCan(const SocketCan&) = delete;
  SocketCan& operator=(const SocketCan&) = delete;

  // ids empty: receive everything. Returns false with the reason in `error`
  // (e.g. "socket(PF_CAN): Address family not supported" on a kernel without CAN).
  // Allocation-free, so a link can be reopened from a real-time thread.
  bool open(const char* interface, std::span<const std::uint32_t> ids, bool extended_ids,
            char* error, std::size_t error_size);
  void close();
  bool is_open() const { return fd_ >= 0; }

  // Receive time: the kernel's timestamp (CLOCK_REALTIME, as candump logs it).
  CanIo receive(CanFrame* frame);
  CanIo send(const CanFrame& frame);
  // Waits up to timeout_ms for a frame to read (for HAL threads that may block;
  // the mapping path never calls it). True when readable.
  bool wait_readable(int timeout_ms);
  int last_errno() const { return last_errno_; }

 private:
  int fd_ = -1;
  int last_errno_ = 0;
};

// Reopens a SocketCan whose link went down, with exponential backoff, so a bus
// fault never stops mapping. Counts everything.
struct CanLinkCounters {
  std::int64_t rx_frames = 0, tx_frames = 0;
  std::int64_t tx_queue_full = 0;  // frames not sent: the kernel's queue was full
  std::int64_t tx_link_down = 0;   // frames not sent: link down
  std::int64_t link_down_events = 0, reopen_attempts = 0, reopens = 0;
};

// What an output needs of a CAN link (so faults can be injected in tests).
class CanTransport {
 public:
  virtual ~CanTransport() = default;
  virtual CanIo send(const CanFrame& frame, double now_s) = 0;
};

class CanLink final : public CanTransport {
 public:
  // Backoff doubles from min to max while the interface stays unavailable.
  CanLink(const std::string& interface, std::span<const std::uint32_t> ids, bool extended_ids,
          double backoff_min_s = 0.1, double backoff_max_s = 5.0);
  // (Re)opens when due at `now_s`; true when the link is usable.
  bool ensure_open(double now_s);
  CanIo receive(CanFrame* frame, double now_s);
  CanIo send(const CanFrame& frame, double now_s) override;
  bool wait_readable(int timeout_ms) {
    return socket_.is_open() && socket_.wait_readable(timeout_ms);
  }
  const CanLinkCounters& counters() const { return counters_; }
  const char* last_error() const { return error_; }
  bool is_open() const { return socket_.is_open(); }

 private:
  void went_down(double now_s);

  char interface_[32] = {};
  std::uint32_t ids_[16] = {};
  std::size_t id_count_ = 0;
  bool extended_;
  double backoff_min_s_, backoff_max_s_, backoff_s_;
  double next_attempt_s_ = 0.0;
  SocketCan socket_;
  char error_[192] = {};
  CanLinkCounters counters_;
};

}  // namespace zonemap::can
