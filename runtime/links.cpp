// The links between the stages, reserved and connected at start-up.
#include "runtime/links.hpp"

namespace zonemap::runtime {
namespace {

std::size_t frame_bytes(const hal::CameraFrame& frame) {
  return frame.depth.capacity() * sizeof(std::uint16_t) + frame.left.capacity();
}

}  // namespace

Links::Links(hal::FrameSource& source, const MapConfig& config, std::size_t boxes,
             std::size_t footprint_rects) {
  filled.connect(&acquisition_bell, &mapping_bell);
  free_slots.connect(&mapping_bell, &acquisition_bell);
  snapshot_free.connect(&extraction_bell, &mapping_bell);
  jobs.connect(&mapping_bell, &extraction_bell);
  reintegration.connect(&extraction_bell, &mapping_bell);
  out_filled.connect(&extraction_bell, &output_bell);
  out_free.connect(&output_bell, &mapping_bell);
  for (auto& frame : frames) frame = source.make_frame();
  for (std::uint32_t i = 0; i < kFrameSlots; ++i) free_slots.push(i);
  for (std::uint32_t i = 0; i < kSnapshotSlots; ++i) {
    snapshots.push_back(
        std::make_unique<ZoneSnapshot>(config.zone_cells, coarse_level_step(config)));
    snapshot_free.push(i);
  }
  for (auto& out : outputs) {
    out.boxes.resize(boxes);
    out.rects.resize(footprint_rects);
    out.rect_offsets.resize(boxes);
    out.rect_counts.resize(boxes);
  }
  for (std::uint32_t i = 0; i < kOutputSlots; ++i) out_free.push(i);
}

std::size_t Links::reserved_bytes() const {
  std::size_t bytes = sizeof(Links);
  for (const auto& frame : frames) bytes += frame_bytes(frame);
  for (const auto& snapshot : snapshots) bytes += snapshot->reserved_bytes();
  for (const auto& out : outputs) {
    bytes += out.boxes.capacity() * sizeof(ObstacleBox) +
             out.rects.capacity() * sizeof(FootprintRect) +
             (out.rect_offsets.capacity() + out.rect_counts.capacity()) * sizeof(std::uint32_t);
  }
  return bytes;
}

hal::ObstacleUpdate OutputBuffer::update(bool world_z_up) const {
  hal::ObstacleUpdate u;
  u.time_s = time_s;
  u.world_T_body = world_T_body;
  u.world_z_up = world_z_up;
  u.boxes = boxes.data();
  u.count = count;
  u.rects = rects.data();
  u.rect_offsets = rect_offsets.data();
  u.rect_counts = rect_counts.data();
  u.sectors_observed = sectors_observed;
  return u;
}

Eigen::Isometry3d ExtractionJob::camera_pose() const {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::Map<const Eigen::Matrix3d>(camera_rotation);
  pose.translation() = Eigen::Map<const Eigen::Vector3d>(camera_position);
  return pose;
}

void SharedInsCounters::store(const hal::PoseSourceCounters& c) {
  messages.store(c.messages, std::memory_order_relaxed);
  malformed.store(c.malformed, std::memory_order_relaxed);
  solutions.store(c.solutions, std::memory_order_relaxed);
  poses_out.store(c.poses_out, std::memory_order_relaxed);
  link_errors.store(c.link_errors, std::memory_order_relaxed);
  rejected.store(c.gate.rejected_total(), std::memory_order_relaxed);
  reanchors.store(c.gate.reanchors, std::memory_order_relaxed);
}

}  // namespace zonemap::runtime
