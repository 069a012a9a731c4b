#include "hal/mavlink/autopilot_monitor.hpp"

#include "hal/mavlink/mavlink_inbound.hpp"
#include "hal/mavlink/obstacle_distance_mavlink.hpp"

namespace zonemap::mavlink {
namespace {

constexpr std::uint8_t kTypeGcs = 6;  // MAV_TYPE_GCS

}  // namespace

void AutopilotMonitor::on_datagram(const std::uint8_t* data, std::size_t size, double now_s) {
  InboundFrame frame;
  // Bounded: every frame read consumes at least its 8-byte header and CRC.
  while (size > 0) {
    std::size_t used = 0;
    const FrameStatus status = read_frame(data, size, &frame, &used);
    if (status == FrameStatus::kBad || status == FrameStatus::kTruncated) {
      ++rejected_;
      return;
    }
    ++frames_;
    data += used;
    size -= used;
    if (status != FrameStatus::kKnown || frame.system_id != system_id_ ||
        frame.component_id != kComponentAutopilot) {
      continue;
    }
    if (frame.message_id == kHeartbeatId) {
      const Heartbeat h = heartbeat_of(frame);
      if (h.autopilot != kAutopilotInvalid && h.type != kTypeGcs &&
          h.type != kTypeOnboardController) {
        on_heartbeat(now_s);
      }
    } else if (frame.message_id == kSysStatusId) {
      const SysStatus s = sys_status_of(frame);
      if (s.present & kSysStatusProximity) {
        on_proximity((s.enabled & kSysStatusProximity) && (s.health & kSysStatusProximity));
      }
    }
  }
}

void AutopilotMonitor::on_heartbeat(double now_s) {
  ++heartbeats_;
  present_ = true;
  last_heartbeat_s_ = now_s;
}

void AutopilotMonitor::on_proximity(bool healthy) {
  if (proximity_ == 1 && !healthy) ++proximity_lost_;
  proximity_ = healthy ? 1 : 0;
}

void AutopilotMonitor::update(double now_s) {
  if (present_ && now_s - last_heartbeat_s_ > kHeartbeatTimeoutS) {
    present_ = false;
    proximity_ = -1;  // nothing it said before holds now
    ++lost_;
  }
}

void AutopilotMonitor::report(hal::HealthSnapshot* h) const {
  h->add("mavlink_in_frames", frames_);
  h->add("mavlink_in_rejected", rejected_);
  h->add("mavlink_autopilot_heartbeats", heartbeats_);
  h->add("mavlink_autopilot_present", present_ ? 1 : 0);
  h->add("mavlink_autopilot_lost", lost_);
  h->add("mavlink_autopilot_proximity", proximity_);
  h->add("mavlink_autopilot_proximity_lost", proximity_lost_);
}

}  // namespace zonemap::mavlink
