// The local grid M̂ of paper §III-C: one frame's rays drawn around the camera
// with max-write, then a gaussian (binomial) blur. Fixed point, see cell.hpp.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>

#include <Eigen/Core>

#include "zonemap/common/cell.hpp"
#include "zonemap/common/work_split.hpp"
#include "zonemap/depth/sensor_model.hpp"

namespace zonemap {

class LocalGrid {
 public:
  // Reserves the cells (and the blur's scratch row) once. dims must each be >= 1.
  explicit LocalGrid(const std::array<int, 3>& dims);

  // Starts a new frame with its minimum corner at world cell `origin`.
  void reset(const CellIndex& origin);

  // Draws one ray by exact voxel traversal. `start` is the ray origin and
  // `direction` the change of position per metre of δ, both in grid units (cells,
  // relative to the grid's minimum corner). Parts outside the grid are omitted.
  // Returns the number of cells visited (bounded by the sum of the dimensions).
  int draw_ray(const Eigen::Vector3f& start, const Eigen::Vector3f& direction,
               const RayProfile& ray);

  // Max-write of one fixed-point value (exposed for tests and feature re-integration).
  void write_max(int x, int y, int z, LocalCell value) {  // within extend_touched's region
    LocalCell& cell = cells_[index(x, y, z)];
    if (cell == kUntouched || value > cell) cell = value;
  }

  // MapConfig::see_through for draw_ray: from now on each cell remembers whether
  // a ray crossed it wholly free and whether one reached `near_peak` (Q6) in it,
  // or `near_peak_behind` past its measured depth, and finish() first frees the
  // cells seen through and never near a peak. Reserves a byte per cell: call at
  // start-up.
  void enable_see_through(LocalCell near_peak, LocalCell near_peak_behind);

  // Widens the region that finish() and fusion work on to hold [lo, hi] (grid
  // cells, clipped). Every writer says where it wrote; cells outside stay untouched.
  void extend_touched(int x0, int y0, int z0, int x1, int y1, int z1);

  // Turns untouched cells of the touched region (grown by the blur radius) into 0
  // (unknown) and applies the separable binomial blur of the given radius (1:
  // [1 2 1]/4, 2: [1 4 6 4 1]/16) along x, y and z there. Values outside count as
  // unknown (0). Rounds half away from zero. A pass makes no cell free that was
  // not free before it: an unknown (no ray saw it) or occupied cell takes its
  // neighbours' occupancy but their free space at most down to unknown (free space
  // blurred into the cells behind a surface would call the inside of a trunk free).
  // With a split, its parts share each of the blur's steps (rows, planes of
  // their own): the grid is the same for any split.
  // With `near` (MapConfig::blur_keep_near_m), a cell whose centre lies within
  // near->depth_m along the optical axis keeps at least half the occupancy it
  // had before the blur; enable_near_keep reserves for it.
  struct NearKeep {
    Eigen::Vector3f camera;         // grid units (cell centres at + 0.5)
    Eigen::Vector3f axis_per_cell;  // the optical axis times the cell size
    float depth_m = 0.0f;
  };
  void finish(int blur_radius, WorkSplit* split = nullptr, const NearKeep* near = nullptr);
  // Reserves the cube finish() may keep cells of around the camera, 2 half_cells
  // + 1 a side (half_cells at most MapConfig::kMaxKeepNearCells): at start-up.
  void enable_near_keep(int half_cells);
  static constexpr int kMaxFinishParts = 8;
  static constexpr int kMaxBlurRadius = 2;

  // Past the paper (eq. 7 adds every view alike), after finish(): each positive
  // cell scaled by how sharply its view places a surface,
  // w = clamp((δ_full/δ)², min_weight, 1) with δ the cell centre's depth along the
  // optical axis (the floor keeps what only far views ever see, e.g. tree tops
  // passed under, from fading below the occupied threshold). Δd grows with δ² (eq. 1),
  // so a view from twice as far says a quarter as much about where the surface is;
  // free evidence keeps its full weight (the ray did pass). `camera` is in grid
  // units, `axis_per_cell` the optical axis times the cell size (metres of δ per
  // grid unit). A positive cell stays at least 1 (a weak hint, never unknown).
  void weight_occupancy_by_range(const Eigen::Vector3f& camera,
                                 const Eigen::Vector3f& axis_per_cell, float full_weight_depth_m,
                                 float min_weight);
  // The region finish() worked on (inclusive grid cells); empty when lo > hi.
  const std::array<int, 3>& active_lo() const { return active_lo_; }
  const std::array<int, 3>& active_hi() const { return active_hi_; }

