#include "hal/mavlink/obstacle_distance_mavlink.hpp"

#include <cstring>

namespace zonemap::mavlink {
namespace {

void put(std::uint8_t* p, std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
std::uint64_t get(const std::uint8_t* p, int bytes) {
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v |= static_cast<std::uint64_t>(p[i]) << (8 * i);
  return v;
}
std::uint32_t float_bits(float f) {
  std::uint32_t bits;
  std::memcpy(&bits, &f, sizeof bits);
  return bits;
}
float bits_float(std::uint32_t bits) {
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

// Wire offsets: time_usec, distances[72], min, max, sensor_type, increment |
// extensions: increment_f, angle_offset, frame.
constexpr std::size_t kTime = 0, kDistances = 8, kMin = 152, kMax = 154, kSensor = 156,
                      kIncrement = 157, kIncrementF = 158, kAngleOffset = 162, kFrame = 166;

}  // namespace

std::size_t encode_frame(std::uint32_t message_id, std::uint8_t crc_extra,
                         const std::uint8_t* payload, std::size_t size, const LinkIds& ids,
                         std::uint8_t sequence, std::uint8_t* buf) {
  std::size_t length = size;
  while (length > 1 && payload[length - 1] == 0) --length;  // MAVLink 2 truncation
  buf[0] = 0xFD;
  buf[1] = static_cast<std::uint8_t>(length);
  buf[2] = 0;  // incompat flags (unsigned)
  buf[3] = 0;  // compat flags
  buf[4] = sequence;
  buf[5] = ids.system_id;
  buf[6] = ids.component_id;
  put(buf + 7, message_id, 3);
  std::memcpy(buf + 10, payload, length);
  std::uint16_t crc = crc_x25(buf + 1, 9 + length);
  crc = crc_x25(&crc_extra, 1, crc);
  put(buf + 10 + length, crc, 2);
  return 12 + length;
}

std::uint16_t crc_x25(const std::uint8_t* data, std::size_t size, std::uint16_t crc) {
  for (std::size_t i = 0; i < size; ++i) {
    std::uint8_t t = static_cast<std::uint8_t>(data[i] ^ (crc & 0xFF));
    t = static_cast<std::uint8_t>(t ^ (t << 4));
    crc = static_cast<std::uint16_t>((crc >> 8) ^ (t << 8) ^ (t << 3) ^ (t >> 4));
  }
  return crc;
}

std::size_t encode_obstacle_distance(const ObstacleDistances& d, std::uint64_t time_usec,
                                     const LinkIds& ids, std::uint8_t sequence, std::uint8_t* buf) {
  std::uint8_t payload[kObstacleDistancePayload] = {};
  put(payload + kTime, time_usec, 8);
  for (int s = 0; s < kObstacleSectors; ++s)
    put(payload + kDistances + 2 * s, d.distances_cm[s], 2);
  put(payload + kMin, d.min_distance_cm, 2);
  put(payload + kMax, d.max_distance_cm, 2);
  payload[kSensor] = kSensorTypeUnknown;
  // The integer increment is whole degrees; increment_f carries the exact one.
  payload[kIncrement] = static_cast<std::uint8_t>(d.increment_deg + 0.5f);
  put(payload + kIncrementF, float_bits(d.increment_deg), 4);
  put(payload + kAngleOffset, float_bits(0.0f), 4);
  payload[kFrame] = kFrameBodyFrd;
  return encode_frame(kObstacleDistanceId, kObstacleDistanceCrcExtra, payload,
                      kObstacleDistancePayload, ids, sequence, buf);
}

std::size_t encode_obstacle_distance_3d(const Obstacle3d& o, const LinkIds& ids,
                                        std::uint8_t sequence, std::uint8_t* buf) {
  // Wire order: time_boot_ms, x, y, z, min_distance, max_distance, obstacle_id,
  // sensor_type, frame.
  std::uint8_t payload[kObstacleDistance3dPayload] = {};
  put(payload + 0, o.time_boot_ms, 4);
  put(payload + 4, float_bits(o.x), 4);
  put(payload + 8, float_bits(o.y), 4);
  put(payload + 12, float_bits(o.z), 4);
  put(payload + 16, float_bits(o.min_distance), 4);
  put(payload + 20, float_bits(o.max_distance), 4);
  put(payload + 24, o.obstacle_id, 2);
  payload[26] = kSensorTypeUnknown;
  payload[27] = kFrameBodyFrd;
  return encode_frame(kObstacleDistance3dId, kObstacleDistance3dCrcExtra, payload,
                      kObstacleDistance3dPayload, ids, sequence, buf);
}

std::size_t encode_heartbeat(const LinkIds& ids, std::uint8_t sequence, std::uint8_t* buf) {
  // Wire order: custom_mode, type, autopilot, base_mode, system_status, mavlink_version.
  std::uint8_t payload[kHeartbeatPayload] = {};
  payload[4] = kTypeOnboardController;
  payload[5] = kAutopilotInvalid;
  payload[7] = kStateActive;
  payload[8] = kMavlinkVersion;
  return encode_frame(kHeartbeatId, kHeartbeatCrcExtra, payload, kHeartbeatPayload, ids, sequence,
                      buf);
}

bool decode_obstacle_distance(const std::uint8_t* buf, std::size_t size,
                              DecodedObstacleDistance* out) {
  if (size < 12 || buf[0] != 0xFD || buf[2] != 0) return false;
  const std::size_t length = buf[1];
  if (length > kObstacleDistancePayload || size != 12 + length) return false;
  if (get(buf + 7, 3) != kObstacleDistanceId) return false;
  std::uint16_t crc = crc_x25(buf + 1, 9 + length);
  crc = crc_x25(&kObstacleDistanceCrcExtra, 1, crc);
  if (get(buf + 10 + length, 2) != crc) return false;
  std::uint8_t payload[kObstacleDistancePayload] = {};  // truncated bytes are zero
  std::memcpy(payload, buf + 10, length);
  DecodedObstacleDistance d;
  d.sequence = buf[4];
  d.system_id = buf[5];
  d.component_id = buf[6];
  d.time_usec = get(payload + kTime, 8);
  for (int s = 0; s < kObstacleSectors; ++s) {
    d.distances[s] = static_cast<std::uint16_t>(get(payload + kDistances + 2 * s, 2));
  }
  d.min_distance = static_cast<std::uint16_t>(get(payload + kMin, 2));
  d.max_distance = static_cast<std::uint16_t>(get(payload + kMax, 2));
  d.sensor_type = payload[kSensor];
  d.increment = payload[kIncrement];
  d.increment_f = bits_float(static_cast<std::uint32_t>(get(payload + kIncrementF, 4)));
  d.angle_offset = bits_float(static_cast<std::uint32_t>(get(payload + kAngleOffset, 4)));
  d.frame = payload[kFrame];
  *out = d;
  return true;
}

}  // namespace zonemap::mavlink
