// zonemap's outputs on LCM: the obstacle map (boxes with footprints), the
// 72-sector obstacle distances for autopilots, and the periodic health message.
// Messages are filled in storage sized at construction and encoded into reserved
// buffers; a provider that is down is retried with backoff (counted).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "hal/lcm/lcm_codec.hpp"
#include "hal/lcm/lcm_link.hpp"
#include "hal/output/obstacle_sink.hpp"
#include "zonemap/outputs/obstacle_distance.hpp"

namespace zonemap::lcm_link {

struct LcmOutputConfig {
  std::string url = "udpm://239.255.76.67:7667?ttl=0";
  std::string map_channel = "OBSTACLE_MAP";
  std::string distance_channel = "OBSTACLE_DIST";
  std::string health_channel = "ZONEMAP_HEALTH";
  std::string mount_channel = "ZONEMAP_MOUNT";  // camera_mount_t, with every health message
  // Said in every obstacle_map_t, so that another vehicle can take the map into
  // its own frame (vehicle.yaml `vehicle`, `world_origin`).
  std::string vehicle = "zonemap";
  bool has_world_origin = false;
  Geodetic world_origin;
  double rate_hz = 10.0;
  std::size_t max_boxes = 512;
  std::size_t max_rects_per_box = 64;
  SectorConfig sectors;
  // The mount body-frame outputs follow (the daemon sets it from camera.yaml).
  Eigen::Isometry3d body_T_camera = Eigen::Isometry3d::Identity();
  bool mount_configured = false;
};

class LcmObstacleSink final : public hal::ObstacleSink {
 public:
  explicit LcmObstacleSink(const LcmOutputConfig& config);
  // Messages to `out` instead of the provider at config.url.
  LcmObstacleSink(const LcmOutputConfig& config, LcmMessageOut& out);
  const char* name() const override { return "obstacles and health over LCM"; }
  void publish(const hal::ObstacleUpdate& update, double now_s) override;
  void publish_health(const hal::HealthSnapshot& health, double now_s) override;
  void report(hal::HealthSnapshot* health) const override;
  // The provider has started (always, with messages to an LcmMessageOut).
  bool ready() const { return publisher_ == nullptr || publisher_->ready(); }

 private:
  LcmObstacleSink(const LcmOutputConfig& config, LcmMessageOut* out);
  void send(const std::string& channel, const std::uint8_t* bytes, std::size_t size, double now_s);

  LcmOutputConfig config_;
  std::unique_ptr<LcmPublisher> publisher_;  // null with an LcmMessageOut
  LcmMessageOut* out_ = nullptr;
  ObstacleMapMessage map_;
  zonemap_lcm::obstacle_distance_t distance_;
  zonemap_lcm::health_t health_;
  zonemap_lcm::camera_mount_t mount_;
  bool world_z_up_ = true;            // of the last update
  std::vector<std::uint8_t> buffer_;  // distance and health messages
  double last_s_ = -1e300;
  std::int64_t encode_failures_ = 0;
  std::int64_t out_published_ = 0, out_failed_ = 0;  // through an LcmMessageOut
};

}  // namespace zonemap::lcm_link
