#include "zonemap/integrator/projective_integrator.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

#include "integrator/projective_detail.hpp"
#include "integrator/projective_geometry.hpp"

namespace zonemap {

ProjectiveIntegrator::ProjectiveIntegrator(const MapConfig& config, const CameraModel& camera)
    : cell_size_m_(config.cell_size_m),
      blocks_{(config.zone_cells[0] + kBlock - 1) / kBlock,
              (config.zone_cells[1] + kBlock - 1) / kBlock,
              (config.zone_cells[2] + kBlock - 1) / kBlock},
      block_count_(static_cast<std::size_t>(blocks_[0]) * static_cast<std::size_t>(blocks_[1]) *
                   static_cast<std::size_t>(blocks_[2])),
      block_class_(new std::uint8_t[block_count_]()),
      d_min_(static_cast<float>(config.d_min_m)),
      d_max_(static_cast<float>(config.d_max_m)),
      resolution_factor_(
          static_cast<float>(camera.match_sigma_px / (camera.baseline_m * camera.fx))),
      code_to_m_(static_cast<float>(1.0 / camera.depth_scale)),
      see_through_(config.see_through > 0.0),
      near_peak_fixed_(to_fixed(static_cast<float>(config.see_through))),
      near_peak_behind_fixed_(
          std::min(near_peak_fixed_, to_fixed(static_cast<float>(config.near_peak_behind())))),
      max_real_code_(static_cast<std::uint16_t>(
          std::clamp(std::floor(config.d_max_m * camera.depth_scale), 1.0,
                     static_cast<double>(DepthRangeTable::kMaxDepthCode)))),
      camera_(camera) {}

// draw()'s constants for one frame: the camera-frame geometry of a grid cell,
// the frustum's rows, the probes and the pixel rays.
struct ProjectiveIntegrator::FrameSetup {
  double s = 0.0, inv_s = 0.0;
  CellIndex origin;
  Eigen::Matrix3d rt;
  Eigen::Vector3d t;
  Eigen::Vector3d half;  // half extents of a cell along the camera axes
  int w = 0, h = 0;
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  float fx_f = 0.0f, fy_f = 0.0f, cx_f = 0.0f, cy_f = 0.0f, cell_size = 0.0f;
  Frustum frustum;
  Eigen::Vector3d base;           // cell (x, y, z) has its centre at base + (x, y, z) * s
  Eigen::Vector3d step_x_camera;  // one cell along x, in the camera frame
  Projection projection;
  Lanes probe_x{}, probe_y{}, probe_z{};
  double quick_max_depth = 0.0;
  CellRays cell;  // the pixel rays in world axes (each cell sets its box)
};

// Inlined too, so that the frame's constants stay draw's own locals (the cell
// writes are bytes, which may alias anything the compiler cannot see is private).
__attribute__((always_inline)) inline ProjectiveIntegrator::FrameSetup
ProjectiveIntegrator::prepare_frame(const Eigen::Isometry3d& world_T_camera,
                                    const LocalGrid& grid) const {
  FrameSetup f;
  f.s = cell_size_m_;
  f.inv_s = 1.0 / f.s;
  const double s = f.s;
  f.origin = grid.origin();
  const Eigen::Matrix3d r = world_T_camera.linear();
  f.rt = r.transpose();
  f.t = world_T_camera.translation();
  // The camera-frame AABB of a cube.
  f.half = 0.5 * s * r.cwiseAbs().colwise().sum().transpose();
  f.w = camera_.width;
  f.h = camera_.height;
  f.fx = camera_.fx;
  f.fy = camera_.fy;
  f.cx = camera_.cx;
  f.cy = camera_.cy;
  // The frustum, widened by a cell's half diagonal: the cells worth a look.
  f.frustum = make_frustum(world_T_camera, camera_, d_min_, d_max_, s);
  f.base =
      (Eigen::Vector3d(f.origin.x, f.origin.y, f.origin.z) + Eigen::Vector3d::Constant(0.5)) * s;
  Eigen::Vector3d corners[8];
  for (int k = 0; k < 8; ++k) {
    corners[k] = f.rt * Eigen::Vector3d((k & 1) ? 0.5 * s : -0.5 * s, (k & 2) ? 0.5 * s : -0.5 * s,
                                        (k & 4) ? 0.5 * s : -0.5 * s);
  }
  f.step_x_camera = f.rt.col(0) * s;
  int far_corner = 0;  // the corner offset with the largest camera-frame z
  for (int k = 1; k < 8; ++k) {
    if (corners[k].z() > corners[far_corner].z()) far_corner = k;
  }
  f.projection = projection_for(camera_);
  for (int k = 0; k < 8; ++k) {
    f.projection.corner_x[k / 4][k % 4] = static_cast<float>(corners[k].x());
    f.projection.corner_y[k / 4][k % 4] = static_cast<float>(corners[k].y());
    f.projection.corner_z[k / 4][k % 4] = static_cast<float>(corners[k].z());
  }
  // Probe points relative to a cell's centre (camera frame): the centre, 3/4 of
  // the way to the farthest and to the nearest corner; lane 3 is replaced by the
  // footprint's centre.
  for (int i = 1; i < 3; ++i) {
    const Eigen::Vector3d o = (i == 1 ? 0.75 : -0.75) * corners[far_corner];
    f.probe_x[i] = static_cast<float>(o.x());
    f.probe_y[i] = static_cast<float>(o.y());
    f.probe_z[i] = static_cast<float>(o.z());
  }
  // Pixel rays in world axes, for the ray-by-ray rule.
  const Eigen::Matrix3f rf = r.cast<float>();
  const Eigen::Vector3f du = rf.col(0) / static_cast<float>(f.fx);
  const Eigen::Vector3f dv = rf.col(1) / static_cast<float>(f.fy);
  const Eigen::Vector3f w00 = rf * Eigen::Vector3f(static_cast<float>(-f.cx / f.fx),
                                                   static_cast<float>(-f.cy / f.fy), 1.0f);
  for (int k = 0; k < 3; ++k) {
    f.cell.rays.w00[k] = splat(w00[k]);
    f.cell.rays.du[k] = splat(du[k]);
    f.cell.rays.dv[k] = splat(dv[k]);
  }
  f.cell.rays.d_min = splat(d_min_);
  f.cell.rays.d_max = splat(d_max_);
  f.cell.rays.code_to_m = splat(code_to_m_);
  f.cell.rays.resolution_factor = splat(resolution_factor_);
  f.cell.rays.min_through = splat(kMinSeenThrough * static_cast<float>(s));
  f.cell_size = static_cast<float>(s);
  // The ray of the pixel nearest to a cell's projected centre passes within
  // 0.75 pixel of the centre: it crosses the cell while the cell spans > 1.5 px.
  f.quick_max_depth = s * std::min(f.fx, f.fy) / 1.5;
  f.fx_f = static_cast<float>(f.fx);
  f.fy_f = static_cast<float>(f.fy);
  f.cx_f = static_cast<float>(f.cx);
  f.cy_f = static_cast<float>(f.cy);
  return f;
}

ProjectiveStats ProjectiveIntegrator::draw(const DepthRangeTable& depths,
                                           const Eigen::Isometry3d& world_T_camera, LocalGrid& grid,
                                           WorkSplit* split) {
  classify_blocks(depths, world_T_camera, grid.origin(), split);
  const FrameSetup f = prepare_frame(world_T_camera, grid);
  const int parts = split == nullptr ? 1 : std::min(split->parts(), kMaxParts);
  for_each_part(split, parts, [&](int part, int all) {
    draw_rows(f, depths, share_of(part, all), grid, &parts_[static_cast<std::size_t>(part)]);
  });
  // Integer sums and bounds: the same whatever the number of parts.
  ProjectiveStats stats;
  PartResult all;
  for (int p = 0; p < parts; ++p) {
    stats += parts_[p].stats;
    for (int a = 0; a < 3; ++a) {
      all.touched_lo[a] = std::min(all.touched_lo[a], parts_[p].touched_lo[a]);
      all.touched_hi[a] = std::max(all.touched_hi[a], parts_[p].touched_hi[a]);
    }
  }
  if (all.touched_hi[0] >= 0) {
    grid.extend_touched(all.touched_lo[0], all.touched_lo[1], all.touched_lo[2], all.touched_hi[0],
                        all.touched_hi[1], all.touched_hi[2]);
  }
  return stats;
}

void ProjectiveIntegrator::draw_rows(const FrameSetup& setup, const DepthRangeTable& depths,
                                     RowShare share, LocalGrid& grid, PartResult* result) const {
  // The part's own copy: the cell writes are bytes, which may alias anything
  // whose address escaped, so constants read through a reference would be
  // reloaded for every cell.
  const FrameSetup f = setup;
  const std::array<int, 3> dims = grid.dims();
  CellRays cell = f.cell;
  PartResult part;  // a local for the same reason, stored at the end
  ProjectiveStats& stats = part.stats;
  int* touched_lo = part.touched_lo.data();
  int* touched_hi = part.touched_hi.data();
  for (int z = share.first; z < dims[2]; z += share.step) {
    for (int y = 0; y < dims[1]; ++y) {
      const double wy = f.base.y() + y * f.s, wz = f.base.z() + z * f.s;
      int xa = 0, xb = -1;
      if (!f.frustum.row(wy, wz, f.base.x(), f.inv_s, dims[0], &xa, &xb)) continue;
      touched_lo[0] = std::min(touched_lo[0], xa);
      touched_hi[0] = std::max(touched_hi[0], xb);
      touched_lo[1] = std::min(touched_lo[1], y);
      touched_hi[1] = std::max(touched_hi[1], y);
      touched_lo[2] = std::min(touched_lo[2], z);
      touched_hi[2] = std::max(touched_hi[2], z);
      Eigen::Vector3d pc = f.rt * (Eigen::Vector3d(f.base.x() + xa * f.s, wy, wz) - f.t);
      const std::uint8_t* block_row =
          block_class_.get() +
          static_cast<std::size_t>(blocks_[0]) *
              (static_cast<std::size_t>(y / kBlock) +
               static_cast<std::size_t>(blocks_[1]) * static_cast<std::size_t>(z / kBlock));
      for (int x = xa; x <= xb; ++x, pc += f.step_x_camera) {
        const std::uint8_t block = block_row[static_cast<unsigned>(x) / kBlock];  // x >= 0
        if (block == kBlockUnseen) {
          // The rest of the block at once: no ray reaches any of its cells.
          const int last = std::min(xb, (x & ~(kBlock - 1)) + kBlock - 1);
          stats.cells_hidden += last - x + 1;
          pc += static_cast<double>(last - x) * f.step_x_camera;
          x = last;
          continue;
        }
        settle_cell(f, depths, block, x, y, z, pc, cell, grid, &stats);
      }
    }
  }
  *result = part;
}

// Where one cell of the walk stands: its indices and its footprint (the pixels
// whose rays can cross it) with their depth range.
struct ProjectiveIntegrator::CellAt {
  int x, y, z;
  int px0, py0, px1, py1;
  std::uint16_t lo_code, hi_code;
  bool quick;  // the centre pixel's ray surely crosses the cell
};

// The code of the pixel nearest to the cell centre's image when its ray surely
// crosses the cell (quick), else kMissing; looked up once a cell (the block
// test, the box test and U < 0 may each ask): *looked_up caches it.
__attribute__((always_inline)) inline std::uint16_t ProjectiveIntegrator::centre_code(
    const FrameSetup& f, const DepthRangeTable& depths, bool quick, const Eigen::Vector3d& pc,
    int* looked_up) const {
  if (*looked_up >= 0) return static_cast<std::uint16_t>(*looked_up);
  std::uint16_t code = DepthRangeTable::kMissing;
  if (quick) {
    const double inv_z = 1.0 / pc.z();
    const double uc = f.fx * pc.x() * inv_z + f.cx, vc = f.fy * pc.y() * inv_z + f.cy;
    if (uc > -0.5 && vc > -0.5 && uc < f.w - 0.5 && vc < f.h - 0.5)
      code = depths.codes()[static_cast<std::size_t>(vc + 0.5) * f.w +
                            static_cast<std::size_t>(uc + 0.5)];
  }
  *looked_up = code;
  return code;
}

__attribute__((always_inline)) inline void ProjectiveIntegrator::set_cell_box(
    const FrameSetup& f, const CellAt& at, CellRays& cell) const {
  const Eigen::Vector3f cell_lo =
      (Eigen::Vector3d(f.origin.x + at.x, f.origin.y + at.y, f.origin.z + at.z) * f.s - f.t)
          .cast<float>();
  for (int k = 0; k < 3; ++k) {
    cell.rays.lo[k] = splat(cell_lo[k]);
    cell.rays.hi[k] = splat(cell_lo[k] + f.cell_size);
  }
}

// Probes, four rays at once: through the centre, through points near the
// corners farthest from and nearest to the camera (the rays that leave the cell
// last and enter it first), and through the centre of the footprint. Their
// largest m̂ in the cell (cell.rays set): a value some ray reaches.
__attribute__((always_inline)) inline float ProjectiveIntegrator::probe_value(
    const FrameSetup& f, const DepthRangeTable& depths, const CellAt& at, const Eigen::Vector3d& pc,
    const CellRays& cell) const {
  const auto pxf = static_cast<float>(pc.x()), pyf = static_cast<float>(pc.y()),
             pzf = static_cast<float>(pc.z());
  const Lanes qx = splat(pxf) + f.probe_x, qy = splat(pyf) + f.probe_y, qz = splat(pzf) + f.probe_z;
  const Lanes footprint_u = splat(0.5f * static_cast<float>(at.px0 + at.px1));
  const Lanes footprint_v = splat(0.5f * static_cast<float>(at.py0 + at.py1));
  const auto ahead = qz > 1e-6f;
  Lanes pu = ahead ? splat(f.fx_f) * qx / qz + splat(f.cx_f) : footprint_u;
  Lanes pv = ahead ? splat(f.fy_f) * qy / qz + splat(f.cy_f) : footprint_v;
  pu[3] = footprint_u[3];
  pv[3] = footprint_v[3];
  // Rounded to the nearest pixel of the footprint (clamped first: in range).
  pu = lanes_min(lanes_max(pu, splat(static_cast<float>(at.px0))),
                 splat(static_cast<float>(at.px1)));
  pv = lanes_min(lanes_max(pv, splat(static_cast<float>(at.py0))),
                 splat(static_cast<float>(at.py1)));
  using Ints = std::int32_t __attribute__((vector_size(16)));
  const Ints pixel_u = __builtin_convertvector(pu + 0.5f, Ints);  // >= 0: truncation
  const Ints pixel_v = __builtin_convertvector(pv + 0.5f, Ints);  // rounds
  pu = __builtin_convertvector(pixel_u, Lanes);
  pv = __builtin_convertvector(pixel_v, Lanes);
  const Ints pixel = pixel_v * f.w + pixel_u;
  const std::uint16_t* codes = depths.codes();
  const Ints code_ints = {codes[pixel[0]], codes[pixel[1]], codes[pixel[2]], codes[pixel[3]]};
  const Lanes probe_code = __builtin_convertvector(code_ints, Lanes);
  return lanes_hmax(rays_best(pu, pv, probe_code, cell.rays));
}

// Whether a real ray reaches into the cell: the reference draws nothing into a
// cell that none crosses, and the footprint box is wider than the cell's
// silhouette. `centre_reaches` settles it for the centre pixel's ray, else the
// probes and then the footprint's rays are clipped until one crosses.
__attribute__((always_inline)) inline bool ProjectiveIntegrator::crossed(
    bool centre_reaches, const FrameSetup& f, const DepthRangeTable& depths, const CellAt& at,
    const Eigen::Vector3d& pc, CellRays& cell) const {
  if (centre_reaches) return true;
  set_cell_box(f, at, cell);
  if (probe_value(f, depths, at, pc, cell) >= -1.0f) return true;
  return any_ray_crosses(depths, at.px0, at.py0, at.px1, at.py1, cell);
}

// Inlined into draw's row loop: it is the per-cell body, apart only for reading.
__attribute__((always_inline)) inline void ProjectiveIntegrator::settle_cell(
    const FrameSetup& f, const DepthRangeTable& depths, std::uint8_t block, int x, int y, int z,
    const Eigen::Vector3d& pc, CellRays& cell, LocalGrid& grid, ProjectiveStats* stats) const {
  const double zc = pc.z();
  const double a = std::max(zc - f.half.z(), static_cast<double>(d_min_));
  const double b = zc + f.half.z();
  if (b < d_min_ || a > d_max_) return;
  // The bulk of the frustum is free space or hidden behind surfaces. When
  // every pixel ray near the cell is free across it, the cell is free if one
  // of them, a real one, crosses it: known for its whole block (then the
  // centre pixel's ray, real and crossing the cell, saves projecting it), or
  // from the depth range over the cell's footprint (best_value's bound is
  // then exactly -1). When every such ray ends before the cell, nothing
  // reaches it.
  const bool quick = zc - f.half.z() >= d_min_ && zc <= f.quick_max_depth;
  int centre = -1;  // centre_code's cache
  if (block == kBlockFree &&
      centre_code(f, depths, quick, pc, &centre) != DepthRangeTable::kMissing) {
    ++stats->cells_evaluated;
    ++stats->cells_block_free;
    grid.write_max(x, y, z, static_cast<LocalCell>(-kCellScale));
    return;
  }
  // The image box of the cube's eight projected corners: the pixels whose
  // rays can cross the cell.
  const PixelRect rect = project_cube(f.projection, static_cast<float>(pc.x()),
                                      static_cast<float>(pc.y()), static_cast<float>(pc.z()));
  if (rect.x0 > rect.x1 || rect.y0 > rect.y1) return;  // no pixel sees the cell
  std::uint16_t lo_code = 0, hi_code = 0;
  depths.range(rect.x0, rect.y0, rect.x1, rect.y1, &lo_code, &hi_code);
  if (lo_code > hi_code) return;  // every pixel near it missing
  if (hi_code != DepthRangeTable::kFar && reach(hi_code) < static_cast<float>(a)) {
    ++stats->cells_hidden;  // every ray ends before the cell
    return;
  }
  cell.a = static_cast<float>(a);
  cell.b = static_cast<float>(b);
  ++stats->cells_evaluated;
  const CellAt at{x, y, z, rect.x0, rect.y0, rect.x1, rect.y1, lo_code, hi_code, quick};
  if (free_across(lo_code, hi_code, static_cast<float>(b))) {
    // What best_value gives here, without its scan. Every ray near the cell
    // is free past it: a real centre ray crosses it.
    const bool centre_reaches =
        centre_code(f, depths, quick, pc, &centre) != DepthRangeTable::kMissing;
    if (!crossed(centre_reaches, f, depths, at, pc, cell)) return;
    ++stats->cells_box_free;
    grid.write_max(x, y, z, static_cast<LocalCell>(-kCellScale));
    return;
  }
  float probed = kNoRay;  // the probes' value, when U >= 0 asked for it
  float value = sign_settled_value(f, depths, at, pc, cell, stats, &centre, &probed);
  if (value < -1.0f) return;
  if (see_through_ && to_fixed(value) > -kCellScale) {
    value = seen_through_value(f, depths, at, cell, stats, value, probed);
  }
  grid.write_max(x, y, z, to_local_cell(value));
}

// An upper bound U from the footprint's depth range (exact when it says free).
// The cell gets U whenever the reference's value has U's sign: a value never
// below the reference's (near a surface, a little more occupied or less free:
// the safe side), at the sign the reference gives. Below -1: nothing written.
__attribute__((always_inline)) inline float ProjectiveIntegrator::sign_settled_value(
    const FrameSetup& f, const DepthRangeTable& depths, const CellAt& at, const Eigen::Vector3d& pc,
    CellRays& cell, ProjectiveStats* stats, int* centre, float* probed) const {
  float value =
      best_value(depths, at.px0, at.py0, at.px1, at.py1, at.lo_code, at.hi_code, cell.a, cell.b);
  const int upper_fixed = to_fixed(value);
  if (value > -1.0f && upper_fixed >= 0) {
    // U < 0 settles the sign: every ray gives at most U. U >= 0 may claim a
    // surface (or an unknown 0) where the rays that really cross the cell are
    // all free. Probe rays give a lower bound; when it rounds to U's sign the
    // sign is settled, else the rays are looked at one by one, as the
    // reference does, until one does.
    set_cell_box(f, at, cell);
    cell.enough_fixed = upper_fixed > 0 ? 1 : 0;
    const float lower = probe_value(f, depths, at, pc, cell);
    *probed = lower;
    if (lower < -1.0f || to_fixed(lower) < cell.enough_fixed) {
      ++stats->cells_exact;
      const float found =
          exact_value(depths, at.px0, at.py0, at.px1, at.py1, cell, lower, &stats->rays_exact);
      if (to_fixed(found) < cell.enough_fixed) value = found;  // a lower sign: exact
    }
  } else if (value >= -1.0f) {
    // U < 0, if a ray reaches the cell: the centre's does when it ends past b.
    const std::uint16_t code = centre_code(f, depths, at.quick, pc, centre);
    const bool centre_reaches =
        code != DepthRangeTable::kMissing &&
        (code == DepthRangeTable::kFar ? cell.b <= d_max_ : reach(code) >= cell.b);
    if (!crossed(centre_reaches, f, depths, at, pc, cell)) return kNoRay;
  }
  return value;
}

// MapConfig::see_through: a ray crossed the cell wholly free and none came near
// its depth in it: free. `value` bounds every ray's m̂ from above; the probes
// (asked whenever value >= 0), when they reach the near peak, keep the cell
// without a search.
__attribute__((always_inline)) inline float ProjectiveIntegrator::seen_through_value(
    const FrameSetup& f, const DepthRangeTable& depths, const CellAt& at, CellRays& cell,
    ProjectiveStats* stats, float value, float probed) const {
  set_cell_box(f, at, cell);
  const int x0 = at.px0, y0 = at.py0, x1 = at.px1, y1 = at.py1;
  const bool may_reach = to_fixed(value) >= near_peak_fixed_;
  const float lower = probed;
  const bool probes_near = lower >= -1.0f && to_fixed(lower) >= near_peak_fixed_;
  // The probes reaching U: kept at its exact value, whether seen through or not.
  const bool settled = probes_near && to_fixed(lower) >= to_fixed(value);
  if (settled || !any_ray_free_across(depths, x0, y0, x1, y1, at.hi_code, cell)) return value;
  // Some ray reaches the near peak (or, behind its depth, the lower bar): kept,
  // from the best value found so far; else seen through.
  float near = probes_near ? lower : kNoRay;
  if (!probes_near && may_reach) near = near_peak_value(depths, x0, y0, x1, y1, lower, cell, stats);
  const bool kept =
      (near >= -1.0f && to_fixed(near) >= near_peak_fixed_) ||
      (near_peak_behind_fixed_ < near_peak_fixed_ && to_fixed(value) >= near_peak_behind_fixed_ &&
       reaches_near_peak_behind(depths, x0, y0, x1, y1, cell));
  // A search that did not reach the near peak found the exact maximum.
  const bool near_exact =
      !probes_near && may_reach && near >= -1.0f && to_fixed(near) < near_peak_fixed_;
  if (!kept) return -1.0f;
  if (near_exact) return std::min(value, near);
  if (to_fixed(value) > 0) {
    return exact_at_edge(depths, x0, y0, x1, y1, value, std::max(lower, near), cell, stats);
  }
  return value;
}

}  // namespace zonemap
