#include "hal/can/ins_can.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace zonemap::can {
namespace {

// Byte-aligned SBG field at byte `offset`, `bytes` long, in either byte order
// (Motorola start bit = the most significant bit: bit 7 of the first byte).
constexpr SignalSpec field(std::string_view name, int offset, int bytes, bool little, bool sign,
                           double factor, std::string_view unit) {
  return {name, little ? offset * 8 : offset * 8 + 7, bytes * 8, little, sign, factor, 0.0, unit};
}

constexpr double kQuatScale = 1.0 / 32767.0;

template <bool kLittle>
struct SbgTables {
  static constexpr SignalSpec info[] = {field("TIME_STAMP", 0, 4, kLittle, false, 1.0, "us"),
                                        field("SOLUTION_STATUS", 4, 4, kLittle, false, 1.0, "")};
  static constexpr SignalSpec quat[] = {field("Q0", 0, 2, kLittle, true, kQuatScale, ""),
                                        field("Q1", 2, 2, kLittle, true, kQuatScale, ""),
                                        field("Q2", 4, 2, kLittle, true, kQuatScale, ""),
                                        field("Q3", 6, 2, kLittle, true, kQuatScale, "")};
  static constexpr SignalSpec pos[] = {field("LATITUDE", 0, 4, kLittle, true, 1e-7, "deg"),
                                       field("LONGITUDE", 4, 4, kLittle, true, 1e-7, "deg")};
  static constexpr SignalSpec altitude[] = {field("ALTITUDE", 0, 4, kLittle, true, 1e-3, "m"),
                                            field("UNDULATION", 4, 2, kLittle, true, 0.005, "m")};
  static constexpr SignalSpec pos_acc[] = {field("LATITUDE_ACC", 0, 2, kLittle, false, 0.01, "m"),
                                           field("LONGITUDE_ACC", 2, 2, kLittle, false, 0.01, "m"),
                                           field("ALTITUDE_ACC", 4, 2, kLittle, false, 0.01, "m")};
  static constexpr MessageSpec messages[] = {{"EKF_INFO", 0x130, false, 8, info},
                                             {"EKF_QUAT", 0x131, false, 8, quat},
                                             {"EKF_POS", 0x134, false, 8, pos},
                                             {"EKF_ALTITUDE", 0x135, false, 6, altitude},
                                             {"EKF_POS_ACC", 0x136, false, 6, pos_acc}};
};

constexpr SignalSpec kSeq{"SEQUENCE", 0, 8, true, false, 1.0, 0.0, ""};
constexpr SignalSpec kZmTime[] = {kSeq,
                                  {"FLAGS", 8, 8, true, false, 1.0, 0.0, ""},
                                  {"TIME_US", 16, 48, true, false, 1.0, 0.0, "us"}};
constexpr SignalSpec kZmPosNe[] = {kSeq,
                                   {"NORTH", 8, 28, true, true, 0.001, 0.0, "m"},
                                   {"EAST", 36, 28, true, true, 0.001, 0.0, "m"}};
constexpr SignalSpec kZmPosD[] = {kSeq,
                                  {"DOWN", 8, 32, true, true, 0.001, 0.0, "m"},
                                  {"POS_SIGMA", 40, 16, true, false, 0.01, 0.0, "m"}};
// All four components (14 bits each): a derived w loses precision near 180 deg
// rotations (heading south), a 4th component costs nothing here.
constexpr double kQuat14 = 1.0 / 8191.0;
constexpr SignalSpec kZmAtt[] = {kSeq,
                                 {"QW", 8, 14, true, true, kQuat14, 0.0, ""},
                                 {"QX", 22, 14, true, true, kQuat14, 0.0, ""},
                                 {"QY", 36, 14, true, true, kQuat14, 0.0, ""},
                                 {"QZ", 50, 14, true, true, kQuat14, 0.0, ""}};
constexpr MessageSpec kZmMessages[] = {{"ZM_INS_TIME", 0x300, false, 8, kZmTime},
                                       {"ZM_INS_POS_NE", 0x301, false, 8, kZmPosNe},
                                       {"ZM_INS_POS_D", 0x302, false, 8, kZmPosD},
                                       {"ZM_INS_ATT", 0x303, false, 8, kZmAtt}};

// Parts of a solution, as bits of parts_seen_.
enum SbgPart { kInfo = 0, kQuat = 1, kPos = 2, kAlt = 3, kPosAcc = 4 };
constexpr unsigned kSbgComplete = (1u << kInfo) | (1u << kQuat) | (1u << kPos) | (1u << kAlt);
constexpr unsigned kZmComplete = 0xF;

double phys(const CanFrame& f, const MessageSpec& m, int signal) {
  return get_physical(f, m.signals[static_cast<std::size_t>(signal)]);
}

}  // namespace

std::span<const MessageSpec> sbg_messages(bool little_endian) {
  if (little_endian) return SbgTables<true>::messages;
  return SbgTables<false>::messages;
}

