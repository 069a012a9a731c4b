// MAVLink 2 OBSTACLE_DISTANCE (message 330) from zonemap's sector distances, so an
// existing autopilot (PX4 collision prevention, ArduPilot proximity) can avoid
// what zonemap sees; OBSTACLE_DISTANCE_3D (ardupilotmega 11037) for ArduPilot's
// obstacle database; HEARTBEAT (0) so routers and ground stations find us. Written from the public
// message definition: payload fields in MAVLink wire order (by type size, extensions last),
// trailing zero bytes truncated, X.25 CRC over header + payload + CRC_EXTRA.
#pragma once

#include <cstddef>
#include <cstdint>

#include "zonemap/outputs/obstacle_distance.hpp"

namespace zonemap::mavlink {

inline constexpr std::uint32_t kObstacleDistanceId = 330;
inline constexpr std::uint8_t kObstacleDistanceCrcExtra = 23;
inline constexpr std::size_t kObstacleDistancePayload = 167;  // with extensions
inline constexpr std::size_t kMaxFrameBytes = 10 + kObstacleDistancePayload + 2;
inline constexpr std::uint8_t kSensorTypeUnknown = 4;  // MAV_DISTANCE_SENSOR_UNKNOWN
inline constexpr std::uint8_t kFrameBodyFrd = 12;      // MAV_FRAME_BODY_FRD

inline constexpr std::uint32_t kObstacleDistance3dId = 11037;
inline constexpr std::uint8_t kObstacleDistance3dCrcExtra = 130;
inline constexpr std::size_t kObstacleDistance3dPayload = 28;
inline constexpr std::uint32_t kHeartbeatId = 0;
inline constexpr std::uint8_t kHeartbeatCrcExtra = 50;
inline constexpr std::size_t kHeartbeatPayload = 9;
inline constexpr std::uint8_t kTypeOnboardController = 18;  // MAV_TYPE_ONBOARD_CONTROLLER
inline constexpr std::uint8_t kAutopilotInvalid = 8;        // MAV_AUTOPILOT_INVALID
inline constexpr std::uint8_t kStateActive = 4;             // MAV_STATE_ACTIVE
inline constexpr std::uint8_t kMavlinkVersion = 3;

struct LinkIds {
  std::uint8_t system_id = 1;
  std::uint8_t component_id = 195;  // MAV_COMP_ID_PATHPLANNER
};

std::uint16_t crc_x25(const std::uint8_t* data, std::size_t size, std::uint16_t crc = 0xFFFF);

// A MAVLink 2 frame around `payload` (trailing zeros truncated, unsigned) into buf
// (room for 12 + size); returns its length.
std::size_t encode_frame(std::uint32_t message_id, std::uint8_t crc_extra,
                         const std::uint8_t* payload, std::size_t size, const LinkIds& ids,
                         std::uint8_t sequence, std::uint8_t* buf);

// Encodes one frame into buf (room for kMaxFrameBytes); returns its length.
std::size_t encode_obstacle_distance(const ObstacleDistances& d, std::uint64_t time_usec,
                                     const LinkIds& ids, std::uint8_t sequence, std::uint8_t* buf);

// One OBSTACLE_DISTANCE_3D: an obstacle's nearest point in BODY_FRD, metres.
struct Obstacle3d {
  std::uint32_t time_boot_ms = 0;  // one scan: every message of an update shares it
  std::uint16_t obstacle_id = 0;
  float x = 0, y = 0, z = 0;
  float min_distance = 0, max_distance = 0;
};
// An OBSTACLE_DISTANCE_3D obstacle_id: a box's point in one of ArduPilot's eight
// sectors, the feature id's low 13 bits and the sector (stable while the feature
// lives; distinct within a scan); UINT16_MAX for "unknown" (an empty scan).
inline constexpr std::uint16_t kUnknownObstacleId = 0xFFFF;
inline std::uint16_t obstacle_id_3d(std::uint32_t feature_id, int wedge) {
  return static_cast<std::uint16_t>(((feature_id % 8191u) << 3) |
                                    static_cast<std::uint32_t>(wedge & 7));
}
std::size_t encode_obstacle_distance_3d(const Obstacle3d& o, const LinkIds& ids,
                                        std::uint8_t sequence, std::uint8_t* buf);
std::size_t encode_heartbeat(const LinkIds& ids, std::uint8_t sequence, std::uint8_t* buf);

// The receiver's side, for tests and tools: checks the frame (start byte, length,
// message id, CRC) and unpacks it. False when anything is wrong.
struct DecodedObstacleDistance {
  std::uint64_t time_usec = 0;
  std::uint8_t sensor_type = 0, increment = 0, frame = 0;
  std::uint16_t distances[kObstacleSectors] = {};
  std::uint16_t min_distance = 0, max_distance = 0;
  float increment_f = 0.0f, angle_offset = 0.0f;
  std::uint8_t sequence = 0, system_id = 0, component_id = 0;
};
bool decode_obstacle_distance(const std::uint8_t* buf, std::size_t size,
                              DecodedObstacleDistance* out);

}  // namespace zonemap::mavlink
