// The fast integration path (paper §III-B/C semantics without walking rays): each
// cell of the camera's frustum is visited once and settled by the cheapest test
// that can: its 4x4x4 block or a box around its footprint shows every pixel ray
// ends before it (nothing written) or is free across it (free); else the pixels
// whose rays can cross it (its eight projected corners) bound eq. (4)/(5) from
// above with a min/max depth range table, and that bound is written whenever the
// reference's value has its sign (found by probe rays, then ray by ray). The
// reference (LocalGrid::draw_ray) stays the definition; tests hold this path to
// it: the same sign, a value never below the reference's.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>

#include <Eigen/Geometry>

#include "zonemap/common/camera.hpp"
#include "zonemap/common/config.hpp"
#include "zonemap/common/work_split.hpp"
#include "zonemap/depth/depth_range_table.hpp"
#include "zonemap/integrator/local_grid.hpp"

namespace zonemap {

// What one frame cost, for the bench and the stats: how many cells the bounds
// settled and how many needed the ray-by-ray rule.
struct ProjectiveStats {
  std::int64_t cells_evaluated = 0;   // frustum cells whose footprint holds pixels
  std::int64_t cells_block_free = 0;  // free: settled by their block's bound and one ray
  std::int64_t cells_box_free = 0;    // free: settled by their own box's bound
  std::int64_t cells_hidden = 0;      // in the frustum, behind every surface: no ray reaches
  std::int64_t cells_exact = 0;  // settled ray by ray (bounds did not agree; edges seen through)
  std::int64_t rays_exact = 0;   // pixel rays clipped against those cells
  ProjectiveStats& operator+=(const ProjectiveStats& o) {
    cells_evaluated += o.cells_evaluated;
    cells_block_free += o.cells_block_free;
    cells_box_free += o.cells_box_free;
    cells_hidden += o.cells_hidden;
    cells_exact += o.cells_exact;
    rays_exact += o.rays_exact;
    return *this;
  }
};

class ProjectiveIntegrator {
 public:
  ProjectiveIntegrator(const MapConfig& config, const CameraModel& camera);

  // Writes the frame into `grid` (already reset to the environment). With a
  // split, the frustum's rows are shared among its parts (each writes cells of
  // its own rows only): the grid and the stats are the same for any split.
  ProjectiveStats draw(const DepthRangeTable& depths, const Eigen::Isometry3d& world_T_camera,
                       LocalGrid& grid, WorkSplit* split = nullptr);
  static constexpr int kMaxParts = 8;

  std::size_t reserved_bytes() const { return block_count_; }

  // Cells are classified in cubes of kBlock^3 first: in a cube every pixel ray
  // crosses in its free part, a cell is free as soon as one ray crosses it.
  static constexpr int kBlock = 4;
  static_assert((kBlock & (kBlock - 1)) == 0, "a power of two: block starts by masking");

 private:
  // The largest m̂ over the pixels in [x0, x1] x [y0, y1] for a cell whose
  // δ-interval is [a, b], given the rectangle's code range [lo, hi]; below -1
  // when no ray reaches the cell. A scan of the codes when they lie on both
  // sides of [a, b].
  float best_value(const DepthRangeTable& depths, int x0, int y0, int x1, int y1, std::uint16_t lo,
                   std::uint16_t hi, float a, float b) const;
  float value_for_code(std::uint16_t code, float a, float b) const;
  float far_end(std::uint16_t lo, std::uint16_t hi, float a, float b) const;
  // The reference rule over the pixels of the rectangle: each pixel's ray is
  // clipped to the cell (world box [lo, lo + s]) and m̂ maximised over that part.
  // `best` is a value known to be reached (a lower bound): parts of the footprint
  // that cannot beat it are skipped. Stops at the first ray that reaches
  // cell.enough_fixed; when none does, the result keeps the reference's sign and
  // is never below its value. Adds the rays it clipped to *rays.
  struct CellRays;
  // The depth codes whose rays reach [a, b] with m̂ >= 1 - s (see the definition).
  void codes_reaching(float a, float b, float s_lo, float s_hi, bool open_past_second_root,
                      std::uint16_t* lo, std::uint16_t* hi) const;
  struct ExactSearch;  // its two passes
  float exact_value(const DepthRangeTable& depths, int x0, int y0, int x1, int y1,
                    const CellRays& cell, float best, std::int64_t* rays) const;
  // Whether the ray of some usable pixel of the rectangle reaches into the cell
  // (the reference draws nothing into a cell that none crosses).
  bool any_ray_crosses(const DepthRangeTable& depths, int x0, int y0, int x1, int y1,
                       const CellRays& cell) const;
  // MapConfig::see_through: whether the ray of some pixel of the rectangle (its
  // largest code hi_code) crosses the cell wholly in its free part, and whether
  // some ray reaches the near peak in it (`lower`: a value some ray reaches).
  std::uint16_t first_code_free_beyond(float b) const;
  bool any_ray_free_across(const DepthRangeTable& depths, int x0, int y0, int x1, int y1,
                           std::uint16_t hi_code, const CellRays& cell) const;
  float near_peak_value(const DepthRangeTable& depths, int x0, int y0, int x1, int y1, float lower,
                        CellRays& cell, ProjectiveStats* stats) const;
  // MapConfig::see_through_behind: whether some ray that ended before the cell
  // reaches that near peak in it (past its measured depth).
  bool reaches_near_peak_behind(const DepthRangeTable& depths, int x0, int y0, int x1, int y1,
                                const CellRays& cell) const;
  // A kept cell that some ray crossed wholly free: the rays' exact maximum when
  // it lies below the footprint's bound `upper`.
  float exact_at_edge(const DepthRangeTable& depths, int x0, int y0, int x1, int y1, float upper,
                      float lower, CellRays& cell, ProjectiveStats* stats) const;