std::span<const MessageSpec> zonemap_ins_messages() {
  return kZmMessages;
}

InsCanDecoder::InsCanDecoder(const InsCanConfig& config) : config_(config) {
  if (config_.profile == InsCanProfile::kSbgEcan) {
    messages_ = sbg_messages(config_.little_endian);
    ids_ = {config_.id_info, config_.id_quat, config_.id_pos, config_.id_altitude,
            config_.id_pos_acc};
    id_count_ = 5;
  } else {
    messages_ = zonemap_ins_messages();
    for (std::uint32_t i = 0; i < 4; ++i) ids_[i] = config_.base_id + i;
    id_count_ = 4;
  }
  if (config_.has_origin) plane_ = LocalTangentPlane(config_.origin);
}

double InsCanDecoder::ins_seconds_from_sbg(std::uint32_t micros) {
  if (has_ins_clock_ && micros < last_micros_ && last_micros_ - micros > 0x80000000u) {
    ++micros_wraps_;
  }
  has_ins_clock_ = true;
  last_micros_ = micros;
  return (static_cast<double>(micros_wraps_) * 4294967296.0 + micros) * 1e-6;
}

bool InsCanDecoder::feed(const CanFrame& frame, InsSolution* out) {
  ++counters_.frames;
  int part = -1;
  for (std::size_t i = 0; i < id_count_; ++i) {
    if (frame.id == ids_[i]) part = static_cast<int>(i);
  }
  if (part < 0) {
    ++counters_.ignored_id;
    return false;
  }
  if (frame.remote || frame.fd || frame.extended != config_.extended_ids) {
    ++counters_.bad_frame_type;
    return false;
  }
  if (frame.dlc != messages_[static_cast<std::size_t>(part)].dlc) {
    ++counters_.bad_dlc;
    return false;
  }
  return config_.profile == InsCanProfile::kSbgEcan ? feed_sbg(frame, part, out)
                                                    : feed_zonemap(frame, part, out);
}

bool InsCanDecoder::feed_sbg(const CanFrame& f, int part, InsSolution* out) {
  const MessageSpec& m = messages_[static_cast<std::size_t>(part)];
  if (part == kPosAcc) {  // follows the solution it belongs to: kept for the next
    position_sigma_m_ = std::max({phys(f, m, 0), phys(f, m, 1), phys(f, m, 2)});
    return false;
  }
  if (part == kInfo) {
    if (open_) ++counters_.incomplete_sets;
    open_ = true;
    parts_seen_ = 1u << kInfo;
    set_start_s_ = f.time_s;
    ins_time_s_ = ins_seconds_from_sbg(static_cast<std::uint32_t>(get_raw(f, m.signals[0])));
    status_ = static_cast<std::uint32_t>(get_raw(f, m.signals[1]));
    return false;
  }
  if (!open_) {
    ++counters_.orphan_parts;
    return false;
  }
  if ((parts_seen_ & (1u << part)) || f.time_s - set_start_s_ > config_.max_set_span_s ||
      f.time_s < set_start_s_) {
    ++counters_.mixed_sets;  // two of a part, or parts of different solutions
    open_ = false;
    return false;
  }
  parts_seen_ |= 1u << part;
  if (part == kQuat) {
    attitude_ = Eigen::Quaterniond(phys(f, m, 0), phys(f, m, 1), phys(f, m, 2), phys(f, m, 3));
  } else if (part == kPos) {
    geodetic_.latitude_deg = phys(f, m, 0);
    geodetic_.longitude_deg = phys(f, m, 1);
  } else if (part == kAlt) {
    geodetic_.height_m = phys(f, m, 0) + phys(f, m, 1);  // MSL + undulation = ellipsoid
  }
  if (parts_seen_ != kSbgComplete) return false;
  open_ = false;

  InsSolution s;
  s.time_s = config_.time_source == InsTimeSource::kIns ? ins_time_s_ : f.time_s;
  s.attitude = attitude_;
  s.attitude_valid = (status_ & kSbgAttitudeValid) && (status_ & kSbgHeadingValid);
  s.position_valid = (status_ & kSbgPositionValid) != 0;
  s.position_sigma_m = position_sigma_m_;
  const bool plausible_fix =
      std::abs(geodetic_.latitude_deg) <= 90.0 && std::abs(geodetic_.longitude_deg) <= 180.0;
  if (!plane_.has_origin()) {
    if (!s.position_valid || !plausible_fix) {
      ++counters_.waiting_for_origin;
      return false;
    }
    plane_ = LocalTangentPlane(geodetic_);
  }
  s.position_m = plausible_fix
                     ? plane_.to_ned(geodetic_)
                     : Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  ++counters_.solutions;
  *out = s;
  return true;
}

