#include "hal/record/flight_recorder.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "hal/record/foxglove_json.hpp"
#include "zonemap/mapping/mapper.hpp"

namespace zonemap::record {
namespace {

constexpr std::size_t kSlots = 4;  // per kind of large item
constexpr double kTrajectoryPeriodS = 1.0;
constexpr double kTrajectoryStepM = 0.1;  // a trajectory point every so far
constexpr std::size_t kTrajectoryPoints = 1 << 16;

struct PoseItem {
  double time_s;
  double position[3];
  double orientation[4];  // w, x, y, z
};

struct BoxSlot {
  double time_s = 0.0;
  Eigen::Isometry3d world_T_body = Eigen::Isometry3d::Identity();
  SectorMask observed{};
  std::vector<ObstacleBox> boxes;
  std::vector<FootprintRect> rects;
  std::vector<std::uint32_t> offsets, counts;
  std::size_t count = 0;
};

struct DepthSlot {
  double time_s = 0.0;
  std::vector<std::uint16_t> pixels;
};

struct CloudSlot {
  double time_s = 0.0;
  std::vector<float> xyzv;  // x, y, z, fused value per cell
  std::size_t points = 0;
};

// Slots handed from the producer to the recorder thread and back, by index on
// two lock-free queues: `free` (recorder -> producer), `full` (producer -> recorder).
template <typename Slot>
struct SlotRing {
  std::vector<Slot> slots;
  SpscQueue<std::uint32_t, kSlots * 2> free, full;
  void reserve(std::size_t n, auto&& size_slot) {
    slots.resize(n);
    for (std::uint32_t i = 0; i < n; ++i) {
      size_slot(slots[i]);
      free.push(i);
    }
  }
  Slot* acquire(std::uint32_t* index) { return free.pop(index) ? &slots[*index] : nullptr; }
};

Eigen::Quaterniond rotation_of(const Eigen::Isometry3d& t) {
  return Eigen::Quaterniond(t.rotation()).normalized();
}

std::string box_entity_id(std::uint32_t id) {
  return "box-" + std::to_string(id);
}

void empty_primitives(JsonWriter& j, bool cubes, bool lines, bool triangles) {
  j.key("arrows").begin_array().end_array();
  if (!cubes) j.key("cubes").begin_array().end_array();
  j.key("spheres").begin_array().end_array();
  j.key("cylinders").begin_array().end_array();
  if (!lines) j.key("lines").begin_array().end_array();
  if (!triangles) j.key("triangles").begin_array().end_array();
  j.key("texts").begin_array().end_array();
  j.key("models").begin_array().end_array();
}

void begin_entity(JsonWriter& j, double time_s, std::string_view id) {
  j.begin_object();
  j.key("timestamp").time(time_s);
  j.key("frame_id").string("world");
  j.key("id").string(id);
  j.key("lifetime").begin_object().key("sec").integer(0).key("nsec").integer(0).end_object();
  j.key("frame_locked").boolean(false);
}

const Eigen::Quaterniond kIdentity = Eigen::Quaterniond::Identity();

}  // namespace

struct FlightRecorder::Impl {
  RecorderConfig config;
  McapWriter writer;
  std::uint16_t boxes_channel = 0, sectors_channel = 0, occupied_channel = 0, pose_channel = 0;
  std::uint16_t trajectory_channel = 0, depth_channel = 0, health_channel = 0;
  SlotRing<BoxSlot> boxes;
  SlotRing<DepthSlot> depth;
  SlotRing<CloudSlot> clouds;
  SpscQueue<PoseItem, 1024> poses;
  SpscQueue<hal::HealthSnapshot, 8> health;
  int depth_width = 0, depth_height = 0;
  // Recorder thread only.
  std::string json;
  std::vector<std::uint32_t> shown_ids, next_ids;
  std::vector<Eigen::Vector3d> trajectory;
  double trajectory_written_s = -INFINITY;
  double last_pose_s = 0.0;
  RecorderCounts counts;
  std::atomic<std::int64_t> published_messages{0};

