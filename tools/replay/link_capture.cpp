#include "tools/replay/link_capture.hpp"

#include <filesystem>

namespace zonemap::tools {

bool LinkCapture::open(const std::string& dir, const CameraModel& camera,
                       const SectorConfig& sectors, std::size_t max_boxes, std::string* error) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (!candump_.open(dir + "/obstacles.candump", "can0", error) ||
      !lcm_log_.open(dir + "/obstacles.lcmlog", error) ||
      !tlog_.open(dir + "/obstacles.tlog", error) ||
      !tlog_ardupilot_.open(dir + "/obstacles-ardupilot.tlog", error)) {
    return false;
  }
  can_ = std::make_unique<can::CanObstacleSink>(candump_, can::ObstacleCanConfig{}, max_boxes);
  lcm_link::LcmOutputConfig lcm;
  lcm.sectors = sectors;
  lcm.body_T_camera = camera.body_T_camera;
  lcm.mount_configured = camera.mount_configured;
  lcm_ = std::make_unique<lcm_link::LcmObstacleSink>(lcm, lcm_log_);
  mavlink::MavlinkUdpConfig mavlink;
  mavlink.sectors = sectors;
  mavlink.autopilot = "px4";
  mavlink_ = std::make_unique<mavlink::MavlinkUdpSink>(mavlink, tlog_);
  mavlink.autopilot = "ardupilot";
  mavlink_ardupilot_ = std::make_unique<mavlink::MavlinkUdpSink>(mavlink, tlog_ardupilot_);
  return true;
}

void LinkCapture::publish(const hal::ObstacleUpdate& update, double time_s) {
  can_->publish(update, time_s);
  can_->tick(time_s);
  lcm_->publish(update, time_s);
  lcm_->tick(time_s);
  mavlink_->publish(update, time_s);
  mavlink_->tick(time_s);
  mavlink_ardupilot_->publish(update, time_s);
  mavlink_ardupilot_->tick(time_s);
}

void LinkCapture::close() {
  candump_.close();
  lcm_log_.close();
  tlog_.close();
  tlog_ardupilot_.close();
}

}  // namespace zonemap::tools