  // draw() in three parts: the frame's constants, the frustum's rows (in draw),
  // and one cell settled (free, the reference's sign, or left alone).
  struct FrameSetup;
  FrameSetup prepare_frame(const Eigen::Isometry3d& world_T_camera, const LocalGrid& grid) const;
  struct PartResult {
    ProjectiveStats stats;
    std::array<int, 3> touched_lo{INT32_MAX, INT32_MAX, INT32_MAX};
    std::array<int, 3> touched_hi{-1, -1, -1};
  };
  void draw_rows(const FrameSetup& f, const DepthRangeTable& depths, RowShare share,
                 LocalGrid& grid, PartResult* result) const;
  // A cell's tiers (settle_cell's parts, inlined into it).
  struct CellAt;
  std::uint16_t centre_code(const FrameSetup& f, const DepthRangeTable& depths, bool quick,
                            const Eigen::Vector3d& pc, int* looked_up) const;
  void set_cell_box(const FrameSetup& f, const CellAt& at, CellRays& cell) const;
  float probe_value(const FrameSetup& f, const DepthRangeTable& depths, const CellAt& at,
                    const Eigen::Vector3d& pc, const CellRays& cell) const;
  bool crossed(bool centre_reaches, const FrameSetup& f, const DepthRangeTable& depths,
               const CellAt& at, const Eigen::Vector3d& pc, CellRays& cell) const;
  float sign_settled_value(const FrameSetup& f, const DepthRangeTable& depths, const CellAt& at,
                           const Eigen::Vector3d& pc, CellRays& cell, ProjectiveStats* stats,
                           int* centre, float* probed) const;
  float seen_through_value(const FrameSetup& f, const DepthRangeTable& depths, const CellAt& at,
                           CellRays& cell, ProjectiveStats* stats, float value, float probed) const;
  void settle_cell(const FrameSetup& f, const DepthRangeTable& depths, std::uint8_t block, int x,
                   int y, int z, const Eigen::Vector3d& pc, CellRays& cell, LocalGrid& grid,
                   ProjectiveStats* stats) const;

  double cell_size_m_;
  // True when every ray of a depth in [lo, hi] (range-table codes) is still free
  // at δ = far_end.
  bool free_across(std::uint16_t lo_code, std::uint16_t hi_code, float far_end) const;
  float reach(std::uint16_t code) const;  // a real depth's ray ends here
  // One class per block of the local grid: mixed, free (every ray near it is
  // free across it) or unseen (no ray reaches it).
  void classify_blocks(const DepthRangeTable& depths, const Eigen::Isometry3d& world_T_camera,
                       const CellIndex& origin, WorkSplit* split);
  struct BlockSetup;
  void classify_block_rows(const DepthRangeTable& depths, const BlockSetup& b,
                           RowShare share) const;

  std::array<int, 3> blocks_{};
  std::size_t block_count_ = 0;
  std::unique_ptr<std::uint8_t[]> block_class_;
  std::array<PartResult, kMaxParts> parts_{};
  float d_min_;
  float d_max_;
  float resolution_factor_;      // Δd = d² * factor (eq. 1)
  float code_to_m_;              // raw depth code -> metres
  bool see_through_;             // MapConfig::see_through > 0
  int near_peak_fixed_;          // MapConfig::see_through in Q6
  int near_peak_behind_fixed_;   // MapConfig::near_peak_behind() in Q6 (<= near_peak_fixed_)
  std::uint16_t max_real_code_;  // the largest real depth code (d_max)
  CameraModel camera_;
};

}  // namespace zonemap
