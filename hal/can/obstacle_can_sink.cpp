#include "hal/can/obstacle_can_sink.hpp"

namespace zonemap::can {

CanObstacleSink::CanObstacleSink(const std::string& interface, const ObstacleCanConfig& config,
                                 std::size_t max_boxes)
    : config_(config),
      encoder_(config),
      link_(interface, {}, config.extended_ids),
      transport_(&link_),
      order_(max_boxes),
      frames_(encoder_.frames_per_update()) {}

CanObstacleSink::CanObstacleSink(CanTransport& transport, const ObstacleCanConfig& config,
                                 std::size_t max_boxes)
    : CanObstacleSink("", config, max_boxes) {
  transport_ = &transport;
}

void CanObstacleSink::publish(const hal::ObstacleUpdate& update, double now_s) {
  if (now_s - last_s_ < 1.0 / config_.rate_hz) return;
  last_s_ = now_s;
  const std::size_t count = std::min(update.count, order_.size());
  const std::size_t n =
      encoder_.encode(update.boxes, count, update.world_T_body.translation(), update.world_z_up,
                      update.time_s, order_.data(), frames_.data());
  for (std::size_t i = 0; i < n; ++i) {
    if (transport_->send(frames_[i], now_s) != CanIo::kOk) {
      ++cut_short_;  // the rest of this update is not sent; the next one starts afresh
      return;
    }
  }
  ++updates_sent_;
}

void CanObstacleSink::report(hal::HealthSnapshot* h) const {
  const CanLinkCounters& c = link_.counters();
  h->add("can_out_updates", updates_sent_);
  h->add("can_out_updates_cut_short", cut_short_);
  h->add("can_out_tx_queue_full", c.tx_queue_full);
  h->add("can_out_link_down", c.tx_link_down);
  h->add("can_out_reopens", c.reopens);
  h->add("can_out_boxes_over_budget", encoder_.counters().boxes_over_budget);
}

}  // namespace zonemap::can
