// MAVLink to a MAVLink router or autopilot over UDP (e.g. mavlink-router's
// 127.0.0.1:14550 on a companion computer): OBSTACLE_DISTANCE (72 sectors) and
// OBSTACLE_DISTANCE_3D (the nearest obstacles) at `rate_hz` whatever the frame
// rate, and HEARTBEAT at 1 Hz. Between map updates the newest one is sent again
// on the output thread's tick, until it is `stale_after_s` old: then only the
// heartbeat goes, and the autopilots' own timeouts (0.5 s) say the data is gone.
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
  double rate_hz = 10.0;       // OBSTACLE_DISTANCE(_3D); [5, 50]: both autopilots time out at 0.5 s
  int system_id = 1;           // our MAVLink system id (the vehicle's)
  int component_id = 195;      // MAV_COMP_ID_PATHPLANNER
  int max_obstacles_3d = 16;   // OBSTACLE_DISTANCE_3D per update; 0 = none
  double stale_after_s = 0.5;  // stop re-sending an update this old
  SectorConfig sectors;
};

// Empty when usable, else why not.
std::string validate(const MavlinkUdpConfig& config);

// Where the datagrams go instead of a socket (a replay on a desk: a telemetry log).
class DatagramOut {
 public:
  virtual ~DatagramOut() = default;
  virtual bool send(const std::uint8_t* datagram, std::size_t size, double now_s) = 0;
};

class MavlinkUdpSink final : public hal::ObstacleSink {
 public:
  static constexpr int kMaxObstacles3d = 64;
  explicit MavlinkUdpSink(const MavlinkUdpConfig& config);
  // Datagrams to `out`, not to a socket (no open()); the config must validate.
  MavlinkUdpSink(const MavlinkUdpConfig& config, DatagramOut& out);
  ~MavlinkUdpSink() override;
  // False with the reason when the address is unusable.
  bool open(std::string* error);
  const char* name() const override { return "MAVLink/UDP (OBSTACLE_DISTANCE, _3D, HEARTBEAT)"; }
  void publish(const hal::ObstacleUpdate& update, double now_s) override;
  void tick(double now_s) override;
  void report(hal::HealthSnapshot* health) const override;
  std::int64_t updates() const { return updates_; }  // map updates handed to publish()
  std::int64_t sent() const { return sent_; }        // datagrams of every kind
  std::int64_t heartbeats() const { return heartbeats_; }
  std::int64_t failed() const { return failed_; }
  // Updates that came sooner than 1 / rate_hz after the last message sent.
  std::int64_t rate_limited() const { return rate_limited_; }

 private:
  void send_obstacles(double now_s);
  void schedule_next(double now_s);
  bool can_send() const { return fd_ >= 0 || out_ != nullptr; }
  void send(const std::uint8_t* frame, std::size_t size, double now_s);

  MavlinkUdpConfig config_;
  LinkIds ids_;
  int fd_ = -1;
  DatagramOut* out_ = nullptr;
  unsigned char address_[16] = {};  // sockaddr_in
  std::uint8_t sequence_ = 0;
  // The newest update, as sent (sectors, nearest obstacles) and when it came.
  ObstacleDistances distances_;
  std::uint64_t time_usec_ = 0;
  NearestObstacle nearest_[kMaxObstacles3d];
  std::size_t nearest_count_ = 0;
  double update_s_ = -1e300, next_send_s_ = -1e300, last_heartbeat_s_ = -1e300;
  std::int64_t sent_ = 0, failed_ = 0, rate_limited_ = 0, resent_ = 0, stale_ = 0;
  std::int64_t heartbeats_ = 0, obstacles_3d_ = 0, updates_ = 0;
};

}  // namespace zonemap::mavlink
