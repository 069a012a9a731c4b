// The autopilot's EKF as the INS (most companion computers have no INS of their
// own): ATTITUDE_QUATERNION (NED <- FRD body) and LOCAL_POSITION_NED received on a
// UDP port of ours (from the autopilot or a router), paired by the autopilot's
// time_boot_ms into one solution, its time mapped onto our CLOCK_MONOTONIC by
// TIMESYNC (asked once a second; the answer's tc1 - midpoint of the round trip,
// smoothed; a persisting step is adopted and counted), then through the same INS
// gate and mount as LCM and CAN. The world is the EKF's NED frame. The messages
// are asked for (MAV_CMD_SET_MESSAGE_INTERVAL) while they do not come. Frames
// from other systems, with a bad CRC, or solutions before the clocks are synced
// are counted and cost only themselves. No allocation after open().
#pragma once

#include <cstdint>
#include <string>

#include <Eigen/Geometry>

#include "hal/ins/pose_source.hpp"
#include "hal/mavlink/mavlink_inbound.hpp"

namespace zonemap::mavlink {

struct MavlinkPoseConfig {
  std::string listen = "127.0.0.1:14551";  // IPv4 address:port we receive on (port 0: any)
  int autopilot_system_id = 1;             // whose messages are the INS
  int system_id = 1, component_id = 195;   // ours, for TIMESYNC and requests
  double rate_hz = 50.0;                   // asked of the autopilot, per message
  double max_pair_gap_s = 0.03;            // attitude and position this close make one solution
  double max_timesync_rtt_s = 0.05;        // a slower round trip says nothing about the offset
};
std::string validate(const MavlinkPoseConfig& config);

// Autopilot clock - our clock, from TIMESYNC round trips.
class ClockSync {
 public:
  static constexpr double kStepS = 0.05;  // a sample this far off, three times running: a step
  // One answer: sent at ts1 and received at now (our clock), tc1 the autopilot's.
  bool add(double ts1_s, double tc1_s, double now_s, double max_rtt_s);
  bool synced() const { return samples_ > 0; }
  double offset_s() const { return offset_s_; }
  std::int64_t samples() const { return samples_; }
  std::int64_t steps() const { return steps_; }

 private:
  double offset_s_ = 0.0;
  int off_in_a_row_ = 0;
  std::int64_t samples_ = 0, steps_ = 0;
};

class MavlinkPoseSource final : public hal::PoseSource {
 public:
  MavlinkPoseSource(const MavlinkPoseConfig& config, const InsGateConfig& gate,
                    const Eigen::Isometry3d& body_T_camera, double time_offset_s);
  ~MavlinkPoseSource() override;
  bool open(std::string* error);
  hal::PollResult poll(hal::PoseSink& sink, int wait_ms) override;
  hal::PoseSourceCounters counters() const override;
  const char* name() const override { return "INS from the autopilot over MAVLink"; }
  int bound_port() const;  // the port listened on (listen's port 0: any free one)

  // The source's work on one datagram at our clock's now_s (the socket's or a test's).
  void on_datagram(const std::uint8_t* data, std::size_t size, hal::PoseSink& sink, double now_s);
  // Requests due at now_s (TIMESYNC, message intervals), framed into `out`; the
  // number of frames (each of `sizes`), at most kMaxRequests.
  static constexpr int kMaxRequests = 3;
  int requests_due(double now_s, std::uint8_t out[kMaxRequests][64], std::size_t sizes[]);
  const ClockSync& clock() const { return clock_; }
  std::int64_t unsynced() const { return unsynced_; }

 private:
  void on_frame(const InboundFrame& frame, hal::PoseSink& sink, double now_s);
  void on_position(const LocalPositionNed& p, hal::PoseSink& sink, double now_s);
  void send_requests(double now_s);

  MavlinkPoseConfig config_;
  hal::InsPoseFilter filter_;
  int fd_ = -1;
  unsigned char peer_[16] = {};  // sockaddr_in of whoever sends the autopilot's frames
  bool have_peer_ = false;
  std::uint8_t sequence_ = 0;
  ClockSync clock_;
  AttitudeQuaternion attitude_{};
  bool have_attitude_ = false;
  double last_timesync_s_ = -1e300, last_request_s_ = -1e300;
  double last_attitude_s_ = -1e300, last_position_s_ = -1e300;  // our clock, on arrival
  std::int64_t messages_ = 0, malformed_ = 0, solutions_ = 0, unsynced_ = 0, unpaired_ = 0;
};

}  // namespace zonemap::mavlink
