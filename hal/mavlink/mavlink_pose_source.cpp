#include "hal/mavlink/mavlink_pose_source.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>

#include "hal/mavlink/obstacle_distance_mavlink.hpp"
#include "hal/os/clock.hpp"

namespace zonemap::mavlink {
namespace {

constexpr std::uint32_t kCommandLongId = 76;
constexpr std::uint8_t kCommandLongCrcExtra = 152;
constexpr std::size_t kCommandLongPayload = 33;
constexpr std::uint16_t kSetMessageInterval = 511;  // MAV_CMD_SET_MESSAGE_INTERVAL
constexpr double kTimesyncPeriodS = 1.0;
constexpr double kRequestPeriodS = 2.0;
constexpr double kMissingAfterS = 1.0;
constexpr int kMaxDatagramsPerPoll = 256;

bool parse_address(const std::string& text, sockaddr_in* out) {
  const std::size_t colon = text.rfind(':');
  if (colon == std::string::npos) return false;
  char* end = nullptr;
  const long port = std::strtol(text.c_str() + colon + 1, &end, 10);
  if (*end != '\0' || port < 0 || port > 65535) return false;  // 0: any free port
  *out = {};
  out->sin_family = AF_INET;
  out->sin_port = htons(static_cast<std::uint16_t>(port));
  return inet_pton(AF_INET, text.substr(0, colon).c_str(), &out->sin_addr) == 1;
}

std::size_t encode_set_interval(std::uint32_t message_id, double rate_hz, const LinkIds& ids,
                                std::uint8_t target, std::uint8_t sequence, std::uint8_t* buf) {
  std::uint8_t payload[kCommandLongPayload] = {};
  const float param1 = static_cast<float>(message_id);
  const float param2 = static_cast<float>(1e6 / rate_hz);  // interval, microseconds
  std::memcpy(payload, &param1, 4);
  std::memcpy(payload + 4, &param2, 4);
  payload[28] = static_cast<std::uint8_t>(kSetMessageInterval & 0xFF);
  payload[29] = static_cast<std::uint8_t>(kSetMessageInterval >> 8);
  payload[30] = target;
  payload[31] = kComponentAutopilot;
  return encode_frame(kCommandLongId, kCommandLongCrcExtra, payload, kCommandLongPayload, ids,
                      sequence, buf);
}

}  // namespace

std::string validate(const MavlinkPoseConfig& c) {
  sockaddr_in address{};
  if (!parse_address(c.listen, &address)) {
    return "poses.mavlink_listen must be an IPv4 address:port, not '" + c.listen + "'";
  }
  if (c.autopilot_system_id < 1 || c.autopilot_system_id > 255) {
    return "poses.autopilot_system_id must be in [1, 255]";
  }
  if (!(c.rate_hz >= 10.0 && c.rate_hz <= 200.0)) {
    return "poses.rate_hz must be in [10, 200]: the mapper interpolates between poses";
  }
  return {};
}

bool ClockSync::add(double ts1_s, double tc1_s, double now_s, double max_rtt_s) {
  const double rtt = now_s - ts1_s;
  if (!(rtt >= 0.0 && rtt <= max_rtt_s) || !std::isfinite(tc1_s)) return false;
  const double sample = tc1_s - 0.5 * (ts1_s + now_s);
  if (samples_ == 0) {
    offset_s_ = sample;
  } else if (std::abs(sample - offset_s_) > kStepS) {
    // One odd answer is ignored; three running are the autopilot's new clock
    // (it rebooted, or its time was set).
    if (++off_in_a_row_ < 3) return false;
    offset_s_ = sample;
    ++steps_;
  } else {
    offset_s_ += 0.1 * (sample - offset_s_);  // smooths the round trips' jitter
  }
  off_in_a_row_ = 0;
  ++samples_;
  return true;
}

MavlinkPoseSource::MavlinkPoseSource(const MavlinkPoseConfig& config, const InsGateConfig& gate,
                                     const Eigen::Isometry3d& body_T_camera, double time_offset_s)
    : config_(config), filter_(gate, body_T_camera, time_offset_s, "mavlink-ins") {}

MavlinkPoseSource::~MavlinkPoseSource() {
  if (fd_ >= 0) ::close(fd_);
}

bool MavlinkPoseSource::open(std::string* error) {
  const std::string why = validate(config_);
  sockaddr_in address{};
  if (!why.empty() || !parse_address(config_.listen, &address)) {
    *error = "mavlink poses: " + why;
    return false;
  }
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0 || ::bind(fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
    *error = "mavlink poses: cannot listen on " + config_.listen + ": " + std::strerror(errno);
    return false;
  }
  return true;
}

void MavlinkPoseSource::on_datagram(const std::uint8_t* data, std::size_t size, hal::PoseSink& sink,
                                    double now_s) {
  InboundFrame frame;
  while (size > 0) {  // bounded: each frame read consumes at least 8 bytes
    std::size_t used = 0;
    const FrameStatus status = read_frame(data, size, &frame, &used);
    if (status == FrameStatus::kBad || status == FrameStatus::kTruncated) {
      ++malformed_;
      filter_.log().log(hal::LogReason::kMalformedMessage, now_s, name(),
                        "a MAVLink frame with a bad length or CRC");
      return;
    }
    data += used;
    size -= used;
    if (status != FrameStatus::kKnown) continue;
    if (frame.system_id != config_.autopilot_system_id ||
        frame.component_id != kComponentAutopilot) {
      continue;  // a ground station's, another vehicle's, ours echoed by a router
    }
    ++messages_;
    on_frame(frame, sink, now_s);
  }
}

void MavlinkPoseSource::on_frame(const InboundFrame& frame, hal::PoseSink& sink, double now_s) {
  switch (frame.message_id) {
    case kTimesyncId: {
      const Timesync t = timesync_of(frame);
      if (t.tc1 != 0) {
        clock_.add(static_cast<double>(t.ts1) * 1e-9, static_cast<double>(t.tc1) * 1e-9, now_s,
                   config_.max_timesync_rtt_s);
      }
      break;
    }
    case kAttitudeQuaternionId:
      attitude_ = attitude_quaternion_of(frame);
      have_attitude_ = true;
      last_attitude_s_ = now_s;
      break;
    case kLocalPositionNedId:
      last_position_s_ = now_s;
      on_position(local_position_ned_of(frame), sink, now_s);
      break;
    default:
      break;
  }
}

// A position with the attitude of (nearly) the same autopilot time: one solution.
void MavlinkPoseSource::on_position(const LocalPositionNed& p, hal::PoseSink& sink, double now_s) {
  const double gap_s =
      std::abs(static_cast<double>(p.time_boot_ms) - static_cast<double>(attitude_.time_boot_ms)) *
      1e-3;
  if (!have_attitude_ || gap_s > config_.max_pair_gap_s) {
    ++unpaired_;
    return;
  }
  if (!clock_.synced()) {
    ++unsynced_;  // no time on our clock yet: it would be guessed
    return;
  }
  ++solutions_;
  InsSolution s;
  s.time_s = p.time_boot_ms * 1e-3 - clock_.offset_s();
  s.position_m = Eigen::Vector3d(p.north, p.east, p.down);
  s.attitude = Eigen::Quaterniond(attitude_.w, attitude_.x, attitude_.y, attitude_.z);
  s.attitude_valid = true;
  s.position_valid = true;
  filter_.pass(s, sink, now_s);
}

int MavlinkPoseSource::requests_due(double now_s, std::uint8_t out[kMaxRequests][64],
                                    std::size_t sizes[]) {
  int n = 0;
  const LinkIds ids{static_cast<std::uint8_t>(config_.system_id),
                    static_cast<std::uint8_t>(config_.component_id)};
  if (now_s - last_timesync_s_ >= kTimesyncPeriodS) {
    last_timesync_s_ = now_s;
    const Timesync ask{0, static_cast<std::int64_t>(std::llround(now_s * 1e9))};
    sizes[n] = encode_timesync(ask, ids.system_id, ids.component_id, sequence_++, out[n]);
    ++n;
  }
  if (now_s - last_request_s_ >= kRequestPeriodS) {
    // Each once at first contact (it may come, but slower than asked), then again
    // while it does not come.
    const auto target = static_cast<std::uint8_t>(config_.autopilot_system_id);
    const bool first = last_request_s_ < -1e299;
    bool asked = false;
    if (first || now_s - last_attitude_s_ > kMissingAfterS) {
      sizes[n] = encode_set_interval(kAttitudeQuaternionId, config_.rate_hz, ids, target,
                                     sequence_++, out[n]);
      ++n;
      asked = true;
    }
    if (first || now_s - last_position_s_ > kMissingAfterS) {
      sizes[n] = encode_set_interval(kLocalPositionNedId, config_.rate_hz, ids, target, sequence_++,
                                     out[n]);
      ++n;
      asked = true;
    }
    if (asked) last_request_s_ = now_s;
  }
  return n;
}

void MavlinkPoseSource::send_requests(double now_s) {
  if (!have_peer_) return;  // nobody to ask yet
  std::uint8_t frames[kMaxRequests][64];
  std::size_t sizes[kMaxRequests];
  const int n = requests_due(now_s, frames, sizes);
  for (int i = 0; i < n; ++i) {
    ::sendto(fd_, frames[i], sizes[i], MSG_DONTWAIT, reinterpret_cast<const sockaddr*>(peer_),
             sizeof(sockaddr_in));
  }
}

hal::PollResult MavlinkPoseSource::poll(hal::PoseSink& sink, int wait_ms) {
  if (fd_ < 0) return hal::PollResult::kIdle;
  if (wait_ms > 0) {
    pollfd p{fd_, POLLIN, 0};
    ::poll(&p, 1, wait_ms);
  }
  const std::int64_t before = filter_.poses_out();
  std::uint8_t datagram[2048];
  for (int i = 0; i < kMaxDatagramsPerPoll; ++i) {
    sockaddr_in from{};
    socklen_t from_size = sizeof from;
    const ssize_t n = ::recvfrom(fd_, datagram, sizeof datagram, MSG_DONTWAIT,
                                 reinterpret_cast<sockaddr*>(&from), &from_size);
    if (n < 0) break;
    const double now_s = os::monotonic_now_s();
    if (!have_peer_) {
      std::memcpy(peer_, &from, sizeof from);  // the autopilot (or its router): asked from now on
      have_peer_ = true;
    }
    on_datagram(datagram, static_cast<std::size_t>(n), sink, now_s);
  }
  send_requests(os::monotonic_now_s());
  return filter_.poses_out() > before ? hal::PollResult::kGotData : hal::PollResult::kIdle;
}

int MavlinkPoseSource::bound_port() const {
  sockaddr_in address{};
  socklen_t size = sizeof address;
  if (fd_ < 0 || ::getsockname(fd_, reinterpret_cast<sockaddr*>(&address), &size) != 0) return -1;
  return ntohs(address.sin_port);
}

hal::PoseSourceCounters MavlinkPoseSource::counters() const {
  hal::PoseSourceCounters c;
  c.messages = messages_;
  c.malformed = malformed_;
  c.solutions = solutions_;
  c.poses_out = filter_.poses_out();
  c.incomplete = unpaired_ + unsynced_;
  c.time_syncs = clock_.samples();
  c.time_sync_steps = clock_.steps();
  c.gate = filter_.gate_counters();
  return c;
}

}  // namespace zonemap::mavlink
