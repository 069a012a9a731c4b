// MAVLink frames from the autopilot, as it sends them to its companion computer:
// MAVLink 2 (0xFD) and 1 (0xFE) framing checked (length, X.25 CRC with the
// message's CRC_EXTRA), truncated payloads zero-extended; a datagram may hold
// several frames. Only the messages zonemap reads are known; any other frame is
// skipped by its length, not counted as bad. Pure: no sockets, no allocation.
#pragma once

#include <cstddef>
#include <cstdint>

namespace zonemap::mavlink {

inline constexpr std::uint32_t kSysStatusId = 1;
inline constexpr std::uint32_t kAttitudeQuaternionId = 31;
inline constexpr std::uint32_t kLocalPositionNedId = 32;
inline constexpr std::uint32_t kTimesyncId = 111;
inline constexpr std::uint8_t kTimesyncCrcExtra = 34;
inline constexpr std::size_t kTimesyncPayload = 18;             // with extensions
inline constexpr std::uint32_t kSysStatusProximity = 1u << 26;  // MAV_SYS_STATUS_SENSOR_PROXIMITY
inline constexpr std::uint8_t kComponentAutopilot = 1;          // MAV_COMP_ID_AUTOPILOT1

struct InboundFrame {
  std::uint32_t message_id = 0;
  std::uint8_t system_id = 0, component_id = 0;
  std::uint8_t payload[255] = {};  // zero-extended to the message's full length
};

enum class FrameStatus {
  kKnown,      // a message zonemap reads, CRC good: `frame` filled
  kOther,      // a well-formed frame of a message zonemap does not read
  kBad,        // bad start byte, length or CRC: the rest of the datagram is dropped
  kTruncated,  // the datagram ends inside the frame
};

// Reads the frame starting at `data`; *used is its length in bytes (0 when bad).
FrameStatus read_frame(const std::uint8_t* data, std::size_t size, InboundFrame* frame,
                       std::size_t* used);

struct Heartbeat {
  std::uint8_t type = 0, autopilot = 0, system_status = 0;
};
Heartbeat heartbeat_of(const InboundFrame& frame);

struct SysStatus {
  std::uint32_t present = 0, enabled = 0, health = 0;
};
SysStatus sys_status_of(const InboundFrame& frame);

// ATTITUDE_QUATERNION: the vehicle's attitude, NED <- FRD body (w, x, y, z).
struct AttitudeQuaternion {
  std::uint32_t time_boot_ms = 0;
  float w = 1, x = 0, y = 0, z = 0;
};
AttitudeQuaternion attitude_quaternion_of(const InboundFrame& frame);

// LOCAL_POSITION_NED: the EKF's position about its origin, metres.
struct LocalPositionNed {
  std::uint32_t time_boot_ms = 0;
  float north = 0, east = 0, down = 0;
};
LocalPositionNed local_position_ned_of(const InboundFrame& frame);

// TIMESYNC: tc1 = 0 asks; an answer carries the responder's time in tc1 and the
// asker's ts1 back (nanoseconds).
struct Timesync {
  std::int64_t tc1 = 0, ts1 = 0;
};
Timesync timesync_of(const InboundFrame& frame);
std::size_t encode_timesync(const Timesync& t, std::uint8_t system_id, std::uint8_t component_id,
                            std::uint8_t sequence, std::uint8_t* buf);

}  // namespace zonemap::mavlink
