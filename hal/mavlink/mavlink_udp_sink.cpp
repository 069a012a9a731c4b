#include "hal/mavlink/mavlink_udp_sink.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>

#include "zonemap/pose/pose_track.hpp"

namespace zonemap::mavlink {

static_assert(sizeof(sockaddr_in) <= 16);

namespace {

bool wants_3d(const MavlinkUdpConfig& c) {
  return c.autopilot == "ardupilot" && c.messages != "2d";
}

}  // namespace

std::string validate(const MavlinkUdpConfig& c) {
  if (c.autopilot != "ardupilot" && c.autopilot != "px4") {
    return "outputs.mavlink.autopilot must be ardupilot (OBSTACLE_DISTANCE_3D) or px4 "
           "(OBSTACLE_DISTANCE): it decides which messages go, never both to one sensor";
  }
  if (!c.messages.empty() && c.messages != "2d" && c.messages != "3d") {
    return "outputs.mavlink.messages must be 2d or 3d";
  }
  if (c.autopilot == "px4" && c.messages == "3d") {
    return "outputs.mavlink.messages: PX4 reads no OBSTACLE_DISTANCE_3D; use 2d";
  }
  if (!(c.rate_hz >= 5.0 && c.rate_hz <= 50.0)) {
    return "outputs.mavlink.rate_hz must be in [5, 50]: PX4 and ArduPilot drop obstacle data "
           "older than 0.5 s";
  }
  if (c.system_id < 1 || c.system_id > 255 || c.component_id < 1 || c.component_id > 255) {
    return "outputs.mavlink.system_id and component_id must be in [1, 255]";
  }
  if (c.max_obstacles_3d < kMaxObstacleWedges ||
      c.max_obstacles_3d > MavlinkUdpSink::kMaxObstacles3d) {
    return "outputs.mavlink.obstacles_3d must be in [8, 64] (a point for each of ArduPilot's "
           "eight sectors at least)";
  }
  if (!(c.stale_after_s > 0.0 && c.stale_after_s <= 5.0)) {
    return "outputs.mavlink.stale_after_s must be in (0, 5]";
  }
  return {};
}

MavlinkUdpSink::MavlinkUdpSink(const MavlinkUdpConfig& config)
    : config_(config),
      send_3d_(wants_3d(config)),
      monitor_(static_cast<std::uint8_t>(config.system_id)) {
  ids_.system_id = static_cast<std::uint8_t>(config.system_id);
  ids_.component_id = static_cast<std::uint8_t>(config.component_id);
  if (!send_3d_) {
    kept_boxes_.resize(config.kept_boxes);
    kept_rects_.resize(config.kept_rects);
    kept_offsets_.resize(config.kept_boxes);
    kept_counts_.resize(config.kept_boxes);
  }
}

MavlinkUdpSink::MavlinkUdpSink(const MavlinkUdpConfig& config, DatagramOut& out)
    : MavlinkUdpSink(config) {
  out_ = &out;
}

MavlinkUdpSink::~MavlinkUdpSink() {
  if (fd_ >= 0) ::close(fd_);
}

bool MavlinkUdpSink::open(std::string* error) {
  const std::string why = validate(config_);
  if (!why.empty()) {
    *error = "mavlink: " + why;
    return false;
  }
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<std::uint16_t>(config_.port));
  if (config_.port <= 0 || config_.port > 65535 ||
      inet_pton(AF_INET, config_.host.c_str(), &to.sin_addr) != 1) {
    *error = "mavlink: '" + config_.host + ":" + std::to_string(config_.port) +
             "' is not an IPv4 address and port";
    return false;
  }
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0) {
    *error = std::string("mavlink: socket: ") + std::strerror(errno);
    return false;
  }
  std::memcpy(address_, &to, sizeof to);
  return true;
}

void MavlinkUdpSink::send(const std::uint8_t* frame, std::size_t size, double now_s) {
  bool sent = false;
  if (out_ != nullptr) {
    sent = out_->send(frame, size, now_s);
  } else {
    sent = ::sendto(fd_, frame, size, MSG_DONTWAIT, reinterpret_cast<const sockaddr*>(address_),
                    sizeof(sockaddr_in)) == static_cast<ssize_t>(size);
  }
  if (sent) {
    ++sent_;
  } else {
    ++failed_;
  }
}

