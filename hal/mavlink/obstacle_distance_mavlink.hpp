// MAVLink 2 OBSTACLE_DISTANCE (message 330) from zonemap's sector distances, so an
// existing autopilot (PX4 collision prevention, ArduPilot proximity) can avoid
// what zonemap sees. Written from the public message definition: payload fields in
// MAVLink wire order (by type size, extensions last), trailing zero bytes
// truncated, X.25 CRC over header + payload + CRC_EXTRA.
#pragma once

#include <cstddef>
#include <cstdint>

#include "zonemap/obstacle_distance.hpp"

namespace zonemap::mavlink {

inline constexpr std::uint32_t kObstacleDistanceId = 330;
inline constexpr std::uint8_t kObstacleDistanceCrcExtra = 23;
inline constexpr std::size_t kObstacleDistancePayload = 167;  // with extensions
inline constexpr std::size_t kMaxFrameBytes = 10 + kObstacleDistancePayload + 2;
inline constexpr std::uint8_t kSensorTypeUnknown = 4;  // MAV_DISTANCE_SENSOR_UNKNOWN
inline constexpr std::uint8_t kFrameBodyFrd = 12;      // MAV_FRAME_BODY_FRD

struct LinkIds {
  std::uint8_t system_id = 1;
  std::uint8_t component_id = 195;  // MAV_COMP_ID_PATHPLANNER
};

std::uint16_t crc_x25(const std::uint8_t* data, std::size_t size, std::uint16_t crc = 0xFFFF);

// Encodes one frame into buf (room for kMaxFrameBytes); returns its length.
std::size_t encode_obstacle_distance(const ObstacleDistances& d, std::uint64_t time_usec,
                                     const LinkIds& ids, std::uint8_t sequence, std::uint8_t* buf);

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
