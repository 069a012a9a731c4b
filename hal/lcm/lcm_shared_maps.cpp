#include "hal/lcm/lcm_shared_maps.hpp"

#include <lcm/lcm.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>

#include "hal/config/prior_map.hpp"
#include "hal/lcm/lcm_codec.hpp"
#include "zonemap_lcm/ins_state_t.hpp"

namespace zonemap::lcm_link {
namespace {

constexpr const char* kName = "shared maps over LCM";

// World metres of a frame about its origin <-> north, east, down.
Eigen::Vector3d to_ned(const Eigen::Vector3d& world, bool z_up) {
  return z_up ? Eigen::Vector3d(world.x(), -world.y(), -world.z()) : world;
}
Eigen::Vector3d from_ned(const Eigen::Vector3d& ned, bool z_up) {
  return to_ned(ned, z_up);  // the turn about north is its own inverse
}

double seconds_now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace

SharedMapDecoder::SharedMapDecoder(const SharedMapsConfig& config)
    : config_(config), own_(config.world_origin) {}

bool SharedMapDecoder::decode(const void* data, std::size_t size, SharedMapUpdate* out,
                              double now_s) {
  out->count = 0;
  if (size > 0x7FFFFFFF || !obstacle_map_counts_fit(data, size) ||
      message_.decode(data, 0, static_cast<int>(size)) < 0) {
    ++counters_.malformed;
    log_.log(hal::LogReason::kMalformedMessage, now_s, kName,
             "malformed obstacle_map_t (fingerprint or length): refused");
    return false;
  }
  if (message_.vehicle == config_.vehicle) {
    ++counters_.refused_own;
    log_.log(hal::LogReason::kWrongWorldFrame, now_s, kName,
             "a map this vehicle sent (its own channel subscribed?): refused");
    return false;
  }
  if (message_.frame != zonemap_lcm::ins_state_t::FRAME_NED &&
      message_.frame != zonemap_lcm::ins_state_t::FRAME_Z_UP) {
    ++counters_.refused_frame;
    log_.log(hal::LogReason::kWrongWorldFrame, now_s, kName,
             "a map in neither NED nor z up: refused");
    return false;
  }
  const Geodetic origin{message_.origin[0], message_.origin[1], message_.origin[2]};
  if (!message_.origin_valid || !(std::abs(origin.latitude_deg) <= 90.0) ||
      !(std::abs(origin.longitude_deg) <= 180.0) || !(std::abs(origin.height_m) <= 1.0e5)) {
    ++counters_.refused_no_origin;
    log_.log(hal::LogReason::kWrongWorldFrame, now_s, kName,
             "a map without a usable world origin (sender's vehicle.yaml world_origin): refused");
    return false;
  }
  const LocalTangentPlane sender(origin);
  const bool sender_z_up = message_.frame == zonemap_lcm::ins_state_t::FRAME_Z_UP;
  const std::size_t capacity = config_.max_boxes;
  for (const zonemap_lcm::obstacle_box_t& box : message_.boxes) {
    if (box.prior || box.kind != zonemap_lcm::obstacle_box_t::KIND_OBSTACLE) {
      ++counters_.boxes_not_measured;
      continue;
    }
    if (out->count == capacity) {
      ++counters_.boxes_over_capacity;
      continue;
    }
    if (take_box(box, sender_z_up, sender, &out->min[out->count], &out->max[out->count])) {
      ++out->count;
      ++counters_.boxes_taken;
    } else {
      ++counters_.boxes_rejected;
      std::snprintf(why_, sizeof why_,
                    "%s box %d: not a number, inside out, over 1 km wide, "
                    "below -1 km or over 1,000 km out: left out",
                    message_.vehicle.c_str(), box.id);
      log_.log(hal::LogReason::kRejectedItem, now_s, kName, why_);
    }
  }
  return true;
}

// The sender's box checked in its frame, its eight corners carried into this
// map's frame (exact ECEF), their bounds checked again.
bool SharedMapDecoder::take_box(const zonemap_lcm::obstacle_box_t& in, bool sender_z_up,
                                const LocalTangentPlane& sender, Eigen::Vector3d* min,
                                Eigen::Vector3d* max) {
  hal::PriorBox b;
  b.min = Eigen::Vector3d(in.min[0], in.min[1], in.min[2]);
  b.max = Eigen::Vector3d(in.max[0], in.max[1], in.max[2]);
  if (!hal::prior_box_problem(b, sender_z_up).empty()) return false;
  hal::PriorBox mine;
  mine.min = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  mine.max = -mine.min;
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3d p((corner & 1) ? b.max.x() : b.min.x(),
                            (corner & 2) ? b.max.y() : b.min.y(),
                            (corner & 4) ? b.max.z() : b.min.z());
    const Eigen::Vector3d here =
        from_ned(own_.to_ned(sender.to_geodetic(to_ned(p, sender_z_up))), config_.world_z_up);
    mine.min = mine.min.cwiseMin(here);
    mine.max = mine.max.cwiseMax(here);
  }
  if (!hal::prior_box_problem(mine, config_.world_z_up).empty()) return false;
  *min = mine.min;
  *max = mine.max;
  return true;
}

LcmSharedMapReceiver::LcmSharedMapReceiver(const SharedMapsConfig& config, SharedMapInbox& inbox)
    : config_(config), inbox_(inbox), decoder_(config) {
  for (std::size_t i = 0; i < config.channels.size() && i < 255; ++i) {
    subscriptions_.push_back({this, static_cast<std::uint8_t>(i + 1)});
  }
}

LcmSharedMapReceiver::~LcmSharedMapReceiver() {
  stop();
}

void LcmSharedMapReceiver::start() {
  if (thread_.started() || subscriptions_.empty()) return;
  thread_.start({"zonemap-maps-in"}, [this] { run(); });
}

void LcmSharedMapReceiver::stop() {
  stop_.store(true);
  if (thread_.started()) thread_.join();
}

void LcmSharedMapReceiver::on_message(const lcm_recv_buf_t* rbuf, const char*, void* user) {
  const auto* sub = static_cast<const Subscription*>(user);
  sub->self->receive(sub->source, rbuf->data, rbuf->data_size);
}

// A slot refused messages leave filled is kept for the next message.
void LcmSharedMapReceiver::receive(std::uint8_t source, const void* data, std::size_t size) {
  if (held_ == nullptr) held_ = inbox_.take_free();
  if (held_ == nullptr) {
    ++decoder_.counters().no_slot;  // the inbox counts it too (health)
    return;
  }
  held_->source = source;
  if (!decoder_.decode(data, size, held_, seconds_now())) return;
  ++decoder_.counters().maps;
  inbox_.post(held_);
  held_ = nullptr;
}

// Subscribes when the provider is up (retried with backoff), handles messages
// until stop(); each wait is bounded so that stop() is seen within 100 ms.
void LcmSharedMapReceiver::run() {
  LcmConnection connection(config_.url);
  lcm_t* subscribed = nullptr;
  const auto now_s = [] { return seconds_now(); };
  while (!stop_.load()) {
    lcm_t* lcm = connection.get(now_s());
    start_failures_.store(connection.start_failures(), std::memory_order_relaxed);
    if (lcm == nullptr) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      continue;
    }
    if (lcm != subscribed) {
      for (std::size_t i = 0; i < subscriptions_.size(); ++i) {
        lcm_subscribe(lcm, config_.channels[i].c_str(), &LcmSharedMapReceiver::on_message,
                      &subscriptions_[i]);
      }
      subscribed = lcm;
    }
    if (lcm_handle_timeout(lcm, 100) < 0) {
      connection.reset(now_s());
      subscribed = nullptr;
    }
  }
}

}  // namespace zonemap::lcm_link
