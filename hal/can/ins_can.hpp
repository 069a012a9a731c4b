// INS solutions over CAN, two profiles selected in the configuration:
//  - SBG ECAN (SBG Systems' Ellipse & co.): EKF_INFO + EKF_QUAT + EKF_POS +
//    EKF_ALTITUDE form one solution (EKF_POS_ACC adds the accuracy); geodetic
//    position turned into local NED about a configured origin or the first fix.
//    IDs and byte order are settings (decoders in the wild disagree on the order).
//  - zonemap INS: a compact four-frame profile for INS units we program ourselves,
//    local NED in millimetres, all frames of a solution carry the same sequence byte.
// Layouts: the tables below, and config/can/*.dbc (a test checks they agree).
// Decoding is allocation-free; every frame that is not used is counted by reason.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>

#include "hal/can/can_frame.hpp"
#include "hal/can/can_signals.hpp"
#include "zonemap/common/geodetic.hpp"
#include "zonemap/pose/ins_gate.hpp"

namespace zonemap::can {

enum class InsCanProfile { kSbgEcan, kZonemapIns };
enum class InsTimeSource {
  kReceive,  // the receive timestamp of the frame completing the solution (host clock)
  kIns,      // the INS's own clock (logs whose depth frames are stamped with it)
};

struct InsCanConfig {
  InsCanProfile profile = InsCanProfile::kSbgEcan;
  bool little_endian = true;  // SBG only; the zonemap profile is little-endian
  // SBG IDs (vendor defaults); the zonemap profile uses base_id .. base_id + 3.
  std::uint32_t id_info = 0x130, id_quat = 0x131, id_pos = 0x134, id_altitude = 0x135,
                id_pos_acc = 0x136;
  std::uint32_t base_id = 0x300;
  bool extended_ids = false;
  InsTimeSource time_source = InsTimeSource::kReceive;
  // The frames of one solution arrive within this span (receive time), else the
  // set is mixed and refused.
  double max_set_span_s = 0.05;
  bool has_origin = false;  // false: the first valid fix is the NED origin
  Geodetic origin;
};

struct InsCanCounters {
  std::int64_t frames = 0;
  std::int64_t solutions = 0;
  std::int64_t ignored_id = 0;          // not one of the profile's IDs
  std::int64_t bad_dlc = 0;             // wrong data length for its ID
  std::int64_t bad_frame_type = 0;      // RTR, FD or wrong ID format
  std::int64_t orphan_parts = 0;        // a part with no open solution (e.g. its INFO was lost)
  std::int64_t incomplete_sets = 0;     // a new solution began before the last was complete
  std::int64_t mixed_sets = 0;          // a part twice, another sequence, or too far apart in time
  std::int64_t waiting_for_origin = 0;  // fixes before a valid position set the origin
};

// Message tables (IDs are the defaults; the decoder applies the configured ones).
std::span<const MessageSpec> sbg_messages(bool little_endian);
std::span<const MessageSpec> zonemap_ins_messages();

// SBG EKF_INFO solution status bits (SBG's public ECAN/sbgECom definition).
inline constexpr std::uint32_t kSbgSolutionModeMask = 0x0F;
inline constexpr std::uint32_t kSbgAttitudeValid = 1u << 4;
inline constexpr std::uint32_t kSbgHeadingValid = 1u << 5;
inline constexpr std::uint32_t kSbgVelocityValid = 1u << 6;
inline constexpr std::uint32_t kSbgPositionValid = 1u << 7;
// zonemap INS flag bits.
inline constexpr std::uint32_t kZmAttitudeValid = 1u << 0;
inline constexpr std::uint32_t kZmPositionValid = 1u << 1;

class InsCanDecoder {
 public:
  explicit InsCanDecoder(const InsCanConfig& config);

  // One received frame; true when it completed a solution, written to *out
  // (position in local NED metres, attitude body -> NED). Validity flags are
  // passed on for the InsGate to judge.
  bool feed(const CanFrame& frame, InsSolution* out);

  // The IDs to let through the socket's filters.
  std::span<const std::uint32_t> ids() const { return {ids_.data(), id_count_}; }
  const InsCanCounters& counters() const { return counters_; }
  const LocalTangentPlane& tangent_plane() const { return plane_; }
  const InsCanConfig& config() const { return config_; }

 private:
  bool feed_sbg(const CanFrame& frame, int part, InsSolution* out);
  bool feed_zonemap(const CanFrame& frame, int part, InsSolution* out);
  double ins_seconds_from_sbg(std::uint32_t micros);

  InsCanConfig config_;
  std::span<const MessageSpec> messages_;
  std::array<std::uint32_t, 5> ids_{};
  std::size_t id_count_ = 0;
  InsCanCounters counters_;
  LocalTangentPlane plane_;

  // The solution being assembled.
  bool open_ = false;
  unsigned parts_seen_ = 0;
  double set_start_s_ = 0.0;
  std::int64_t sequence_ = -1;
  std::uint32_t status_ = 0;
  double ins_time_s_ = 0.0;
  Eigen::Quaterniond attitude_ = Eigen::Quaterniond::Identity();
  Geodetic geodetic_;
  Eigen::Vector3d ned_ = Eigen::Vector3d::Zero();
  double position_sigma_m_ = -1.0;
  // SBG's 32-bit microsecond clock wraps every 71.6 minutes: unwrapped here.
  bool has_ins_clock_ = false;
  std::uint32_t last_micros_ = 0;
  std::int64_t micros_wraps_ = 0;
};

// Encoders (the INS side): for tests, the simulator's recorded flights and bench
// peers. Frames are written to `out` (room for 5); returns how many.
struct SbgSample {
  std::uint32_t time_us = 0;
  std::uint32_t solution_status = kSbgAttitudeValid | kSbgHeadingValid | kSbgPositionValid | 4;
  Eigen::Quaterniond attitude = Eigen::Quaterniond::Identity();  // body -> NED
  Geodetic position;
  double undulation_m = 0.0;
  double position_sigma_m = 0.5;
};
int encode_sbg(const SbgSample& sample, const InsCanConfig& config, double receive_time_s,
               CanFrame* out);

struct ZonemapInsSample {
  std::uint8_t sequence = 0;
  std::uint32_t flags = kZmAttitudeValid | kZmPositionValid;
  std::uint64_t time_us = 0;
  Eigen::Vector3d ned_m = Eigen::Vector3d::Zero();
  Eigen::Quaterniond attitude = Eigen::Quaterniond::Identity();
  double position_sigma_m = 0.1;
};
int encode_zonemap_ins(const ZonemapInsSample& sample, const InsCanConfig& config,
                       double receive_time_s, CanFrame* out);

}  // namespace zonemap::can
