#include "hal/lcm/lcm_sinks.hpp"

#include <cmath>

namespace zonemap::lcm_link {

LcmObstacleSink::LcmObstacleSink(const LcmOutputConfig& config) : LcmObstacleSink(config, nullptr) {
  publisher_ = std::make_unique<LcmPublisher>(config.url, true);
  out_ = publisher_.get();
}

LcmObstacleSink::LcmObstacleSink(const LcmOutputConfig& config, LcmMessageOut& out)
    : LcmObstacleSink(config, &out) {}

LcmObstacleSink::LcmObstacleSink(const LcmOutputConfig& config, LcmMessageOut* out)
    : config_(config), out_(out), map_(config.max_boxes, config.max_rects_per_box) {
  map_.set_sender(config.vehicle, config.has_world_origin ? &config.world_origin : nullptr);
  health_.num_counters = hal::HealthSnapshot::kMaxNamed;
  health_.counter_names.assign(hal::HealthSnapshot::kMaxNamed, std::string(63, 'x'));
  health_.counter_values.assign(hal::HealthSnapshot::kMaxNamed, 0);
  buffer_.resize(
      static_cast<std::size_t>(std::max(health_.getEncodedSize(), distance_.getEncodedSize())));
  for (auto& name : health_.counter_names) name.clear();  // keeps the capacity
  const Eigen::Quaterniond q(config.body_T_camera.linear());
  mount_.body_frame = 12;  // MAV_FRAME_BODY_FRD
  mount_.configured = config.mount_configured;
  const double qv[4] = {q.w(), q.x(), q.y(), q.z()};
  for (int i = 0; i < 4; ++i) mount_.body_q_camera[i] = qv[i];
  for (int i = 0; i < 3; ++i) mount_.body_t_camera[i] = config.body_T_camera.translation()[i];
}

void LcmObstacleSink::publish(const hal::ObstacleUpdate& update, double now_s) {
  if (now_s - last_s_ < 1.0 / config_.rate_hz) return;
  last_s_ = now_s;
  const auto utime = static_cast<std::int64_t>(std::llround(update.time_s * 1e6));
  world_z_up_ = update.world_z_up;
  map_.fill(utime, update.world_T_body.translation(), update.world_z_up, update.boxes, update.count,
            update.rects, update.rect_offsets, update.rect_counts);
  const std::uint8_t* bytes = nullptr;
  const std::size_t size = map_.encode(&bytes);
  if (size == 0) {
    ++encode_failures_;
  } else {
    send(config_.map_channel, bytes, size, now_s);
  }
  const ObstacleDistances d =
      obstacle_distances(update.boxes, update.count, update.footprints(), update.world_T_body,
                         update.world_z_up, config_.sectors, update.sectors_observed);
  distance_ = to_message(d, utime);
  const int n = distance_.encode(buffer_.data(), 0, static_cast<int>(buffer_.size()));
  if (n <= 0) {
    ++encode_failures_;
  } else {
    send(config_.distance_channel, buffer_.data(), static_cast<std::size_t>(n), now_s);
  }
}

void LcmObstacleSink::publish_health(const hal::HealthSnapshot& h, double now_s) {
  zonemap_lcm::health_t& m = health_;
  m.utime = static_cast<std::int64_t>(std::llround(h.time_s * 1e6));
  m.uptime_us = static_cast<std::int64_t>(std::llround(h.uptime_s * 1e6));
  m.frames_in = h.frames_in;
  m.frames_mapped = h.frames_mapped;
  m.frames_rejected = h.frames_rejected;
  m.frames_skipped_no_pose = h.frames_skipped_no_pose;
  m.frames_dropped = h.frames_dropped();
  m.deadline_misses = h.deadline_misses;
  m.poses_in = h.poses_in;
  m.poses_rejected = h.poses_rejected;
  m.heap_allocations_after_init = h.heap_allocations_after_init;
  m.mapping_ms_p50 = static_cast<float>(h.mapping_ms_p50);
  m.mapping_ms_p99 = static_cast<float>(h.mapping_ms_p99);
  m.end_to_end_ms_p50 = static_cast<float>(h.end_to_end_ms_p50);
  m.end_to_end_ms_p99 = static_cast<float>(h.end_to_end_ms_p99);
  m.end_to_end_ms_p999 = static_cast<float>(h.end_to_end_ms_p999);
  m.static_memory_bytes = h.static_memory_bytes;
  m.rss_bytes = h.rss_bytes;
  m.zones_allocated = h.zones_allocated;
  m.features = h.features;
  m.num_counters = h.named;
  for (int i = 0; i < h.named; ++i) {
    // Within the capacity reserved at construction: no allocation.
    m.counter_names[static_cast<std::size_t>(i)].assign(h.names[i] != nullptr ? h.names[i] : "?");
    m.counter_values[static_cast<std::size_t>(i)] = h.values[i];
  }
  const int n = m.encode(buffer_.data(), 0, static_cast<int>(buffer_.size()));
  if (n <= 0) {
    ++encode_failures_;
    return;
  }
  send(config_.health_channel, buffer_.data(), static_cast<std::size_t>(n), now_s);
  // The frames and the mount, beside the health: a consumer can tell a wrong mount.
  mount_.utime = m.utime;
  mount_.world_frame =
      world_z_up_ ? zonemap_lcm::ins_state_t::FRAME_Z_UP : zonemap_lcm::ins_state_t::FRAME_NED;
  const int k = mount_.encode(buffer_.data(), 0, static_cast<int>(buffer_.size()));
  if (k <= 0) {
    ++encode_failures_;
    return;
  }
  send(config_.mount_channel, buffer_.data(), static_cast<std::size_t>(k), now_s);
}

void LcmObstacleSink::send(const std::string& channel, const std::uint8_t* bytes, std::size_t size,
                           double now_s) {
  if (out_->publish(channel.c_str(), bytes, size, now_s)) {
    ++out_published_;
  } else {
    ++out_failed_;
  }
}

void LcmObstacleSink::report(hal::HealthSnapshot* h) const {
  if (publisher_ == nullptr) {
    h->add("lcm_out_published", out_published_);
    h->add("lcm_out_failed", out_failed_ + encode_failures_);
    return;
  }
  h->add("lcm_out_published", publisher_->published());
  h->add("lcm_out_failed", publisher_->failed() + encode_failures_);
  h->add("lcm_out_provider_down", publisher_->provider_down());
  h->add("lcm_out_start_failures", publisher_->start_failures());
}

}  // namespace zonemap::lcm_link
