// What the vehicle links would have carried during a replay, written to files a
// user can open with the links' own tools: the obstacle CAN frames as a candump
// log (`canplayer`, a DBC viewer), the LCM messages as an LCM event log
// (`lcm-logplayer`, lcm-spy), the MAVLink messages as a telemetry log (.tlog:
// MAVProxy, QGroundControl, pymavlink), as PX4 reads them (OBSTACLE_DISTANCE) and
// as ArduPilot does (OBSTACLE_DISTANCE_3D scans). The sinks are the daemon's, with default
// settings; every message is stamped with the mapped frame's time, so the files
// of one sequence are the same on every run.
#pragma once

#include <memory>
#include <string>

#include <Eigen/Geometry>

#include "hal/can/candump_writer.hpp"
#include "hal/can/obstacle_can_sink.hpp"
#include "hal/lcm/lcm_log_writer.hpp"
#include "hal/lcm/lcm_sinks.hpp"
#include "hal/mavlink/mavlink_udp_sink.hpp"
#include "hal/mavlink/tlog_writer.hpp"
#include "zonemap/common/camera.hpp"
#include "zonemap/outputs/obstacle_distance.hpp"

namespace zonemap::tools {

class LinkCapture {
 public:
  // DIR/obstacles.candump, DIR/obstacles.lcmlog, DIR/obstacles.tlog (PX4),
  // DIR/obstacles-ardupilot.tlog.
  bool open(const std::string& dir, const CameraModel& camera, const SectorConfig& sectors,
            std::size_t max_boxes, std::string* error);
  // One map update to every link, then each link's periodic work.
  void publish(const hal::ObstacleUpdate& update, double time_s);
  // Flushes and closes the files (the run's end).
  void close();

 private:
  can::CandumpWriter candump_;
  lcm_link::LcmLogWriter lcm_log_;
  mavlink::TlogWriter tlog_, tlog_ardupilot_;
  std::unique_ptr<can::CanObstacleSink> can_;
  std::unique_ptr<lcm_link::LcmObstacleSink> lcm_;
  std::unique_ptr<mavlink::MavlinkUdpSink> mavlink_, mavlink_ardupilot_;
};

}  // namespace zonemap::tools
