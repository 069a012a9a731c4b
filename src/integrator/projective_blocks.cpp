// The block classes: each kBlock^3 cube of the local grid inside the frustum is
// mixed, free (every ray near it free across it) or unseen (no ray reaches it),
// from its own image box.
#include <algorithm>

#include "integrator/projective_detail.hpp"
#include "integrator/projective_geometry.hpp"

namespace zonemap {

// classify_blocks()'s constants for one frame, shared by its parts.
struct ProjectiveIntegrator::BlockSetup {
  double side = 0.0, half_z = 0.0;
  Eigen::Matrix3d rt;
  Eigen::Vector3d t, base, step_x_camera;
  Projection projection;
  Frustum frustum;
};

void ProjectiveIntegrator::classify_blocks(const DepthRangeTable& depths,
                                           const Eigen::Isometry3d& world_T_camera,
                                           const CellIndex& origin, WorkSplit* split) {
  const double side = cell_size_m_ * kBlock;
  const Eigen::Matrix3d rt = world_T_camera.linear().transpose();
  const Eigen::Vector3d t = world_T_camera.translation();
  const double half_z = 0.5 * side * rt.row(2).cwiseAbs().sum();
  // Corner offsets from a block's centre in the camera frame, four at a time.
  Projection projection = projection_for(camera_);
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3d o =
        rt * Eigen::Vector3d((k & 1) ? 0.5 * side : -0.5 * side, (k & 2) ? 0.5 * side : -0.5 * side,
                             (k & 4) ? 0.5 * side : -0.5 * side);
    projection.corner_x[k / 4][k % 4] = static_cast<float>(o.x());
    projection.corner_y[k / 4][k % 4] = static_cast<float>(o.y());
    projection.corner_z[k / 4][k % 4] = static_cast<float>(o.z());
  }
  // Blocks outside the frustum hold no cell that draw() visits: they stay mixed.
  std::fill_n(block_class_.get(), block_count_, kBlockMixed);
  const Frustum frustum = make_frustum(world_T_camera, camera_, d_min_, d_max_, side);
  const Eigen::Vector3d base = Eigen::Vector3d(origin.x, origin.y, origin.z) * cell_size_m_ +
                               Eigen::Vector3d::Constant(0.5 * side);  // centre of block (0, 0, 0)
  const Eigen::Vector3d step_x_camera = rt.col(0) * side;
  const BlockSetup b{side, half_z, rt, t, base, step_x_camera, projection, frustum};
  const int parts = split == nullptr ? 1 : std::min(split->parts(), kMaxParts);
  for_each_part(split, parts,
                [&](int part, int all) { classify_block_rows(depths, b, share_of(part, all)); });
}

void ProjectiveIntegrator::classify_block_rows(const DepthRangeTable& depths, const BlockSetup& b,
                                               RowShare share) const {
  const double side = b.side, half_z = b.half_z;
  const Eigen::Matrix3d& rt = b.rt;
  const Eigen::Vector3d& t = b.t;
  const Eigen::Vector3d& base = b.base;
  const Eigen::Vector3d& step_x_camera = b.step_x_camera;
  const Projection& projection = b.projection;
  const Frustum& frustum = b.frustum;
  for (int bz = share.first; bz < blocks_[2]; bz += share.step) {
    for (int by = 0; by < blocks_[1]; ++by) {
      const double wy = base.y() + by * side, wz = base.z() + bz * side;
      int bx_lo = 0, bx_hi = -1;
      if (!frustum.row(wy, wz, base.x(), 1.0 / side, blocks_[0], &bx_lo, &bx_hi)) continue;
      std::size_t i = static_cast<std::size_t>(bx_lo) +
                      static_cast<std::size_t>(blocks_[0]) *
                          (static_cast<std::size_t>(by) +
                           static_cast<std::size_t>(blocks_[1]) * static_cast<std::size_t>(bz));
      Eigen::Vector3d pc = rt * (Eigen::Vector3d(base.x() + bx_lo * side, wy, wz) - t);
      for (int bx = bx_lo; bx <= bx_hi; ++bx, ++i, pc += step_x_camera) {
        const double zc = pc.z();
        if (zc + half_z < d_min_ || zc - half_z > d_max_) continue;
        const PixelRect rect = project_cube(projection, static_cast<float>(pc.x()),
                                            static_cast<float>(pc.y()), static_cast<float>(zc));
        const int px0 = rect.x0, px1 = rect.x1, py0 = rect.y0, py1 = rect.y1;
        if (px0 > px1 || py0 > py1) {
          block_class_[i] = kBlockUnseen;
          continue;
        }
        std::uint16_t lo_code = 0, hi_code = 0;
        depths.range(px0, py0, px1, py1, &lo_code, &hi_code);
        if (lo_code > hi_code || (hi_code != DepthRangeTable::kFar &&
                                  reach(hi_code) < static_cast<float>(zc - half_z))) {
          block_class_[i] = kBlockUnseen;  // every pixel missing, or every ray ends before it
        } else if (free_across(lo_code, hi_code, static_cast<float>(zc + half_z))) {
          block_class_[i] = kBlockFree;
        }
      }
    }
  }
}

}  // namespace zonemap
