// MAVLink to a MAVLink router or autopilot over UDP (e.g. mavlink-router's
// 127.0.0.1:14550 on a companion computer): the obstacles at `rate_hz` whatever
// the frame rate, as the configured autopilot reads them, and HEARTBEAT at 1 Hz.
// One message kind to one proximity sensor, never both: ArduPilot replaces its
// whole proximity boundary on each OBSTACLE_DISTANCE, so 3-D points the 2-D
// sectors do not carry would be wiped on every tick.
//  - ArduPilot, 3d (its default): one scan of OBSTACLE_DISTANCE_3D (BODY_FRD) a
//    tick, back to back under one new time_boot_ms: each box's nearest point in
//    each of ArduPilot's eight 45-degree sectors, nearest first, every sector's
//    nearest kept; a scan with no obstacle is one zero vector (ArduPilot clears
//    its boundary on the new time_boot_ms, drops the point and keeps the sensor
//    healthy).
//    Between map updates each scan's points are the newest update's, expressed
//    in the body frame of the vehicle moved on since (its last two updates'
//    velocity, over at most 0.5 s): ArduPilot keeps a point's body-frame vector
//    as it comes, so a vector for where the vehicle was reads an obstacle ahead
//    as farther than it is by the distance flown since.
//  - ArduPilot, 2d, and PX4 (which reads no 3-D message): OBSTACLE_DISTANCE
//    alone, 72 sectors of 5 degrees, BODY_FRD. Between map updates the sectors
//    are the newest update's obstacles from where the vehicle has moved to since
//    (its obstacle boxes within reach kept, at most kept_boxes with kept_rects
//    footprint rectangles; past that its sectors re-expressed,
//    moved_obstacle_distances: never farther, but spread), the seen sectors
//    turned with the vehicle.
// Between map updates the newest update is sent again on the output thread's
// tick, until it is `stale_after_s` old: then only the heartbeat goes, and the
// autopilots' own timeouts (0.5 s) say the data is gone.
// Non-blocking: a send that cannot go is counted. What the autopilot sends back
// to our port from the configured address (its heartbeats, SYS_STATUS) is read
// on each tick, at most kMaxDatagramsPerTick, into the AutopilotMonitor's
// counters; datagrams from any other address are counted and dropped.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "hal/mavlink/autopilot_monitor.hpp"
#include "hal/mavlink/obstacle_distance_mavlink.hpp"
#include "hal/output/obstacle_sink.hpp"

namespace zonemap::mavlink {

struct MavlinkUdpConfig {
  std::string autopilot;  // "ardupilot" or "px4": required (which messages go)
  std::string messages;   // "3d" or "2d"; empty: the autopilot's own (ardupilot 3d, px4 2d)
  std::string host = "127.0.0.1";  // IPv4 address
  int port = 14550;
  double rate_hz = 10.0;       // OBSTACLE_DISTANCE(_3D); [5, 50]: both autopilots time out at 0.5 s
  int system_id = 1;           // our MAVLink system id (the vehicle's)
  int component_id = 195;      // MAV_COMP_ID_PATHPLANNER
  int max_obstacles_3d = 32;   // OBSTACLE_DISTANCE_3D points a scan, [8, 64]
  double stale_after_s = 0.5;  // stop re-sending an update this old
  SectorConfig sectors;
  // 2-D: the newest update's obstacle boxes (and footprint rectangles) kept for
  // the sectors sent between updates, reserved at start; the daemon sizes them as
  // the feature map's merged output, so that they always fit.
  std::size_t kept_boxes = 256;
  std::size_t kept_rects = 2048;
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
  const char* name() const override {
    return send_3d_ ? "MAVLink/UDP for ArduPilot (OBSTACLE_DISTANCE_3D, HEARTBEAT)"
                    : "MAVLink/UDP (OBSTACLE_DISTANCE, HEARTBEAT)";
  }
  bool sends_3d() const { return send_3d_; }
  // One datagram from the autopilot (the socket's, or a test's).
  void on_datagram(const std::uint8_t* data, std::size_t size, double now_s) {
    monitor_.on_datagram(data, size, now_s);
  }
  const AutopilotMonitor& autopilot() const { return monitor_; }
  static constexpr int kMaxDatagramsPerTick = 64;
  void publish(const hal::ObstacleUpdate& update, double now_s) override;
  void tick(double now_s) override;
  void report(hal::HealthSnapshot* health) const override;
  std::int64_t updates() const { return updates_; }  // map updates handed to publish()
  std::int64_t sent() const { return sent_; }        // datagrams of every kind
  std::int64_t heartbeats() const { return heartbeats_; }
  std::int64_t failed() const { return failed_; }
  // Updates that came sooner than 1 / rate_hz after the last message sent.
  std::int64_t rate_limited() const { return rate_limited_; }
  // OBSTACLE_DISTANCE sent between updates: from the kept obstacles, or (too many
  // to keep) the update's sectors re-expressed.
  std::int64_t sectors_from_kept() const { return sectors_from_kept_; }
  std::int64_t sectors_re_expressed() const { return sectors_re_expressed_; }

 private:
  void send_obstacles(double now_s);
  void send_scan_3d(double now_s);
  Eigen::Isometry3d pose_now(double now_s) const;
  double pose_ahead_s(double now_s) const;
  void keep_obstacles(const hal::ObstacleUpdate& update);
  ObstacleDistances sectors_now(double now_s);
  void receive(double now_s);
  void schedule_next(double now_s);
  bool can_send() const { return fd_ >= 0 || out_ != nullptr; }
  void send(const std::uint8_t* frame, std::size_t size, double now_s);

  MavlinkUdpConfig config_;
  bool send_3d_ = false;  // else OBSTACLE_DISTANCE
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
  // The nearest points in the world, and the vehicle's poses of the newest two
  // updates (frame times): a message sent later re-expresses the points, or the
  // sectors (moved_obstacle_distances), for where the vehicle has moved to since
  // (extrapolate_pose), never for where it was.
  Eigen::Vector3d nearest_world_[kMaxObstacles3d];
  Eigen::Isometry3d update_pose_ = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d previous_pose_ = Eigen::Isometry3d::Identity();
  double update_frame_s_ = -1e300, previous_frame_s_ = -1e300;
  bool world_z_up_ = true;
  // The newest update's obstacle boxes within reach and what it had seen (2-D),
  // for the sectors of a message sent later; kept_all_ false: they did not fit.
  std::vector<ObstacleBox> kept_boxes_;
  std::vector<FootprintRect> kept_rects_;
  std::vector<std::uint32_t> kept_offsets_, kept_counts_;
  std::size_t kept_count_ = 0;
  bool kept_all_ = false;
  SectorMask observed_{};
  std::int64_t sectors_from_kept_ = 0, sectors_re_expressed_ = 0;
  double update_s_ = -1e300, next_send_s_ = -1e300, last_heartbeat_s_ = -1e300;
  std::int64_t sent_ = 0, failed_ = 0, rate_limited_ = 0, resent_ = 0, stale_ = 0;
  std::int64_t heartbeats_ = 0, obstacles_3d_ = 0, updates_ = 0;
  std::int64_t obstacle_distance_ = 0, scans_3d_ = 0, empty_scans_3d_ = 0;
  std::uint32_t last_scan_ms_ = 0;  // a scan's time_boot_ms: each new one greater
  AutopilotMonitor monitor_;
  std::int64_t foreign_ = 0;  // datagrams from an address that is not the autopilot's
};

}  // namespace zonemap::mavlink
