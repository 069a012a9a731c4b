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
  std::size_t length = kObstacleDistancePayload;
  while (length > 1 && payload[length - 1] == 0) --length;  // MAVLink 2 truncation

  buf[0] = 0xFD;
  buf[1] = static_cast<std::uint8_t>(length);
  buf[2] = 0;  // incompat flags (unsigned)
  buf[3] = 0;  // compat flags
  buf[4] = sequence;
  buf[5] = ids.system_id;
  buf[6] = ids.component_id;
  put(buf + 7, kObstacleDistanceId, 3);
  std::memcpy(buf + 10, payload, length);
  std::uint16_t crc = crc_x25(buf + 1, 9 + length);
  crc = crc_x25(&kObstacleDistanceCrcExtra, 1, crc);
  put(buf + 10 + length, crc, 2);
  return 12 + length;
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
