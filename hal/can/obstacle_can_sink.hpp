// Obstacle boxes to the flight controller over SocketCAN (layout:
// config/can/zonemap-obstacles.dbc), at the configured rate and bus budget.
// A full transmit queue or a link that is down cuts the update short (counted;
// the receiver sees no END and keeps its last complete map); mapping never waits.
#pragma once

#include <string>
#include <vector>

#include "hal/can/obstacle_can.hpp"
#include "hal/can/socketcan.hpp"
#include "hal/output/obstacle_sink.hpp"

namespace zonemap::can {

class CanObstacleSink final : public hal::ObstacleSink {
 public:
  CanObstacleSink(const std::string& interface, const ObstacleCanConfig& config,
                  std::size_t max_boxes);
  // Sends through `transport` instead of its own SocketCAN link (fault injection).
  CanObstacleSink(CanTransport& transport, const ObstacleCanConfig& config, std::size_t max_boxes);
  const char* name() const override { return "obstacles over SocketCAN"; }
  void publish(const hal::ObstacleUpdate& update, double now_s) override;
  void report(hal::HealthSnapshot* health) const override;
  const CanLinkCounters& link_counters() const { return link_.counters(); }
  const ObstacleCanCounters& encoder_counters() const { return encoder_.counters(); }
  std::int64_t updates_cut_short() const { return cut_short_; }

 private:
  ObstacleCanConfig config_;
  ObstacleCanEncoder encoder_;
  CanLink link_;
  CanTransport* transport_;
  std::vector<std::uint32_t> order_;
  std::vector<CanFrame> frames_;
  double last_s_ = -1e300;
  std::int64_t cut_short_ = 0, updates_sent_ = 0;
};

}  // namespace zonemap::can
