// The fast integration path (paper §III-B/C semantics without walking rays): each
// cell of the camera's frustum is visited once, projected into the depth image,
// and given the largest value of eq. (4)/(5) over the pixels whose rays can cross
// it, found with a min/max depth range table. The reference (LocalGrid::draw_ray)
// stays the definition; tests hold this path to it.
#pragma once

#include <cstdint>

#include <Eigen/Geometry>

#include "zonemap/camera.hpp"
#include "zonemap/config.hpp"
#include "zonemap/depth_range_table.hpp"
#include "zonemap/local_grid.hpp"

namespace zonemap {

class ProjectiveIntegrator {
 public:
  ProjectiveIntegrator(const MapConfig& config, const CameraModel& camera);

  // Writes the frame into `grid` (already reset to the environment). Returns the
  // number of cells evaluated.
  std::int64_t draw(const DepthRangeTable& depths, const Eigen::Isometry3d& world_T_camera,
                    LocalGrid& grid) const;

 private:
  // The largest m̂ over the pixels in [x0, x1] x [y0, y1] for a cell whose
  // δ-interval is [a, b]; below -1 when no ray reaches the cell.
  float best_value(const DepthRangeTable& depths, int x0, int y0, int x1, int y1, float a,
                   float b) const;
  float value_for_code(std::uint16_t code, float a, float b) const;
  // The reference rule over the pixels of the rectangle: each pixel's ray is
  // clipped to the cell (world box [lo, lo + s]) and m̂ maximised over that part.
  float exact_value(const DepthRangeTable& depths, int x0, int y0, int x1, int y1,
                    const Eigen::Isometry3d& world_T_camera, const Eigen::Vector3d& cell_lo) const;

  double cell_size_m_;
  float d_min_;
  float d_max_;
  float resolution_factor_;  // Δd = d² * factor (eq. 1)
  float code_to_m_;          // raw depth code -> metres
  CameraModel camera_;
};

}  // namespace zonemap
