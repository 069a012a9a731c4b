// MAVLink OBSTACLE_DISTANCE over UDP to a MAVLink router or autopilot (e.g.
// mavlink-router's 127.0.0.1:14550 on a companion computer), at a fixed rate.
// Non-blocking: a send that cannot go is counted.
#pragma once

#include <cstdint>
#include <string>

#include "hal/mavlink/obstacle_distance_mavlink.hpp"
#include "hal/output/obstacle_sink.hpp"

namespace zonemap::mavlink {

struct MavlinkUdpConfig {
  std::string host = "127.0.0.1";  // IPv4 address
  int port = 14550;
  double rate_hz = 10.0;
  LinkIds ids;
  SectorConfig sectors;
};

class MavlinkUdpSink final : public hal::ObstacleSink {
 public:
  explicit MavlinkUdpSink(const MavlinkUdpConfig& config);
  ~MavlinkUdpSink() override;
  // False with the reason when the address is unusable.
  bool open(std::string* error);
  const char* name() const override { return "OBSTACLE_DISTANCE over MAVLink/UDP"; }
  void publish(const hal::ObstacleUpdate& update, double now_s) override;
  void report(hal::HealthSnapshot* health) const override;
  std::int64_t sent() const { return sent_; }
  std::int64_t failed() const { return failed_; }
  // Updates that came sooner than 1 / rate_hz after the last message sent.
  std::int64_t rate_limited() const { return rate_limited_; }

 private:
  MavlinkUdpConfig config_;
  int fd_ = -1;
  unsigned char address_[16] = {};  // sockaddr_in
  std::uint8_t sequence_ = 0;
  double last_s_ = -1e300;
  std::int64_t sent_ = 0, failed_ = 0, rate_limited_ = 0;
};

}  // namespace zonemap::mavlink