  void write(std::uint16_t channel, double time_s) {
    const std::uint64_t t = time_ns(time_s);
    writer.write(channel, t, t, json);
  }
  void write_boxes(const BoxSlot& slot);
  void write_sectors(const BoxSlot& slot);
  void write_pose(const PoseItem& pose);
  void write_trajectory(double time_s);
  void write_depth(const DepthSlot& slot);
  void write_cloud(const CloudSlot& slot);
  void write_health(const hal::HealthSnapshot& h);
  bool drain_once();
};

RecorderConfig recorder_config_for(const CameraModel& camera, std::size_t max_boxes,
                                   std::size_t max_rects) {
  RecorderConfig rc;
  rc.max_boxes = max_boxes;
  rc.max_rects = max_rects;
  rc.depth_width = camera.width;
  rc.depth_height = camera.height;
  rc.depth_decimation = camera.width > 320 ? 2 : 1;
  rc.world_z_up = camera.world_z_up;
  rc.body_T_camera = camera.body_T_camera;
  return rc;
}

FlightRecorder::FlightRecorder() : impl_(std::make_unique<Impl>()) {}

FlightRecorder::~FlightRecorder() {
  std::string ignored;
  close(&ignored);
}

bool FlightRecorder::open(const RecorderConfig& config, std::string* error) {
  Impl& m = *impl_;
  m.config = config;
  const int dec = std::max(1, config.depth_decimation);
  m.depth_width = (config.depth_width + dec - 1) / dec;
  m.depth_height = (config.depth_height + dec - 1) / dec;
  m.boxes.reserve(kSlots, [&](BoxSlot& s) {
    s.boxes.resize(config.max_boxes);
    s.rects.resize(config.max_rects);
    s.offsets.resize(config.max_boxes);
    s.counts.resize(config.max_boxes);
  });
  m.depth.reserve(kSlots, [&](DepthSlot& s) {
    s.pixels.resize(static_cast<std::size_t>(m.depth_width) * m.depth_height);
  });
  m.clouds.reserve(2, [&](CloudSlot& s) { s.xyzv.resize(config.max_occupied * 4); });
  m.shown_ids.reserve(config.max_boxes);
  m.next_ids.reserve(config.max_boxes);
  m.trajectory.reserve(kTrajectoryPoints);
  reserved_bytes_ = sizeof(Impl) +
                    kSlots * (config.max_boxes * (sizeof(ObstacleBox) + 8) +
                              config.max_rects * sizeof(FootprintRect) +
                              static_cast<std::size_t>(m.depth_width) * m.depth_height * 2) +
                    2 * config.max_occupied * 16 + kTrajectoryPoints * sizeof(Eigen::Vector3d);

  if (!m.writer.open(config.path, config.mcap, error)) return false;
  auto channel = [&](const SchemaText& schema, const char* topic) {
    return m.writer.add_channel(m.writer.add_schema(schema.name, "jsonschema", schema.json), topic,
                                "json");
  };
  const SchemaText scene = scene_update_schema();
  const std::uint16_t scene_schema = m.writer.add_schema(scene.name, "jsonschema", scene.json);
  m.boxes_channel = m.writer.add_channel(scene_schema, "/zonemap/boxes", "json");
  m.sectors_channel = m.writer.add_channel(scene_schema, "/zonemap/sectors", "json");
  m.trajectory_channel = m.writer.add_channel(scene_schema, "/zonemap/trajectory", "json");
  m.occupied_channel = channel(point_cloud_schema(), "/zonemap/occupied");
  m.pose_channel = channel(frame_transform_schema(), "/zonemap/pose");
  m.depth_channel = channel(raw_image_schema(), "/zonemap/depth");
  m.health_channel = channel(health_schema(), "/zonemap/health");
  stopping_.store(false);
  thread_.start({"zonemap-record"}, [this] { run(); });
  return true;
}

bool FlightRecorder::close(std::string* error) {
  if (!thread_.started()) return true;
  stopping_.store(true, std::memory_order_release);
  work_.ring();
  thread_.join();
  Impl& m = *impl_;
  m.write_trajectory(m.last_pose_s);
  const bool ok = m.writer.close(error);
  const McapCounts& c = m.writer.counts();
  m.counts.messages = static_cast<std::int64_t>(c.messages);
  m.counts.bytes = static_cast<std::int64_t>(c.bytes);
  m.counts.chunks = static_cast<std::int64_t>(c.chunks);
  m.counts.bytes_uncompressed = static_cast<std::int64_t>(c.chunk_bytes_uncompressed);
  return ok;
}

RecorderCounts FlightRecorder::counts() const {
  RecorderCounts c = impl_->counts;
  c.dropped = dropped_.load(std::memory_order_relaxed);
  return c;
}

void FlightRecorder::report(hal::HealthSnapshot* health) const {
  health->add("recording_dropped", dropped_.load(std::memory_order_relaxed));
  health->add("recording_messages", impl_->published_messages.load(std::memory_order_relaxed));
}

// --- producer side ---------------------------------------------------------------

bool FlightRecorder::record_pose(double time_s, const Eigen::Isometry3d& world_T_body) {
  const Eigen::Quaterniond q = rotation_of(world_T_body);
  const Eigen::Vector3d p = world_T_body.translation();
  const PoseItem item{time_s, {p.x(), p.y(), p.z()}, {q.w(), q.x(), q.y(), q.z()}};
  if (!thread_.started() || !impl_->poses.push(item)) {
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  work_.ring();
  return true;
}

bool FlightRecorder::record_depth(double time_s, const std::uint16_t* depth) {
  Impl& m = *impl_;
  std::uint32_t index = 0;
  DepthSlot* slot = thread_.started() ? m.depth.acquire(&index) : nullptr;
  if (slot == nullptr || depth == nullptr) {
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  const int dec = std::max(1, m.config.depth_decimation);
  std::uint16_t* out = slot->pixels.data();
  for (int y = 0; y < m.config.depth_height; y += dec) {
    const std::uint16_t* row = depth + static_cast<std::size_t>(y) * m.config.depth_width;
    for (int x = 0; x < m.config.depth_width; x += dec) *out++ = row[x];
  }
  slot->time_s = time_s;
  m.depth.full.push(index);
  work_.ring();
  return true;
}

bool FlightRecorder::record_occupied(double time_s, Mapper& mapper) {
  Impl& m = *impl_;
  std::uint32_t index = 0;
  CloudSlot* slot = thread_.started() ? m.clouds.acquire(&index) : nullptr;
  if (slot == nullptr) {
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  std::size_t n = 0;
  bool truncated = false;
  float* out = slot->xyzv.data();
  const std::size_t capacity = m.config.max_occupied;
  mapper.for_each_occupied_cell([&](const Eigen::Vector3d& c, FusedCell v) {
    if (n == capacity) {
      truncated = true;
      return;
    }
    out[4 * n + 0] = static_cast<float>(c.x());
    out[4 * n + 1] = static_cast<float>(c.y());
    out[4 * n + 2] = static_cast<float>(c.z());
    out[4 * n + 3] = static_cast<float>(v);
    ++n;
  });
  slot->points = n;
  slot->time_s = time_s;
  if (truncated) ++m.counts.occupied_truncated;  // read by the recorder only after close
  m.clouds.full.push(index);
  work_.ring();
  return true;
}

namespace {
// Copies an update's boxes and footprint rectangles into a slot (a box whose
// rectangles do not fit keeps none: the box is its shape).
void copy_update(const hal::ObstacleUpdate& u, BoxSlot* slot) {
  slot->time_s = u.time_s;
  slot->world_T_body = u.world_T_body;
  slot->observed = u.sectors_observed;
  slot->count = std::min(u.count, slot->boxes.size());
  std::size_t used = 0;
  for (std::size_t i = 0; i < slot->count; ++i) {
    slot->boxes[i] = u.boxes[i];
    const std::uint32_t n = u.rects != nullptr ? u.rect_counts[i] : 0;
    slot->offsets[i] = static_cast<std::uint32_t>(used);
    slot->counts[i] = 0;
    if (n == 0 || used + n > slot->rects.size()) continue;
    std::copy_n(u.rects + u.rect_offsets[i], n, slot->rects.begin() + used);
    slot->counts[i] = n;
    used += n;
  }
}
}  // namespace

bool FlightRecorder::record_boxes(const hal::ObstacleUpdate& update) {
  Impl& m = *impl_;
  std::uint32_t index = 0;
  BoxSlot* slot = thread_.started() ? m.boxes.acquire(&index) : nullptr;
  if (slot == nullptr) {
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  copy_update(update, slot);
  m.boxes.full.push(index);
  work_.ring();
  if (poses_from_updates_) record_pose(update.time_s, update.world_T_body);
  return true;
}

void FlightRecorder::record_final_boxes(const hal::ObstacleUpdate& update) {
  if (!thread_.started()) return;
  Impl& m = *impl_;
  std::uint32_t index = 0;
  // Not on a real-time path (the run is over): wait for the recorder to free a slot.
  for (;;) {
    const std::uint32_t ticket = room_.ticket();
    if (m.boxes.free.pop(&index)) break;
    room_.wait(ticket);
  }
  copy_update(update, &m.boxes.slots[index]);
  m.boxes.full.push(index);
  work_.ring();
}

bool FlightRecorder::record_health(const hal::HealthSnapshot& health) {
  if (!thread_.started() || !impl_->health.push(health)) {
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  work_.ring();
  return true;
}

void FlightRecorder::publish(const hal::ObstacleUpdate& update, double /*now_s*/) {
  record_boxes(update);
}

void FlightRecorder::publish_health(const hal::HealthSnapshot& health, double /*now_s*/) {
  record_health(health);
}

// --- recorder thread -------------------------------------------------------------

void FlightRecorder::run() {
  Impl& m = *impl_;
  for (;;) {
    const std::uint32_t ticket = work_.ticket();
    const bool stopping = stopping_.load(std::memory_order_acquire);
    if (m.drain_once()) {
      room_.ring();
      continue;
    }
    if (stopping) return;  // everything pushed before close() has been written
    work_.wait(ticket);
  }
}

bool FlightRecorder::Impl::drain_once() {
  bool any = false;
  PoseItem pose;
  while (poses.pop(&pose)) {
    write_pose(pose);
    any = true;
  }
  std::uint32_t index = 0;
  if (boxes.full.pop(&index)) {
    write_boxes(boxes.slots[index]);
    write_sectors(boxes.slots[index]);
    boxes.free.push(index);
    any = true;
  }
  if (depth.full.pop(&index)) {
    write_depth(depth.slots[index]);
    depth.free.push(index);
    any = true;
  }
  if (clouds.full.pop(&index)) {
    write_cloud(clouds.slots[index]);
    clouds.free.push(index);
    any = true;
  }
  hal::HealthSnapshot h;
  if (health.pop(&h)) {
    write_health(h);
    any = true;
  }
  published_messages.store(static_cast<std::int64_t>(writer.counts().messages),
                           std::memory_order_relaxed);
  return any;
}

void FlightRecorder::Impl::write_boxes(const BoxSlot& slot) {
  json.clear();
  JsonWriter j(&json);
  next_ids.clear();
  for (std::size_t i = 0; i < slot.count; ++i) next_ids.push_back(slot.boxes[i].id);
  std::sort(next_ids.begin(), next_ids.end());
  j.begin_object().key("deletions").begin_array();
  for (std::uint32_t id : shown_ids) {
    if (std::binary_search(next_ids.begin(), next_ids.end(), id)) continue;
    j.begin_object();
    j.key("timestamp").time(slot.time_s);
    j.key("type").integer(0);  // MATCHING_ID
    j.key("id").string(box_entity_id(id));
    j.end_object();
  }
  j.end_array().key("entities").begin_array();
  for (std::size_t i = 0; i < slot.count; ++i) {
    const ObstacleBox& b = slot.boxes[i];
    const bool ground = b.kind == FeatureKind::kGround;
    begin_entity(j, slot.time_s, box_entity_id(b.id));
    j.key("metadata").begin_array();
    j.begin_object().key("key").string("kind").key("value").string(ground ? "ground" : "obstacle");
    j.end_object();
    j.begin_object().key("key").string("cells").key("value").string(std::to_string(b.cells));
    j.end_object();
    j.begin_object().key("key").string("parts").key("value").string(std::to_string(b.parts));
    j.end_object();
    char seen[32];
    std::snprintf(seen, sizeof(seen), "%.3f", b.last_seen_s);
    j.begin_object().key("key").string("last_seen_s").key("value").string(seen);
    j.end_object();
    j.begin_object().key("key").string("prior").key("value").string(b.prior ? "1" : "0");
    j.end_object();
    j.end_array();
    j.key("cubes").begin_array().begin_object();
    j.key("pose").pose((b.min + b.max) / 2, kIdentity);
    j.key("size").vector3(b.max - b.min);
    if (ground) {
      j.key("color").color(0.55f, 0.45f, 0.30f, 0.25f);
    } else if (b.prior) {
      j.key("color").color(0.55f, 0.35f, 0.85f, 0.45f);  // known before, not seen yet: violet
    } else {
      j.key("color").color(1.0f, 0.35f, 0.10f, 0.45f);
    }
    j.end_object().end_array();
    // The quadtree footprint: each full square's outline at the box's bottom and top.
    j.key("lines").begin_array().begin_object();
    j.key("type").integer(2);  // LINE_LIST
    j.key("pose").pose(Eigen::Vector3d::Zero(), kIdentity);
    j.key("thickness").number(2.0).key("scale_invariant").boolean(true);
    j.key("points").begin_array();
    const std::uint32_t rects = slot.counts[i];
    for (std::uint32_t r = 0; r < std::max<std::uint32_t>(rects, 1); ++r) {
      FootprintRect f{static_cast<float>(b.min.x()), static_cast<float>(b.min.y()),
                      static_cast<float>(b.max.x()), static_cast<float>(b.max.y())};
      if (rects > 0) f = slot.rects[slot.offsets[i] + r];
      for (double z : {b.min.z(), b.max.z()}) {
        const Eigen::Vector3d c[4] = {
            {f.x0, f.y0, z}, {f.x1, f.y0, z}, {f.x1, f.y1, z}, {f.x0, f.y1, z}};
        for (int k = 0; k < 4; ++k) j.vector3(c[k]).vector3(c[(k + 1) % 4]);
      }
    }
    j.end_array();
    j.key("color").color(1.0f, 1.0f, 1.0f, 0.8f);
    j.key("colors").begin_array().end_array().key("indices").begin_array().end_array();
    j.end_object().end_array();
    empty_primitives(j, true, true, false);
    j.end_object();
  }
  j.end_array().end_object();
  shown_ids.swap(next_ids);
  write(boxes_channel, slot.time_s);
  ++counts.boxes_updates;
}

// The 72 sectors as the flight controller gets them: a wedge per sector in the
// horizontal plane at the vehicle, red to the obstacle, green to max_distance
// when seen free, grey when never seen.
void FlightRecorder::Impl::write_sectors(const BoxSlot& slot) {
  const FootprintView footprints{slot.rects.data(), slot.offsets.data(), slot.counts.data()};
  const ObstacleDistances d =
      obstacle_distances(slot.boxes.data(), slot.count, footprints, slot.world_T_body,
                         config.world_z_up, config.sectors, slot.observed);
  const HorizontalAxes axes = horizontal_axes(slot.world_T_body, config.world_z_up);
  const Eigen::Vector3d origin = slot.world_T_body.translation();
  json.clear();
  JsonWriter j(&json);
  j.begin_object().key("deletions").begin_array().end_array().key("entities").begin_array();
  begin_entity(j, slot.time_s, "sectors");
  // The distances as sent (cm; max_distance + 1 = free, 65535 = never seen).
  std::string sent;
  for (int s = 0; s < kObstacleSectors; ++s) {
    if (s > 0) sent.push_back(',');
    sent.append(std::to_string(d.distances_cm[s]));
  }
  j.key("metadata").begin_array();
  j.begin_object().key("key").string("distances_cm").key("value").string(sent).end_object();
  j.end_array();
  j.key("triangles").begin_array().begin_object();
  j.key("pose").pose(Eigen::Vector3d::Zero(), kIdentity);
  j.key("points").begin_array();
  const double half = M_PI / kObstacleSectors;
  for (int s = 0; s < kObstacleSectors; ++s) {
    const std::uint16_t cm = d.distances_cm[s];
    const double r =
        cm == kSectorUnknown || cm > d.max_distance_cm ? config.sectors.max_distance_m : cm / 100.0;
    const double a = 2.0 * half * s;
    auto edge = [&](double angle) {
      return origin + r * (std::cos(angle) * axes.forward + std::sin(angle) * axes.right);
    };
    j.vector3(origin).vector3(edge(a - half)).vector3(edge(a + half));
  }
  j.end_array();
  j.key("color").color(0.5f, 0.5f, 0.5f, 0.3f);
  j.key("colors").begin_array();
  for (int s = 0; s < kObstacleSectors; ++s) {
    const std::uint16_t cm = d.distances_cm[s];
    for (int k = 0; k < 3; ++k) {
      if (cm == kSectorUnknown) {
        j.color(0.5f, 0.5f, 0.5f, 0.15f);
      } else if (cm > d.max_distance_cm) {
        j.color(0.2f, 0.8f, 0.3f, 0.2f);
      } else {
        j.color(1.0f, 0.1f, 0.1f, 0.6f);
      }
    }
  }
  j.end_array().key("indices").begin_array().end_array();
  j.end_object().end_array();
  empty_primitives(j, false, false, true);
  j.end_object().end_array().end_object();
  write(sectors_channel, slot.time_s);
  ++counts.sectors;
}

void FlightRecorder::Impl::write_pose(const PoseItem& pose) {
  const Eigen::Vector3d p(pose.position[0], pose.position[1], pose.position[2]);
  const Eigen::Quaterniond q(pose.orientation[0], pose.orientation[1], pose.orientation[2],
                             pose.orientation[3]);
  auto transform = [&](const char* parent, const char* child, const Eigen::Vector3d& t,
                       const Eigen::Quaterniond& r) {
    json.clear();
    JsonWriter j(&json);
    j.begin_object();
    j.key("timestamp").time(pose.time_s);
    j.key("parent_frame_id").string(parent).key("child_frame_id").string(child);
    j.key("translation").vector3(t).key("rotation").quaternion(r);
    j.end_object();
    write(pose_channel, pose.time_s);
  };
  transform("world", "body", p, q);
  transform("body", "camera", config.body_T_camera.translation(),
            rotation_of(config.body_T_camera));
  ++counts.poses;
  last_pose_s = pose.time_s;
  if ((trajectory.empty() || (trajectory.back() - p).norm() >= kTrajectoryStepM) &&
      trajectory.size() < trajectory.capacity()) {
    trajectory.push_back(p);
  }
  if (pose.time_s - trajectory_written_s >= kTrajectoryPeriodS) write_trajectory(pose.time_s);
}

void FlightRecorder::Impl::write_trajectory(double time_s) {
  if (trajectory.empty()) return;
  trajectory_written_s = time_s;
  json.clear();
  JsonWriter j(&json);
  j.begin_object().key("deletions").begin_array().end_array().key("entities").begin_array();
  begin_entity(j, time_s, "trajectory");
  j.key("metadata").begin_array().end_array();
  j.key("lines").begin_array().begin_object();
  j.key("type").integer(0);  // LINE_STRIP
  j.key("pose").pose(Eigen::Vector3d::Zero(), kIdentity);
  j.key("thickness").number(3.0).key("scale_invariant").boolean(true);
  j.key("points").begin_array();
  for (const Eigen::Vector3d& p : trajectory) j.vector3(p);
  j.end_array();
  j.key("color").color(0.2f, 0.6f, 1.0f, 1.0f);
  j.key("colors").begin_array().end_array().key("indices").begin_array().end_array();
  j.end_object().end_array();
  empty_primitives(j, false, true, false);
  j.end_object().end_array().end_object();
  write(trajectory_channel, time_s);
}

void FlightRecorder::Impl::write_depth(const DepthSlot& slot) {
  json.clear();
  JsonWriter j(&json);
  j.begin_object();
  j.key("timestamp").time(slot.time_s);
  j.key("frame_id").string("camera");
  j.key("width").integer(depth_width).key("height").integer(depth_height);
  j.key("encoding").string("16UC1").key("step").integer(2 * depth_width);
  j.key("data").base64(slot.pixels.data(), slot.pixels.size() * 2);  // little-endian host
  j.end_object();
  write(depth_channel, slot.time_s);
  ++counts.depth_images;
}

void FlightRecorder::Impl::write_cloud(const CloudSlot& slot) {
  json.clear();
  JsonWriter j(&json);
  j.begin_object();
  j.key("timestamp").time(slot.time_s);
  j.key("frame_id").string("world");
  j.key("pose").pose(Eigen::Vector3d::Zero(), kIdentity);
  j.key("point_stride").integer(16);
  j.key("fields").begin_array();
  const char* names[4] = {"x", "y", "z", "value"};
  for (int f = 0; f < 4; ++f) {
    j.begin_object().key("name").string(names[f]).key("offset").integer(4 * f);
    j.key("type").integer(7).end_object();  // FLOAT32
  }
  j.end_array();
  j.key("data").base64(slot.xyzv.data(), slot.points * 16);
  j.end_object();
  write(occupied_channel, slot.time_s);
  ++counts.occupied_clouds;
}

void FlightRecorder::Impl::write_health(const hal::HealthSnapshot& h) {
  json.clear();
  JsonWriter j(&json);
  j.begin_object();
  j.key("timestamp").time(h.time_s);
  j.key("counters").begin_object();
  j.key("frames_in").integer(h.frames_in).key("frames_mapped").integer(h.frames_mapped);
  j.key("frames_rejected").integer(h.frames_rejected);
  j.key("frames_skipped_no_pose").integer(h.frames_skipped_no_pose);
  j.key("frames_dropped")
      .integer(h.frames_dropped())
      .key("deadline_misses")
      .integer(h.deadline_misses);
  j.key("poses_in").integer(h.poses_in).key("poses_rejected").integer(h.poses_rejected);
  j.key("heap_allocations_after_init").integer(h.heap_allocations_after_init);
  j.key("zones_allocated").integer(h.zones_allocated).key("features").integer(h.features);
  for (int i = 0; i < h.named; ++i) j.key(h.names[i]).integer(h.values[i]);
  j.end_object();
  j.key("latencies_ms").begin_object();
  j.key("mapping_p50").number(h.mapping_ms_p50).key("mapping_p99").number(h.mapping_ms_p99);
  j.key("end_to_end_p50").number(h.end_to_end_ms_p50);
  j.key("end_to_end_p99").number(h.end_to_end_ms_p99);
  j.end_object();
  j.end_object();
  write(health_channel, h.time_s);
  ++counts.health;
}

}  // namespace zonemap::record