  // After finish(): the cells of row (y, z) that may be non-zero, [*x_lo, *x_hi]
  // (grid x, within the active region); false when the whole row is 0, so that
  // fusion passes it over. Cells outside the span are 0.
  bool row_span(int y, int z, int* x_lo, int* x_hi) const {
    const RowSpan& span = spans_[span_index(y, z)];
    *x_lo = span.lo;
    *x_hi = span.hi;
    return span.lo <= span.hi;
  }

  // A cell's value after finish(); cells no frame touched read as unknown (0).
  LocalCell at(int x, int y, int z) const {
    const LocalCell v = cells_[index(x, y, z)];
    return v == kUntouched ? LocalCell{0} : v;
  }
  const LocalCell* data() const { return cells_.get(); }
  const std::array<int, 3>& dims() const { return dims_; }
  const CellIndex& origin() const { return origin_; }
  std::size_t cell_count() const { return cell_count_; }
  std::size_t reserved_bytes() const;

  std::size_t index(int x, int y, int z) const {
    return static_cast<std::size_t>(x) +
           static_cast<std::size_t>(dims_[0]) *
               (static_cast<std::size_t>(y) +
                static_cast<std::size_t>(dims_[1]) * static_cast<std::size_t>(z));
  }

 private:
  bool clip_to_grid(const Eigen::Vector3f& start, const Eigen::Vector3f& direction, float* t0,
                    float* t1) const;
  void finish_rows(int radius, RowShare share, int part);
  void blur_x_row(int y, int z, int radius, int part);
  // y (rows) or z (planes), vectorisable over x; the share's sheets only.
  void blur_across(int axis, int radius, RowShare share, int part);
  struct RowSpan;
  // One sheet (a fixed coordinate o on the other axis) of blur_across, per kernel.
  void blur_sheet_121(int axis, int o, int part, RowSpan saved_span[2]);
  void blur_sheet_wide(int axis, int radius, int o, int part);
  // Row c of sheet o along `axis` (1: y, 2: z), from the active region's x0.
  LocalCell* sheet_row(int axis, int c, int o) {
    return cells_.get() + (axis == 1 ? index(active_lo_[0], c, o) : index(active_lo_[0], o, c));
  }
  RowSpan& sheet_span(int axis, int c, int o) {
    return spans_[axis == 1 ? span_index(c, o) : span_index(o, c)];
  }
  void free_cells_seen_through();  // the touched region; clears the marks for the next frame
  void record_near(const NearKeep& near);  // the cube around the camera, before the blur
  void restore_near();                     // ... each at least half of it after
  LocalCell* saved_rows(int part) {        // a part's 2 * kMaxBlurRadius + 1 scratch rows
    return saved_.get() + static_cast<std::size_t>(part) * static_cast<std::size_t>(dims_[0]) *
                              (2 * kMaxBlurRadius + 1);
  }

  std::array<int, 3> dims_;
  std::size_t cell_count_;
  CellIndex origin_;
  std::unique_ptr<LocalCell[]> cells_;
  // see_through: per cell, kSeenThrough | kNearPeak marks of this frame's rays.
  static constexpr std::uint8_t kSeenThrough = 1, kNearPeak = 2;
  std::unique_ptr<std::uint8_t[]> through_marks_;
  LocalCell near_peak_ = 0;
  LocalCell near_peak_behind_ = 0;  // <= near_peak_
  // Scratch, one of each per part of the blur (kMaxFinishParts):
  std::unique_ptr<std::int16_t[]> line_;  // one x line of cells, padded by the kernel radius
  std::unique_ptr<LocalCell[]> saved_;    // originals of the last x rows overwritten (a ring)
  std::unique_ptr<std::int16_t[]> sum_;   // one x row of partial sums
  // One span per x row (y, z): the cells that may be non-zero. Most rows of the
  // active box lie outside the frustum or behind surfaces, and a row's cells in
  // the frustum are a fraction of the box's width: the blur and fusion work on
  // the spans only.
  struct RowSpan {
    std::int32_t lo = 0, hi = -1;  // grid x; empty when lo > hi
  };
  std::unique_ptr<RowSpan[]> spans_;
  std::size_t span_index(int y, int z) const {
    return static_cast<std::size_t>(y) +
           static_cast<std::size_t>(dims_[1]) * static_cast<std::size_t>(z);
  }
  std::array<int, 3> touched_lo_;
  std::array<int, 3> touched_hi_;
  std::array<int, 3> active_lo_;
  std::array<int, 3> active_hi_;
  bool cells_written_ = false;  // false until the first reset filled the whole grid
  // NearKeep: the cube's cells as they were before the blur, its bounds (grid cells).
  std::unique_ptr<LocalCell[]> near_cells_;
  int near_half_ = 0;
  NearKeep near_{};  // this frame's
  std::array<int, 3> near_lo_{0, 0, 0};
  std::array<int, 3> near_hi_{-1, -1, -1};
};

}  // namespace zonemap
