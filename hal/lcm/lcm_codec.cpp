#include "hal/lcm/lcm_codec.hpp"

#include <algorithm>
#include <cmath>

namespace zonemap::lcm_link {

InsDecode decode_ins_state(const void* data, std::size_t size, bool world_z_up, InsSolution* out) {
  zonemap_lcm::ins_state_t m;
  // decode() checks the fingerprint and every length; -1 on any mismatch.
  if (size > 0x7FFFFFFF || m.decode(data, 0, static_cast<int>(size)) < 0) {
    return InsDecode::kMalformed;
  }
  const std::int8_t expected =
      world_z_up ? zonemap_lcm::ins_state_t::FRAME_Z_UP : zonemap_lcm::ins_state_t::FRAME_NED;
  if (m.frame != expected) return InsDecode::kWrongFrame;
  InsSolution s;
  s.time_s = static_cast<double>(m.utime) * 1e-6;
  s.position_m = {m.position[0], m.position[1], m.position[2]};
  s.attitude =
      Eigen::Quaterniond(m.orientation[0], m.orientation[1], m.orientation[2], m.orientation[3]);
  s.attitude_valid = (m.flags & zonemap_lcm::ins_state_t::ATTITUDE_VALID) != 0;
  s.position_valid = (m.flags & zonemap_lcm::ins_state_t::POSITION_VALID) != 0;
  s.position_sigma_m = m.position_sigma_m;
  *out = s;
  return InsDecode::kOk;
}

zonemap_lcm::ins_state_t to_message(const InsSolution& s, bool world_z_up, std::int64_t utime) {
  zonemap_lcm::ins_state_t m;
  m.utime = utime;
  m.frame = world_z_up ? zonemap_lcm::ins_state_t::FRAME_Z_UP : zonemap_lcm::ins_state_t::FRAME_NED;
  for (int i = 0; i < 3; ++i) m.position[i] = s.position_m[i];
  m.orientation[0] = s.attitude.w();
  m.orientation[1] = s.attitude.x();
  m.orientation[2] = s.attitude.y();
  m.orientation[3] = s.attitude.z();
  m.flags = (s.attitude_valid ? zonemap_lcm::ins_state_t::ATTITUDE_VALID : 0) |
            (s.position_valid ? zonemap_lcm::ins_state_t::POSITION_VALID : 0);
  m.position_sigma_m = static_cast<float>(s.position_sigma_m);
  m.attitude_sigma_rad = -1.0f;
  return m;
}

ObstacleMapMessage::ObstacleMapMessage(std::size_t max_boxes, std::size_t max_rects_per_box)
    : max_rects_(max_rects_per_box) {
  message_.boxes.resize(max_boxes);
  for (auto& box : message_.boxes) box.footprint.assign(max_rects_per_box, std::vector<float>(4));
  message_.num_boxes = static_cast<std::int32_t>(max_boxes);
  for (auto& box : message_.boxes) box.num_footprint = static_cast<std::int32_t>(max_rects_per_box);
  buffer_.resize(static_cast<std::size_t>(message_.getEncodedSize()));  // the largest message
  message_.num_boxes = 0;
}

void ObstacleMapMessage::set_sender(const std::string& vehicle, const Geodetic* world_origin) {
  message_.vehicle = vehicle;
  message_.origin_valid = world_origin != nullptr;
  const Geodetic o = world_origin != nullptr ? *world_origin : Geodetic{};
  message_.origin[0] = o.latitude_deg;
  message_.origin[1] = o.longitude_deg;
  message_.origin[2] = o.height_m;
  // The largest message grows by the name.
  const std::size_t boxes = static_cast<std::size_t>(message_.num_boxes);
  message_.num_boxes = static_cast<std::int32_t>(message_.boxes.size());
  buffer_.resize(static_cast<std::size_t>(message_.getEncodedSize()));
  message_.num_boxes = static_cast<std::int32_t>(boxes);
}

void ObstacleMapMessage::fill(std::int64_t utime, const Eigen::Vector3d& vehicle, bool world_z_up,
                              const ObstacleBox* boxes, std::size_t count,
                              const FootprintRect* rects, const std::uint32_t* offsets,
                              const std::uint32_t* rect_counts) {
  message_.utime = utime;
  message_.generation = ++generation_;
  message_.frame =
      world_z_up ? zonemap_lcm::ins_state_t::FRAME_Z_UP : zonemap_lcm::ins_state_t::FRAME_NED;
  for (int i = 0; i < 3; ++i) message_.vehicle_position[i] = vehicle[i];
  message_.total_boxes = static_cast<std::int32_t>(count);
  const std::size_t n = std::min(count, message_.boxes.size());
  message_.num_boxes = static_cast<std::int32_t>(n);
  for (std::size_t b = 0; b < n; ++b) {
    zonemap_lcm::obstacle_box_t& out = message_.boxes[b];
    const ObstacleBox& in = boxes[b];
    out.id = static_cast<std::int32_t>(in.id);
    out.kind = in.kind == FeatureKind::kGround ? zonemap_lcm::obstacle_box_t::KIND_GROUND
                                               : zonemap_lcm::obstacle_box_t::KIND_OBSTACLE;
    for (int i = 0; i < 3; ++i) {
      out.min[i] = in.min[i];
      out.max[i] = in.max[i];
    }
    out.cells = in.cells;
    out.last_seen_utime = static_cast<std::int64_t>(std::llround(in.last_seen_s * 1e6));
    out.prior = in.prior;
    const std::size_t r = rects == nullptr ? 0 : rect_counts[b];
    // A shape larger than the message allows is sent as its box alone (num_footprint 0).
    out.num_footprint = r <= max_rects_ ? static_cast<std::int32_t>(r) : 0;
    for (std::int32_t k = 0; k < out.num_footprint; ++k) {
      const FootprintRect& rect = rects[offsets[b] + static_cast<std::uint32_t>(k)];
      std::vector<float>& o = out.footprint[static_cast<std::size_t>(k)];
      o[0] = rect.x0;
      o[1] = rect.y0;
      o[2] = rect.x1;
      o[3] = rect.y1;
    }
  }
}

std::size_t ObstacleMapMessage::encode(const std::uint8_t** bytes) {
  const int size = message_.getEncodedSize();
  if (size < 0 || static_cast<std::size_t>(size) > buffer_.size() ||
      message_.encode(buffer_.data(), 0, size) < 0) {
    *bytes = nullptr;
    return 0;
  }
  *bytes = buffer_.data();
  return static_cast<std::size_t>(size);
}

zonemap_lcm::obstacle_distance_t to_message(const ObstacleDistances& d, std::int64_t utime) {
  zonemap_lcm::obstacle_distance_t m;
  m.utime = utime;
  m.frame = 12;  // MAV_FRAME_BODY_FRD
  m.increment_deg = d.increment_deg;
  m.angle_offset_deg = 0.0f;
  m.min_distance_cm = d.min_distance_cm;
  m.max_distance_cm = d.max_distance_cm;
  for (int s = 0; s < kObstacleSectors; ++s) m.distances_cm[s] = d.distances_cm[s];
  return m;
}

namespace {

// A big-endian int32 at `pos`, if it is there.
bool read_count(const std::uint8_t* b, std::size_t size, std::size_t pos, std::int64_t* out) {
  if (pos + 4 > size) return false;
  const std::uint32_t v = (std::uint32_t{b[pos]} << 24) | (std::uint32_t{b[pos + 1]} << 16) |
                          (std::uint32_t{b[pos + 2]} << 8) | std::uint32_t{b[pos + 3]};
  *out = static_cast<std::int32_t>(v);
  return true;
}

}  // namespace

bool obstacle_map_counts_fit(const void* data, std::size_t size) {
  // config/lcm/obstacle_map_t.lcm, encoded: fingerprint, utime, generation, frame,
  // vehicle_position[3], total_boxes, then num_boxes; a box (no fingerprint):
  // id, kind, min[3], max[3], cells, last_seen_utime, prior, then num_footprint
  // rows of 4 floats; after the boxes the name (length with its NUL, bytes),
  // origin_valid, origin[3].
  constexpr std::size_t kHead = 8 + 8 + 4 + 1 + 24 + 4;
  constexpr std::size_t kBoxFixed = 4 + 1 + 24 + 24 + 4 + 8 + 1;
  constexpr std::size_t kRect = 16;
  constexpr std::size_t kTail = 1 + 24;
  const auto* b = static_cast<const std::uint8_t*>(data);
  std::int64_t boxes = 0;
  if (!read_count(b, size, kHead, &boxes) || boxes < 0) return false;
  std::size_t pos = kHead + 4;
  // Each box takes at least kBoxFixed + 4 bytes: the loop is bounded by the size.
  if (static_cast<std::size_t>(boxes) > (size - pos) / (kBoxFixed + 4)) return false;
  for (std::int64_t i = 0; i < boxes; ++i) {
    std::int64_t rects = 0;
    if (!read_count(b, size, pos + kBoxFixed, &rects) || rects < 0) return false;
    pos += kBoxFixed + 4;
    if (static_cast<std::size_t>(rects) > (size - pos) / kRect) return false;
    pos += static_cast<std::size_t>(rects) * kRect;
  }
  std::int64_t name = 0;
  if (!read_count(b, size, pos, &name) || name < 1) return false;
  pos += 4;
  return static_cast<std::size_t>(name) <= size - pos &&
         kTail <= size - pos - static_cast<std::size_t>(name);
}

}  // namespace zonemap::lcm_link