bool InsCanDecoder::feed_zonemap(const CanFrame& f, int part, InsSolution* out) {
  const MessageSpec& m = messages_[static_cast<std::size_t>(part)];
  const std::int64_t sequence = get_raw(f, m.signals[0]);
  if (part == 0) {
    if (open_) ++counters_.incomplete_sets;
    open_ = true;
    parts_seen_ = 1u;
    sequence_ = sequence;
    set_start_s_ = f.time_s;
    status_ = static_cast<std::uint32_t>(get_raw(f, m.signals[1]));
    ins_time_s_ = static_cast<double>(get_raw(f, m.signals[2])) * 1e-6;
    return false;
  }
  if (!open_) {
    ++counters_.orphan_parts;
    return false;
  }
  if (sequence != sequence_ || (parts_seen_ & (1u << part)) ||
      f.time_s - set_start_s_ > config_.max_set_span_s || f.time_s < set_start_s_) {
    ++counters_.mixed_sets;
    open_ = false;
    return false;
  }
  parts_seen_ |= 1u << part;
  if (part == 1) {
    ned_.x() = phys(f, m, 1);
    ned_.y() = phys(f, m, 2);
  } else if (part == 2) {
    ned_.z() = phys(f, m, 1);
    position_sigma_m_ = phys(f, m, 2);
  } else {
    // Not normalised here: a corrupt frame shows as a non-unit norm the gate refuses.
    attitude_ = Eigen::Quaterniond(phys(f, m, 1), phys(f, m, 2), phys(f, m, 3), phys(f, m, 4));
  }
  if (parts_seen_ != kZmComplete) return false;
  open_ = false;
  InsSolution s;
  s.time_s = config_.time_source == InsTimeSource::kIns ? ins_time_s_ : f.time_s;
  s.position_m = ned_;
  s.attitude = attitude_;
  s.attitude_valid = (status_ & kZmAttitudeValid) != 0;
  s.position_valid = (status_ & kZmPositionValid) != 0;
  s.position_sigma_m = position_sigma_m_;
  ++counters_.solutions;
  *out = s;
  return true;
}

namespace {

CanFrame blank(std::uint32_t id, bool extended, std::uint8_t dlc, double time_s) {
  CanFrame f;
  f.id = id;
  f.extended = extended;
  f.dlc = dlc;
  f.time_s = time_s;
  return f;
}

}  // namespace

int encode_sbg(const SbgSample& sample, const InsCanConfig& config, double receive_time_s,
               CanFrame* out) {
  const std::span<const MessageSpec> m = sbg_messages(config.little_endian);
  const std::uint32_t ids[] = {config.id_info, config.id_quat, config.id_pos, config.id_altitude,
                               config.id_pos_acc};
  for (int i = 0; i < 5; ++i) {
    out[i] = blank(ids[i], config.extended_ids, m[static_cast<std::size_t>(i)].dlc,
                   receive_time_s + i * 1e-4);
  }
  set_raw(&out[0], m[0].signals[0], sample.time_us);
  set_raw(&out[0], m[0].signals[1], sample.solution_status);
  Eigen::Quaterniond q = sample.attitude.normalized();
  set_physical(&out[1], m[1].signals[0], q.w());
  set_physical(&out[1], m[1].signals[1], q.x());
  set_physical(&out[1], m[1].signals[2], q.y());
  set_physical(&out[1], m[1].signals[3], q.z());
  set_physical(&out[2], m[2].signals[0], sample.position.latitude_deg);
  set_physical(&out[2], m[2].signals[1], sample.position.longitude_deg);
  set_physical(&out[3], m[3].signals[0], sample.position.height_m - sample.undulation_m);
  set_physical(&out[3], m[3].signals[1], sample.undulation_m);
  for (int s = 0; s < 3; ++s) set_physical(&out[4], m[4].signals[s], sample.position_sigma_m);
  return 5;
}

int encode_zonemap_ins(const ZonemapInsSample& sample, const InsCanConfig& config,
                       double receive_time_s, CanFrame* out) {
  const std::span<const MessageSpec> m = zonemap_ins_messages();
  for (std::uint32_t i = 0; i < 4; ++i) {
    out[i] = blank(config.base_id + i, config.extended_ids, 8, receive_time_s + i * 1e-4);
    set_raw(&out[i], m[i].signals[0], sample.sequence);
  }
  set_raw(&out[0], m[0].signals[1], sample.flags);
  set_raw(&out[0], m[0].signals[2], static_cast<std::int64_t>(sample.time_us));
  set_physical(&out[1], m[1].signals[1], sample.ned_m.x());
  set_physical(&out[1], m[1].signals[2], sample.ned_m.y());
  set_physical(&out[2], m[2].signals[1], sample.ned_m.z());
  set_physical(&out[2], m[2].signals[2], sample.position_sigma_m);
  const Eigen::Quaterniond q = sample.attitude.normalized();
  set_physical(&out[3], m[3].signals[1], q.w());
  set_physical(&out[3], m[3].signals[2], q.x());
  set_physical(&out[3], m[3].signals[3], q.y());
  set_physical(&out[3], m[3].signals[4], q.z());
  return 4;
}

}  // namespace zonemap::can
