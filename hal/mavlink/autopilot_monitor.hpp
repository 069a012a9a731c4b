// What the autopilot says back on the MAVLink link: its heartbeats (is it there?)
// and the proximity bit of its SYS_STATUS (does it take our obstacles?), so a
// link that fails shows in the daemon's health. Only the vehicle's autopilot
// counts (our system id, component 1, a real autopilot type); frames that fail
// their CRC or length are counted and dropped. No allocation.
#pragma once

#include <cstddef>
#include <cstdint>

#include "hal/output/obstacle_sink.hpp"

namespace zonemap::mavlink {

class AutopilotMonitor {
 public:
  static constexpr double kHeartbeatTimeoutS = 3.0;  // three missed 1 Hz heartbeats

  explicit AutopilotMonitor(std::uint8_t vehicle_system_id) : system_id_(vehicle_system_id) {}
  // One datagram from the link, at the output thread's clock.
  void on_datagram(const std::uint8_t* data, std::size_t size, double now_s);
  // Notices an autopilot that went silent.
  void update(double now_s);
  void report(hal::HealthSnapshot* health) const;

  bool autopilot_present() const { return present_; }
  // 1: ArduPilot/PX4 reports its proximity sensor healthy, 0: unhealthy, -1: not said.
  int proximity_state() const { return proximity_; }

 private:
  void on_heartbeat(double now_s);
  void on_proximity(bool healthy);

  std::uint8_t system_id_;
  bool present_ = false;
  int proximity_ = -1;
  double last_heartbeat_s_ = -1e300;
  std::int64_t frames_ = 0, rejected_ = 0, heartbeats_ = 0, lost_ = 0, proximity_lost_ = 0;
};

}  // namespace zonemap::mavlink
