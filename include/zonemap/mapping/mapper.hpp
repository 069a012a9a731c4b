// One mapping step (paper §III): depth frame + camera pose -> local grid M̂
// (sensor model, ray traversal, max-write, blur) -> fused into the zones (eq. 7).
// Everything is reserved in the constructor; integrate() does not allocate,
// lock, throw or do I/O, and its loops are bounded by the image and grid sizes.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Geometry>

#include "zonemap/common/camera.hpp"
#include "zonemap/common/config.hpp"
#include "zonemap/depth/depth_filter.hpp"
#include "zonemap/depth/depth_range_table.hpp"
#include "zonemap/depth/sky_filter.hpp"
#include "zonemap/integrator/local_grid.hpp"
#include "zonemap/integrator/projective_integrator.hpp"
#include "zonemap/zones/zone_map.hpp"

namespace zonemap {

struct DepthFrameView {
  const std::uint16_t* depth = nullptr;  // row-major, width x height, 0 = no measurement
  const std::uint8_t* left = nullptr;    // optional left intensity image, same size
  int width = 0;
  int height = 0;
};

enum class FrameStatus : std::uint8_t {
  kMapped,
  kBadPose,   // non-finite or non-rigid pose: nothing mapped
  kBadFrame,  // missing buffer or size different from the camera model
};

struct FrameReport {
  FrameStatus status = FrameStatus::kMapped;
  std::int32_t rays_hit = 0;    // pixels with a depth in [d_min, d_max]
  std::int32_t rays_free = 0;   // depth beyond d_max, or sky: free up to d_max
  std::int32_t pixels_sky = 0;  // missing depth classified as sky
  // Missing depth, bright and flat, but not where sky can be (SkyFilter: below
  // the horizon, under or resting on a measured surface): left unknown.
  std::int32_t pixels_sky_refused = 0;
  std::int32_t pixels_missing = 0;   // missing depth, not sky: ignored
  std::int32_t pixels_too_near = 0;  // depth below d_min: ignored
  std::int32_t zones_allocated = 0;
  std::int64_t cells_visited = 0;
  std::int64_t cells_block_free = 0;  // projective path: free, settled by the block bound
  std::int64_t cells_box_free = 0;    // projective path: free, settled by the cell's box
  std::int64_t cells_hidden = 0;      // projective path: behind every surface, skipped
  std::int64_t cells_exact = 0;       // projective path: cells settled ray by ray
  std::int64_t rays_exact = 0;        // projective path: rays clipped for them
  // Every kBelowSampleStep-th pixel of each kBelowSampleStep-th row: its measured
  // depths (in [d_min, d_max]), and those ending more than a cell under the
  // environment's bottom face (the ground the camera sees is out of the map's reach).
  std::int32_t sampled_hits = 0;
  std::int32_t sampled_hits_below_environment = 0;
};

inline constexpr int kBelowSampleStep = 8;
// A frame whose sampled hits end under the environment this often has the
// ground out of reach (counted and warned about by the programs).
inline constexpr double kGroundBelowShare = 0.25;
inline bool ground_below_environment(const FrameReport& report) {
  return report.sampled_hits > 0 &&
         report.sampled_hits_below_environment > kGroundBelowShare * report.sampled_hits;
}

// True when the pose is finite and its rotation is orthonormal with det +1.
bool is_valid_pose(const Eigen::Isometry3d& pose);

class Mapper {
 public:
  // `config` must have passed validate(); the camera must fit kMaxImage*.
  Mapper(const MapConfig& config, const CameraModel& camera);

  FrameReport integrate(const DepthFrameView& frame, const Eigen::Isometry3d& world_T_camera);
  // Shares the projective frustum walk and the fusion among a split's parts (nullptr: one
  // part, on the calling thread). The map is the same either way.
  void set_work_split(WorkSplit* split) { split_ = split; }

  // The world cell that contains a world point.
  CellIndex cell_of(const Eigen::Vector3d& point) const;
  Eigen::Vector3d cell_center(const CellIndex& cell) const;

