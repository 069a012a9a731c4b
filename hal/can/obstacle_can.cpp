#include "hal/can/obstacle_can.hpp"

#include <algorithm>
#include <cmath>

namespace zonemap::can {
namespace {

constexpr SignalSpec kBegin[] = {{"GENERATION", 0, 16, true, false, 1.0, 0.0, ""},
                                 {"BOX_COUNT", 16, 16, true, false, 1.0, 0.0, ""},
                                 {"ANCHOR_X", 32, 16, true, true, 100.0, 0.0, "m"},
                                 {"ANCHOR_Y", 48, 16, true, true, 100.0, 0.0, "m"}};
constexpr SignalSpec kBoxMin[] = {{"BOX_ID", 0, 15, true, false, 1.0, 0.0, ""},
                                  {"GROUND", 15, 1, true, false, 1.0, 0.0, ""},
                                  {"MIN_X", 16, 16, true, true, 0.1, 0.0, "m"},
                                  {"MIN_Y", 32, 16, true, true, 0.1, 0.0, "m"},
                                  {"MIN_Z", 48, 16, true, true, 0.1, 0.0, "m"}};
constexpr SignalSpec kBoxMax[] = {{"BOX_ID", 0, 15, true, false, 1.0, 0.0, ""},
                                  {"GROUND", 15, 1, true, false, 1.0, 0.0, ""},
                                  {"MAX_X", 16, 16, true, true, 0.1, 0.0, "m"},
                                  {"MAX_Y", 32, 16, true, true, 0.1, 0.0, "m"},
                                  {"MAX_Z", 48, 16, true, true, 0.1, 0.0, "m"}};
constexpr SignalSpec kEnd[] = {{"GENERATION", 0, 16, true, false, 1.0, 0.0, ""},
                               {"BOX_COUNT", 16, 16, true, false, 1.0, 0.0, ""},
                               {"TOTAL_BOXES", 32, 16, true, false, 1.0, 0.0, ""},
                               {"FLAGS", 48, 8, true, false, 1.0, 0.0, ""}};
constexpr SignalSpec kBoxAge[] = {{"BOX_ID", 0, 15, true, false, 1.0, 0.0, ""},
                                  {"GROUND", 15, 1, true, false, 1.0, 0.0, ""},
                                  {"AGE", 16, 16, true, false, 0.1, 0.0, "s"},
                                  {"PRIOR", 32, 1, true, false, 1.0, 0.0, ""}};
constexpr MessageSpec kMessages[] = {{"ZM_OBST_BEGIN", 0x320, false, 8, kBegin},
                                     {"ZM_OBST_BOX_MIN", 0x321, false, 8, kBoxMin},
                                     {"ZM_OBST_BOX_MAX", 0x322, false, 8, kBoxMax},
                                     {"ZM_OBST_END", 0x323, false, 8, kEnd},
                                     {"ZM_OBST_BOX_AGE", 0x324, false, 8, kBoxAge}};
constexpr double kReachM = 3276.0;  // what 16 bits of decimetres hold around the anchor

CanFrame blank(std::uint32_t id, bool extended, double time_s) {
  CanFrame f;
  f.id = id;
  f.extended = extended;
  f.dlc = 8;
  f.time_s = time_s;
  return f;
}

double horizontal_distance(const ObstacleBox& box, const Eigen::Vector3d& p) {
  const Eigen::Vector3d closest = p.cwiseMax(box.min).cwiseMin(box.max);
  return (closest - p).norm();
}

}  // namespace

std::span<const MessageSpec> obstacle_messages() {
  return kMessages;
}

ObstacleCanEncoder::ObstacleCanEncoder(const ObstacleCanConfig& config) : config_(config) {
  const double per_update = config.max_frames_per_s / std::max(config.rate_hz, 1e-3);
  frames_per_update_ = static_cast<std::size_t>(std::clamp(per_update, 2.0, 65535.0));
}

std::size_t ObstacleCanEncoder::encode(const ObstacleBox* boxes, std::size_t count,
                                       const Eigen::Vector3d& vehicle, bool world_z_up,
                                       double time_s, std::uint32_t* order, CanFrame* out) {
  ++generation_;
  ++counters_.updates;
  std::size_t eligible = 0;
  for (std::size_t i = 0; i < count; ++i) {
    if (config_.include_ground || boxes[i].kind == FeatureKind::kObstacle) {
      order[eligible++] = static_cast<std::uint32_t>(i);
    }
  }
  // The anchor: the vehicle's position rounded to 100 m.
  const Eigen::Vector2d anchor(std::round(vehicle.x() / 100.0) * 100.0,
                               std::round(vehicle.y() / 100.0) * 100.0);
  const std::size_t room = (frames_per_update_ - 2) / 2;
  std::uint8_t flags = world_z_up ? 0 : kObstacleWorldZDown;
  if (eligible > room) {
    // Nearest first: only the `room` nearest need ordering.
    std::partial_sort(order, order + room, order + eligible, [&](std::uint32_t a, std::uint32_t b) {
      return horizontal_distance(boxes[a], vehicle) < horizontal_distance(boxes[b], vehicle);
    });
    counters_.boxes_over_budget += static_cast<std::int64_t>(eligible - room);
    flags |= kObstacleUpdateTruncated;
  }
  const std::size_t sending = std::min(eligible, room);
  std::size_t n = 1;  // out[0] is BEGIN, written once the count is known
  std::size_t sent = 0;
  for (std::size_t k = 0; k < sending; ++k) {
    const ObstacleBox& box = boxes[order[k]];
    const double age_s = time_s - box.last_seen_s;
    // A prior box says so from the first update on, whatever its age.
    const bool report_age = age_s > kObstacleAgeReportedS || box.prior;
    if (n + 2 + (report_age ? 1 : 0) + 1 > frames_per_update_) {  // the AGE frames used it up
      counters_.boxes_over_budget += static_cast<std::int64_t>(sending - k);
      flags |= kObstacleUpdateTruncated;
      break;
    }
    const Eigen::Vector2d lo = box.min.head<2>() - anchor, hi = box.max.head<2>() - anchor;
    if (lo.cwiseAbs().maxCoeff() > kReachM || hi.cwiseAbs().maxCoeff() > kReachM ||
        std::abs(box.min.z()) > kReachM || std::abs(box.max.z()) > kReachM) {
      ++counters_.boxes_out_of_range;
      flags |= kObstacleUpdateOutOfRange;
      continue;
    }
    const std::int64_t id = box.id & 0x7FFF;
    const std::int64_t ground = box.kind == FeatureKind::kGround ? 1 : 0;
    CanFrame& a = out[n++] = blank(config_.base_id + 1, config_.extended_ids, time_s);
    CanFrame& b = out[n++] = blank(config_.base_id + 2, config_.extended_ids, time_s);
    set_raw(&a, kBoxMin[0], id);
    set_raw(&a, kBoxMin[1], ground);
    set_raw(&b, kBoxMax[0], id);
    set_raw(&b, kBoxMax[1], ground);
    // Round outwards so the box sent always holds the obstacle.
    const double lo3[3] = {lo.x(), lo.y(), box.min.z()}, hi3[3] = {hi.x(), hi.y(), box.max.z()};
    for (int axis = 0; axis < 3; ++axis) {
      set_raw(&a, kBoxMin[2 + axis], static_cast<std::int64_t>(std::floor(lo3[axis] * 10.0)));
      set_raw(&b, kBoxMax[2 + axis], static_cast<std::int64_t>(std::ceil(hi3[axis] * 10.0)));
    }
    if (report_age) {
      CanFrame& c = out[n++] = blank(config_.base_id + 4, config_.extended_ids, time_s);
      set_raw(&c, kBoxAge[0], id);
      set_raw(&c, kBoxAge[1], ground);
      set_raw(&c, kBoxAge[2],
              static_cast<std::int64_t>(std::clamp(std::floor(age_s * 10.0), 0.0, 65535.0)));
      set_raw(&c, kBoxAge[3], box.prior ? 1 : 0);
      ++counters_.ages_sent;
    }
    ++sent;
  }
  out[0] = blank(config_.base_id, config_.extended_ids, time_s);
  set_raw(&out[0], kBegin[0], generation_);
  set_raw(&out[0], kBegin[1], static_cast<std::int64_t>(sent));
  set_raw(&out[0], kBegin[2], static_cast<std::int64_t>(anchor.x() / 100.0));
  set_raw(&out[0], kBegin[3], static_cast<std::int64_t>(anchor.y() / 100.0));
  CanFrame& end = out[n++] = blank(config_.base_id + 3, config_.extended_ids, time_s);
  set_raw(&end, kEnd[0], generation_);
  set_raw(&end, kEnd[1], static_cast<std::int64_t>(sent));
  set_raw(&end, kEnd[2], static_cast<std::int64_t>(std::min<std::size_t>(eligible, 65535)));
  set_raw(&end, kEnd[3], flags);
  counters_.boxes_sent += static_cast<std::int64_t>(sent);
  return n;
}

bool ObstacleCanDecoder::feed(const CanFrame& f) {
  if (f.dlc != 8 || f.id < base_id_ || f.id > base_id_ + 4) return false;
  const std::uint32_t kind = f.id - base_id_;
  if (kind == 4) {
    // The age of the box just completed (BOX_MIN + BOX_MAX of the same id).
    if (!open_) return false;
    if (have_min_ || count_ == 0 ||
        static_cast<std::uint16_t>(get_raw(f, kBoxAge[0])) != boxes_[count_ - 1].id) {
      ++broken_;
      open_ = false;
      return false;
    }
    boxes_[count_ - 1].age_s = get_physical(f, kBoxAge[2]);
    boxes_[count_ - 1].prior = get_raw(f, kBoxAge[3]) != 0;
    return false;
  }
  if (kind == 0) {
    if (open_) ++broken_;
    open_ = true;
    count_ = 0;
    have_min_ = false;
    generation_ = static_cast<std::uint16_t>(get_raw(f, kBegin[0]));
    announced_ = static_cast<int>(get_raw(f, kBegin[1]));
    anchor_ = {get_physical(f, kBegin[2]), get_physical(f, kBegin[3])};
    return false;
  }
  if (!open_) return false;
  if (kind == 1) {
    if (have_min_ || count_ >= kMaxBoxes) {
      ++broken_;
      open_ = false;
      return false;
    }
    DecodedObstacleBox& box = boxes_[count_];
    box.id = static_cast<std::uint16_t>(get_raw(f, kBoxMin[0]));
    box.ground = get_raw(f, kBoxMin[1]) != 0;
    box.min = {get_physical(f, kBoxMin[2]) + anchor_.x(), get_physical(f, kBoxMin[3]) + anchor_.y(),
               get_physical(f, kBoxMin[4])};
    have_min_ = true;
    return false;
  }
  if (kind == 2) {
    if (!have_min_ || static_cast<std::uint16_t>(get_raw(f, kBoxMax[0])) != boxes_[count_].id) {
      ++broken_;
      open_ = false;
      return false;
    }
    boxes_[count_].max = {get_physical(f, kBoxMax[2]) + anchor_.x(),
                          get_physical(f, kBoxMax[3]) + anchor_.y(), get_physical(f, kBoxMax[4])};
    ++count_;
    have_min_ = false;
    return false;
  }
  open_ = false;
  const bool complete = static_cast<std::uint16_t>(get_raw(f, kEnd[0])) == generation_ &&
                        static_cast<int>(get_raw(f, kEnd[1])) == announced_ &&
                        static_cast<int>(count_) == announced_ && !have_min_;
  if (!complete) {
    ++broken_;
    return false;
  }
  total_ = static_cast<int>(get_raw(f, kEnd[2]));
  flags_ = static_cast<std::uint8_t>(get_raw(f, kEnd[3]));
  return true;
}

}  // namespace zonemap::can