void MavlinkUdpSink::publish(const hal::ObstacleUpdate& update, double now_s) {
  if (!can_send()) return;
  ++updates_;
  if (!send_3d_) {
    distances_ =
        obstacle_distances(update.boxes, update.count, update.footprints(), update.world_T_body,
                           update.world_z_up, config_.sectors, update.sectors_observed);
    keep_obstacles(update);
  } else {
    nearest_count_ = nearest_obstacles(
        update.boxes, update.count, update.footprints(), update.world_T_body, update.world_z_up,
        config_.sectors, nearest_,
        static_cast<std::size_t>(std::clamp(config_.max_obstacles_3d, 0, kMaxObstacles3d)),
        kMaxObstacleWedges);
    for (std::size_t i = 0; i < nearest_count_; ++i) {
      nearest_world_[i] = update.world_T_body * nearest_[i].body_frd;
    }
  }
  previous_pose_ = update_pose_;
  previous_frame_s_ = update_frame_s_;
  update_pose_ = update.world_T_body;
  update_frame_s_ = update.time_s;
  world_z_up_ = update.world_z_up;
  time_usec_ = static_cast<std::uint64_t>(std::llround(std::max(update.time_s, 0.0) * 1e6));
  update_s_ = now_s;
  if (now_s < next_send_s_) {
    ++rate_limited_;  // goes out on the next tick that is due
    return;
  }
  send_obstacles(now_s);
}

void MavlinkUdpSink::receive(double now_s) {
  std::uint8_t datagram[2048];
  for (int i = 0; fd_ >= 0 && i < kMaxDatagramsPerTick; ++i) {
    sockaddr_in from{};
    socklen_t from_size = sizeof from;
    const ssize_t n = ::recvfrom(fd_, datagram, sizeof datagram, MSG_DONTWAIT,
                                 reinterpret_cast<sockaddr*>(&from), &from_size);
    if (n < 0) break;  // nothing waiting (or an ICMP error reported on the socket)
    sockaddr_in to{};
    std::memcpy(&to, address_, sizeof to);
    if (from.sin_addr.s_addr != to.sin_addr.s_addr || from.sin_port != to.sin_port) {
      ++foreign_;
      continue;
    }
    monitor_.on_datagram(datagram, static_cast<std::size_t>(n), now_s);
  }
  monitor_.update(now_s);
}

void MavlinkUdpSink::tick(double now_s) {
  if (!can_send()) return;
  receive(now_s);
  if (now_s - last_heartbeat_s_ >= 1.0) {
    last_heartbeat_s_ = now_s;
    std::uint8_t frame[12 + kHeartbeatPayload];
    send(frame, encode_heartbeat(ids_, sequence_++, frame), now_s);
    ++heartbeats_;
  }
  if (now_s < next_send_s_ || update_s_ < -1e299) return;
  if (now_s - update_s_ > config_.stale_after_s) {
    ++stale_;  // the map stopped: let the autopilot time out rather than repeat old data
    schedule_next(now_s);
    return;
  }
  ++resent_;
  send_obstacles(now_s);
}

// The next send one period after the last one was due, so that ticks arriving a
// little late do not lower the rate; after a pause, one period from now.
void MavlinkUdpSink::schedule_next(double now_s) {
  const double period = 1.0 / config_.rate_hz;
  next_send_s_ += period;
  if (next_send_s_ < now_s) next_send_s_ = now_s + period;
}

void MavlinkUdpSink::send_obstacles(double now_s) {
  schedule_next(now_s);
  if (send_3d_) {
    send_scan_3d(now_s);
    return;
  }
  // The sectors from where the vehicle is now (as computed, at once), stamped with
  // the time they are for: the update's frame time and the time the pose moved on
  // by (none where there was no motion to go by: they stand for the update's pose).
  const double ahead_s = pose_ahead_s(now_s);
  const ObstacleDistances moved = ahead_s > 0.0 ? sectors_now(now_s) : distances_;
  const std::uint64_t time_usec =
      time_usec_ + static_cast<std::uint64_t>(std::llround(ahead_s * 1e6));
  std::uint8_t frame[kMaxFrameBytes];
  send(frame, encode_obstacle_distance(moved, time_usec, ids_, sequence_++, frame), now_s);
  ++obstacle_distance_;
}

// The update's obstacle boxes that a vehicle moving on for up to half a second
// may have within max_distance, with their footprints, while they fit.
void MavlinkUdpSink::keep_obstacles(const hal::ObstacleUpdate& update) {
  const PoseExtrapolationLimits limits;
  const double reach = config_.sectors.max_distance_m + limits.max_speed_mps * limits.max_ahead_s;
  const Eigen::Vector2d position = update.world_T_body.translation().head<2>();
  observed_ = update.sectors_observed;
  kept_count_ = 0;
  kept_all_ = true;
  std::size_t rects = 0;
  // Without all three footprint arrays a box is its own rectangle (FootprintView).
  const bool shaped =
      update.rect_counts != nullptr && update.rect_offsets != nullptr && update.rects != nullptr;
  for (std::size_t b = 0; b < update.count && kept_all_; ++b) {
    const ObstacleBox& box = update.boxes[b];
    if (box.kind != FeatureKind::kObstacle) continue;
    const Eigen::Vector2d lo(box.min.x(), box.min.y()), hi(box.max.x(), box.max.y());
    if ((position.cwiseMax(lo).cwiseMin(hi) - position).norm() > reach) continue;
    const std::uint32_t n = shaped ? update.rect_counts[b] : 0;
    if (kept_count_ == kept_boxes_.size() || rects + n > kept_rects_.size()) {
      kept_all_ = false;
      break;
    }
    kept_boxes_[kept_count_] = box;
    kept_offsets_[kept_count_] = static_cast<std::uint32_t>(rects);
    kept_counts_[kept_count_] = n;
    if (n > 0) {
      std::copy_n(update.rects + update.rect_offsets[b], n, kept_rects_.begin() + rects);
    }
    rects += n;
    ++kept_count_;
  }
}

