#include "hal/can/socketcan.hpp"

#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>

#include "hal/os/clock.hpp"

namespace zonemap::can {
namespace {

void describe(char* out, std::size_t size, const char* what, int err, const char* interface) {
  std::snprintf(out, size, "%s: %s (%s)", what, std::strerror(err), interface);
}

double seconds(const timespec& ts) {
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

}  // namespace

SocketCan::~SocketCan() {
  close();
}

void SocketCan::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

bool SocketCan::open(const char* interface, std::span<const std::uint32_t> ids, bool extended_ids,
                     char* error, std::size_t error_size) {
  close();
  const std::size_t name_length = std::strlen(interface);
  if (name_length == 0 || name_length >= IFNAMSIZ) {
    std::snprintf(error, error_size, "CAN interface name '%s' is empty or too long", interface);
    return false;
  }
  const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) {
    last_errno_ = errno;
    describe(error, error_size, "socket(PF_CAN)", last_errno_, interface);
    return false;
  }
  const auto fail = [&](const char* what) {
    last_errno_ = errno;
    describe(error, error_size, what, last_errno_, interface);
    ::close(fd);
    return false;
  };
  ifreq request{};
  std::memcpy(request.ifr_name, interface, name_length + 1);
  if (::ioctl(fd, SIOCGIFINDEX, &request) < 0) return fail("SIOCGIFINDEX");
  if (!ids.empty()) {
    can_filter filters[16];
    const std::size_t n = std::min<std::size_t>(ids.size(), 16);
    for (std::size_t i = 0; i < n; ++i) {
      filters[i].can_id = extended_ids ? (ids[i] | CAN_EFF_FLAG) : ids[i];
      filters[i].can_mask =
          (extended_ids ? CAN_EFF_MASK : CAN_SFF_MASK) | CAN_EFF_FLAG | CAN_RTR_FLAG;
    }
    if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, filters,
                     static_cast<socklen_t>(n * sizeof(can_filter))) < 0) {
      return fail("CAN_RAW_FILTER");
    }
  }
  const int on = 1;
  if (::setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on) < 0)
    return fail("SO_TIMESTAMPNS");
  sockaddr_can address{};
  address.can_family = AF_CAN;
  address.can_ifindex = request.ifr_ifindex;
  if (::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) < 0) return fail("bind");
  fd_ = fd;
  return true;
}

CanIo SocketCan::receive(CanFrame* out) {
  if (fd_ < 0) return CanIo::kDown;
  can_frame raw{};
  iovec io{&raw, sizeof raw};
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timespec))];
  msghdr message{};
  message.msg_iov = &io;
  message.msg_iovlen = 1;
  message.msg_control = control;
  message.msg_controllen = sizeof control;
  const ssize_t n = ::recvmsg(fd_, &message, MSG_DONTWAIT);
  if (n < 0) {
    last_errno_ = errno;
    if (last_errno_ == EAGAIN || last_errno_ == EWOULDBLOCK || last_errno_ == EINTR) {
      return CanIo::kWouldBlock;
    }
    return CanIo::kDown;
  }
  CanFrame f;
  f.extended = (raw.can_id & CAN_EFF_FLAG) != 0;
  f.remote = (raw.can_id & CAN_RTR_FLAG) != 0;
  f.id = raw.can_id & (f.extended ? CAN_EFF_MASK : CAN_SFF_MASK);
  f.fd = static_cast<std::size_t>(n) != CAN_MTU;  // an FD frame does not fit: mark it refused
  f.dlc = std::min<std::uint8_t>(raw.len, 8);
  std::memcpy(f.data.data(), raw.data, 8);
  f.time_s = os::realtime_now_s();
  for (cmsghdr* c = CMSG_FIRSTHDR(&message); c != nullptr; c = CMSG_NXTHDR(&message, c)) {
    if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_TIMESTAMPNS) {
      timespec ts{};
      std::memcpy(&ts, CMSG_DATA(c), sizeof ts);
      f.time_s = seconds(ts);
    }
  }
  *out = f;
  return CanIo::kOk;
}

CanIo SocketCan::send(const CanFrame& f) {
  if (fd_ < 0) return CanIo::kDown;
  can_frame raw{};
  raw.can_id = f.id | (f.extended ? CAN_EFF_FLAG : 0u) | (f.remote ? CAN_RTR_FLAG : 0u);
  raw.len = std::min<std::uint8_t>(f.dlc, 8);
  std::memcpy(raw.data, f.data.data(), 8);
  const ssize_t n = ::send(fd_, &raw, sizeof raw, MSG_DONTWAIT);
  if (n == static_cast<ssize_t>(sizeof raw)) return CanIo::kOk;
  last_errno_ = n < 0 ? errno : EIO;
  if (last_errno_ == ENOBUFS || last_errno_ == EAGAIN || last_errno_ == EWOULDBLOCK ||
      last_errno_ == EINTR) {
    return CanIo::kWouldBlock;
  }
  return CanIo::kDown;
}

bool SocketCan::wait_readable(int timeout_ms) {
  if (fd_ < 0) return false;
  pollfd p{fd_, POLLIN, 0};
  return ::poll(&p, 1, timeout_ms) > 0 && (p.revents & POLLIN);
}

CanLink::CanLink(const std::string& interface, std::span<const std::uint32_t> ids,
                 bool extended_ids, double backoff_min_s, double backoff_max_s)
    : extended_(extended_ids),
      backoff_min_s_(backoff_min_s),
      backoff_max_s_(backoff_max_s),
      backoff_s_(backoff_min_s) {
  std::snprintf(interface_, sizeof interface_, "%s", interface.c_str());
  id_count_ = std::min<std::size_t>(ids.size(), 16);
  std::copy_n(ids.begin(), id_count_, ids_);
}

bool CanLink::ensure_open(double now_s) {
  if (socket_.is_open()) return true;
  if (now_s < next_attempt_s_) return false;
  ++counters_.reopen_attempts;
  if (socket_.open(interface_, {ids_, id_count_}, extended_, error_, sizeof error_)) {
    if (counters_.reopen_attempts > 1) ++counters_.reopens;
    backoff_s_ = backoff_min_s_;
    return true;
  }
  next_attempt_s_ = now_s + backoff_s_;
  backoff_s_ = std::min(backoff_s_ * 2.0, backoff_max_s_);
  return false;
}

void CanLink::went_down(double now_s) {
  ++counters_.link_down_events;
  describe(error_, sizeof error_, "CAN link down", socket_.last_errno(), interface_);
  socket_.close();
  next_attempt_s_ = now_s + backoff_s_;
}

CanIo CanLink::receive(CanFrame* frame, double now_s) {
  if (!ensure_open(now_s)) return CanIo::kDown;
  const CanIo io = socket_.receive(frame);
  if (io == CanIo::kOk) ++counters_.rx_frames;
  if (io == CanIo::kDown) went_down(now_s);
  return io;
}

CanIo CanLink::send(const CanFrame& frame, double now_s) {
  if (!ensure_open(now_s)) {
    ++counters_.tx_link_down;
    return CanIo::kDown;
  }
  const CanIo io = socket_.send(frame);
  if (io == CanIo::kOk) ++counters_.tx_frames;
  if (io == CanIo::kWouldBlock) ++counters_.tx_queue_full;
  if (io == CanIo::kDown) {
    ++counters_.tx_link_down;
    went_down(now_s);
  }
  return io;
}

}  // namespace zonemap::can