  ZoneMap& zones() { return zones_; }
  const ZoneMap& zones() const { return zones_; }
  const LocalGrid& local_grid() const { return local_; }
  const MapConfig& config() const { return config_; }
  const CameraModel& camera() const { return camera_; }
  // The projective path's depth range table and block flags.
  std::size_t depth_table_bytes() const {
    return depths_.reserved_bytes() + projective_.reserved_bytes() +
           kMaxDepthParts *
               (filter_.reserved_bytes() + 3 * static_cast<std::size_t>(camera_.width)) +
           sky_.reserved_bytes();
  }
  std::size_t reserved_bytes() const {
    return zones_.reserved_bytes() + local_.reserved_bytes() + depth_table_bytes();
  }

  FusedCell occupied_threshold() const { return occupied_threshold_; }
  // Every occupied cell of the zones holding a grid: fn(cell centre, fused value).
  template <typename Fn>
  void for_each_occupied_cell(Fn&& fn) {
    zones_.for_each_live_zone([&](ZoneView& zone) {
      for (int z = 0; z < zone.dims[2]; ++z)
        for (int y = 0; y < zone.dims[1]; ++y)
          for (int x = 0; x < zone.dims[0]; ++x) {
            const FusedCell v = zone.cells[zone.index(x, y, z)];
            if (v <= occupied_threshold_) continue;
            fn(cell_center(CellIndex{zone.origin.x + x, zone.origin.y + y, zone.origin.z + z}), v);
          }
    });
  }
  FusedCell free_threshold() const { return free_threshold_; }

 private:
  // The two integration paths, each drawing the frame into the local grid: the
  // projective one (the depth table, then every frustum cell once) and the
  // reference (every pixel_step-th pixel's ray walked).
  void integrate_projective(const DepthFrameView& frame, const Eigen::Isometry3d& world_T_camera,
                            FrameReport* report);
  // Level 0 of the depth table from the frame, sky marked, pixels counted: in
  // bands of rows, one per part of the work split.
  void classify_depths(const DepthFrameView& frame, FrameReport* report);
  struct DepthCounts {
    std::int32_t hit = 0, near = 0, far = 0, missing = 0, sky = 0, sky_refused = 0;
  };
  // Rows [first, end) of classify_depths, with a part's own filter and sky rows.
  DepthCounts classify_rows(const DepthFrameView& frame, int first, int end, DepthFilter& filter,
                            std::uint8_t* sky_flags);
  void integrate_reference(const DepthFrameView& frame, const Eigen::Vector3f& start,
                           const Eigen::Matrix3f& rotation_cells, FrameReport* report);
  // FrameReport's sampled_hits*: where the sampled measurements end against the
  // bottom face of the environment at `origin`.
  void sample_hits_below(const DepthFrameView& frame, const Eigen::Isometry3d& world_T_camera,
                         const CellIndex& origin, FrameReport* report) const;
  // The frame's local grid blurred, weighted by range (when configured), fused.
  void finish_and_fuse(const Eigen::Vector3f& camera_cells,
                       const Eigen::Isometry3d& world_T_camera);

  MapConfig config_;
  CameraModel camera_;
  LocalGrid local_;
  ZoneMap zones_;
  // The parts classify_depths splits into at most (its own filters and sky rows each).
  static constexpr int kMaxDepthParts = 8;
  DepthFilter filter_;                     // rows as the sensor model reads them (part 0's)
  std::vector<DepthFilter> part_filters_;  // parts 1 ..
  DepthRangeTable depths_;
  ProjectiveIntegrator projective_;
  FusedCell occupied_threshold_;
  FusedCell free_threshold_;
  SkyFilter sky_;                              // where bright flat pixels may be sky
  std::unique_ptr<std::uint8_t[]> sky_flags_;  // candidate_row's three rows, per part
  std::array<DepthCounts, kMaxDepthParts> part_counts_{};
  WorkSplit* split_ = nullptr;
  std::uint16_t raw_near_last_ = 0;   // raw depths <= this are below d_min (0: none)
  std::uint16_t raw_far_last_ = 0;    // raw depths above this are beyond d_max
  float full_weight_depth_m_ = 0.0f;  // range weighting: full weight up to here
};

}  // namespace zonemap