// The sectors from where the vehicle is now: the kept obstacles where they all
// fit, else the update's sectors re-expressed.
ObstacleDistances MavlinkUdpSink::sectors_now(double now_s) {
  const Eigen::Isometry3d now = pose_now(now_s);
  if (!kept_all_) {
    ++sectors_re_expressed_;
    return moved_obstacle_distances(distances_, update_pose_, now, world_z_up_);
  }
  ++sectors_from_kept_;
  const FootprintView footprints{kept_rects_.data(), kept_offsets_.data(), kept_counts_.data()};
  return obstacle_distances(kept_boxes_.data(), kept_count_, footprints, now, world_z_up_,
                            config_.sectors,
                            turned_sector_mask(observed_, update_pose_, now, world_z_up_));
}

// Where the vehicle is now, by the time since the newest update came.
Eigen::Isometry3d MavlinkUdpSink::pose_now(double now_s) const {
  return extrapolate_pose(previous_pose_, previous_frame_s_, update_pose_, update_frame_s_,
                          now_s - update_s_);
}

// How far pose_now moves the update's pose on: 0 where it keeps it.
double MavlinkUdpSink::pose_ahead_s(double now_s) const {
  return extrapolated_ahead_s(previous_pose_, previous_frame_s_, update_pose_, update_frame_s_,
                              now_s - update_s_);
}

// One scan: every point shares a time_boot_ms newer than the last scan's (the
// autopilot starts a new boundary on a new one), the messages back to back.
void MavlinkUdpSink::send_scan_3d(double now_s) {
  const auto now_ms = static_cast<std::uint32_t>(std::llround(std::max(now_s, 0.0) * 1000.0));
  last_scan_ms_ = std::max(now_ms, last_scan_ms_ + 1);
  ++scans_3d_;
  Obstacle3d o;
  o.time_boot_ms = last_scan_ms_;
  o.min_distance = static_cast<float>(config_.sectors.min_distance_m);
  o.max_distance = static_cast<float>(config_.sectors.max_distance_m);
  std::uint8_t frame3d[12 + kObstacleDistance3dPayload];
  if (nearest_count_ == 0) {
    // Nothing in range: a zero vector, unknown id. The new time_boot_ms clears
    // the boundary; the point itself is dropped; the sensor stays alive.
    o.obstacle_id = kUnknownObstacleId;
    send(frame3d, encode_obstacle_distance_3d(o, ids_, sequence_++, frame3d), now_s);
    ++empty_scans_3d_;
    return;
  }
  const Eigen::Isometry3d body_T_world = pose_now(now_s).inverse();
  for (std::size_t i = 0; i < nearest_count_; ++i) {
    const Eigen::Vector3d body_frd = body_T_world * nearest_world_[i];
    o.obstacle_id = obstacle_id_3d(nearest_[i].id, nearest_[i].wedge);
    o.x = static_cast<float>(body_frd.x());
    o.y = static_cast<float>(body_frd.y());
    o.z = static_cast<float>(body_frd.z());
    send(frame3d, encode_obstacle_distance_3d(o, ids_, sequence_++, frame3d), now_s);
    ++obstacles_3d_;
  }
}

void MavlinkUdpSink::report(hal::HealthSnapshot* h) const {
  h->add("mavlink_out_sent", sent_);
  h->add("mavlink_out_failed", failed_);
  h->add("mavlink_out_rate_limited", rate_limited_);
  h->add("mavlink_out_resent", resent_);
  h->add("mavlink_out_stale", stale_);
  h->add("mavlink_out_heartbeats", heartbeats_);
  h->add("mavlink_out_obstacle_distance", obstacle_distance_);
  h->add("mavlink_out_sectors_moved", sectors_from_kept_);
  h->add("mavlink_out_sectors_re_expressed", sectors_re_expressed_);
  h->add("mavlink_out_obstacles_3d", obstacles_3d_);
  h->add("mavlink_out_scans_3d", scans_3d_);
  h->add("mavlink_out_empty_scans_3d", empty_scans_3d_);
  h->add("mavlink_in_foreign", foreign_);
  monitor_.report(h);
}

}  // namespace zonemap::mavlink
