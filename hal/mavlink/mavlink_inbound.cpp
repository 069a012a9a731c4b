#include "hal/mavlink/mavlink_inbound.hpp"

#include <cstring>

#include "hal/mavlink/obstacle_distance_mavlink.hpp"

namespace zonemap::mavlink {
namespace {

std::uint32_t get(const std::uint8_t* p, int bytes) {
  std::uint32_t v = 0;
  for (int i = 0; i < bytes; ++i) v |= static_cast<std::uint32_t>(p[i]) << (8 * i);
  return v;
}
float get_float(const std::uint8_t* p) {
  const std::uint32_t bits = get(p, 4);
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}
std::int64_t get_int64(const std::uint8_t* p) {
  std::uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= static_cast<std::uint64_t>(p[i]) << (8 * i);
  return static_cast<std::int64_t>(v);
}

struct KnownMessage {
  std::uint32_t id;
  std::uint8_t crc_extra;
  std::uint8_t length;  // with extensions
};
// The messages zonemap reads (CRC_EXTRA from their public definitions).
constexpr KnownMessage kKnown[] = {{kHeartbeatId, kHeartbeatCrcExtra, kHeartbeatPayload},
                                   {kSysStatusId, 124, 43},
                                   {kAttitudeQuaternionId, 246, 48},
                                   {kLocalPositionNedId, 185, 28},
                                   {kTimesyncId, kTimesyncCrcExtra, kTimesyncPayload}};

const KnownMessage* known(std::uint32_t id) {
  for (const KnownMessage& k : kKnown) {
    if (k.id == id) return &k;
  }
  return nullptr;
}

struct Header {
  std::size_t header_bytes, payload_bytes, trailer_bytes;  // trailer: CRC (+ signature)
  std::uint32_t message_id;
  std::uint8_t system_id, component_id;
};

bool read_header(const std::uint8_t* d, std::size_t size, Header* h) {
  if (d[0] == 0xFD) {
    if (size < 10) return false;
    *h = {10, d[1], 2u + ((d[2] & 1) ? 13u : 0u), get(d + 7, 3), d[5], d[6]};
    return (d[2] & ~1u) == 0;  // no incompatibility flag zonemap does not know
  }
  if (size < 6) return false;
  *h = {6, d[1], 2, d[5], d[3], d[4]};
  return true;
}

}  // namespace

FrameStatus read_frame(const std::uint8_t* data, std::size_t size, InboundFrame* frame,
                       std::size_t* used) {
  *used = 0;
  if (size == 0 || (data[0] != 0xFD && data[0] != 0xFE)) return FrameStatus::kBad;
  Header h{};
  if (size < 10 && data[0] == 0xFD) return FrameStatus::kTruncated;
  if (!read_header(data, size, &h)) return size < 6 ? FrameStatus::kTruncated : FrameStatus::kBad;
  const std::size_t total = h.header_bytes + h.payload_bytes + h.trailer_bytes;
  if (size < total) return FrameStatus::kTruncated;
  *used = total;
  const KnownMessage* k = known(h.message_id);
  if (k == nullptr) return FrameStatus::kOther;
  if (h.payload_bytes > k->length) {
    *used = 0;
    return FrameStatus::kBad;
  }
  std::uint16_t crc = crc_x25(data + 1, h.header_bytes - 1 + h.payload_bytes);
  crc = crc_x25(&k->crc_extra, 1, crc);
  if (get(data + h.header_bytes + h.payload_bytes, 2) != crc) {
    *used = 0;
    return FrameStatus::kBad;
  }
  frame->message_id = h.message_id;
  frame->system_id = h.system_id;
  frame->component_id = h.component_id;
  std::memset(frame->payload, 0, sizeof frame->payload);
  std::memcpy(frame->payload, data + h.header_bytes, h.payload_bytes);
  return FrameStatus::kKnown;
}

Heartbeat heartbeat_of(const InboundFrame& f) {
  // Wire order: custom_mode, type, autopilot, base_mode, system_status, mavlink_version.
  return {f.payload[4], f.payload[5], f.payload[7]};
}

SysStatus sys_status_of(const InboundFrame& f) {
  // Wire order: present, enabled, health (uint32 each), then the rest.
  return {get(f.payload, 4), get(f.payload + 4, 4), get(f.payload + 8, 4)};
}

AttitudeQuaternion attitude_quaternion_of(const InboundFrame& f) {
  // Wire order: time_boot_ms, q1 (w), q2 (x), q3 (y), q4 (z), rates, repr_offset_q.
  return {get(f.payload, 4), get_float(f.payload + 4), get_float(f.payload + 8),
          get_float(f.payload + 12), get_float(f.payload + 16)};
}

LocalPositionNed local_position_ned_of(const InboundFrame& f) {
  // Wire order: time_boot_ms, x, y, z, vx, vy, vz.
  return {get(f.payload, 4), get_float(f.payload + 4), get_float(f.payload + 8),
          get_float(f.payload + 12)};
}

Timesync timesync_of(const InboundFrame& f) {
  return {get_int64(f.payload), get_int64(f.payload + 8)};
}

std::size_t encode_timesync(const Timesync& t, std::uint8_t system_id, std::uint8_t component_id,
                            std::uint8_t sequence, std::uint8_t* buf) {
  // Wire order: tc1, ts1, target_system, target_component (0: every system).
  std::uint8_t payload[kTimesyncPayload] = {};
  for (int i = 0; i < 8; ++i) {
    payload[i] = static_cast<std::uint8_t>(static_cast<std::uint64_t>(t.tc1) >> (8 * i));
    payload[8 + i] = static_cast<std::uint8_t>(static_cast<std::uint64_t>(t.ts1) >> (8 * i));
  }
  return encode_frame(kTimesyncId, kTimesyncCrcExtra, payload, kTimesyncPayload,
                      {system_id, component_id}, sequence, buf);
}

}  // namespace zonemap::mavlink
