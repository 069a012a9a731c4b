#include "hal/mavlink/mavlink_udp_sink.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>

namespace zonemap::mavlink {

static_assert(sizeof(sockaddr_in) <= 16);

MavlinkUdpSink::MavlinkUdpSink(const MavlinkUdpConfig& config) : config_(config) {}

MavlinkUdpSink::~MavlinkUdpSink() {
  if (fd_ >= 0) ::close(fd_);
}

bool MavlinkUdpSink::open(std::string* error) {
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<std::uint16_t>(config_.port));
  if (config_.port <= 0 || config_.port > 65535 ||
      inet_pton(AF_INET, config_.host.c_str(), &to.sin_addr) != 1) {
    *error = "mavlink: '" + config_.host + ":" + std::to_string(config_.port) +
             "' is not an IPv4 address and port";
    return false;
  }
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0) {
    *error = std::string("mavlink: socket: ") + std::strerror(errno);
    return false;
  }
  std::memcpy(address_, &to, sizeof to);
  return true;
}

void MavlinkUdpSink::publish(const hal::ObstacleUpdate& update, double now_s) {
  if (fd_ < 0) return;
  if (now_s - last_s_ < 1.0 / config_.rate_hz) {
    ++rate_limited_;
    return;
  }
  last_s_ = now_s;
  const ObstacleDistances d = obstacle_distances(update.boxes, update.count, update.world_T_body,
                                                 update.world_z_up, config_.sectors);
  std::uint8_t frame[kMaxFrameBytes];
  const auto usec = static_cast<std::uint64_t>(std::llround(std::max(update.time_s, 0.0) * 1e6));
  const std::size_t n = encode_obstacle_distance(d, usec, config_.ids, sequence_++, frame);
  const ssize_t sent = ::sendto(fd_, frame, n, MSG_DONTWAIT,
                                reinterpret_cast<const sockaddr*>(address_), sizeof(sockaddr_in));
  if (sent == static_cast<ssize_t>(n)) {
    ++sent_;
  } else {
    ++failed_;
  }
}

void MavlinkUdpSink::report(hal::HealthSnapshot* h) const {
  h->add("mavlink_out_sent", sent_);
  h->add("mavlink_out_failed", failed_);
  h->add("mavlink_out_rate_limited", rate_limited_);
}

}  // namespace zonemap::mavlink
