// The sky filter (paper §II, made safe): a pixel without depth whose left-image
// patch is bright and flat is a *candidate*; it is sky, its ray free up to d_max,
// only where the pose and the image say nothing solid can stand there. Candidates
// form regions (8-connected); a candidate is sky when
//   (a) nothing was measured above it in its image column, nor a band of texture
//       wider than max_gap_px lies above it (a measured or textured surface
//       encloses what lies under it: a white wall under its roof line or eaves;
//       the sky is what lies above everything else),
//   (b) its region reaches above the horizon + margin (the pose's horizon; the
//       margin covers attitude error and the camera mount),
//   (c) its region nowhere reaches below the horizon - margin (a bright, flat
//       region that continues below the horizon is a surface standing on the
//       ground: a white wall, however its top blends into the sky), and
//   (d) its column's run of candidates does not rest on a measured surface: no
//       measured pixel with at most max_gap_px rows between (a white wall over a
//       hedge or a tree whose top stands above the horizon), and
//   (e) its region covers at least min_region_share of the image (the panes of a
//       white facade between its matched frames are small; sky seen through a
//       small gap is little free space to lose).
// Everything else without depth stays unknown, never free (docs/sky.md: why this
// is safe, and what it cannot tell apart).
//
// scan() walks the rows from the top until every column has its limit (rules a,
// d) and lies below the horizon - margin, keeping each row's candidate runs and
// joining them into regions (union-find); sky_mask_row() then gives any scanned
// row's sky pixels. Memory is reserved for kRunsPerRow runs a row on average; a
// frame with more stops storing there and takes nothing further down for sky.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>

#include <Eigen/Core>

#include "zonemap/common/camera.hpp"
#include "zonemap/common/config.hpp"

namespace zonemap {

class SkyFilter {
 public:
  static constexpr int kRunsPerRow = 16;

  SkyFilter(const SkyFilterConfig& config, const CameraModel& camera);

  // flags[u] = 1 where pixel (u, v) of the left image is bright and every
  // 8-neighbour (clamped at the border) lies within max_gradient of it. flags holds
  // three rows (the flags, then the columns' maxima and minima over rows v - 1..v + 1).
  void candidate_row(const std::uint8_t* left, int v, std::uint8_t* flags) const;

  // Scans the raw depth and the left image (see above). up_camera: the world's up
  // direction in the camera frame. Allocation-free.
  void scan(const std::uint16_t* depth, const std::uint8_t* left, const Eigen::Vector3f& up_camera);
  // Rows below this hold no sky in the scanned frame (0: none at all).
  int sky_rows() const { return sky_rows_; }
  // mask[u] = 1 where pixel (u, v) of the scanned frame is sky, else 0. Safe to
  // call from several threads at once for different rows.
  void sky_mask_row(int v, std::uint8_t* mask) const;

  std::size_t reserved_bytes() const;

 private:
  // -1 below the horizon - margin, +1 above the horizon + margin, 0 between: of
  // one pixel (with the row's s0 = up.y y + up.z and n0 = y² + 1), and of a whole row.
  int side_at(int u, float s0, float n0, const Eigen::Vector3f& up_camera) const;
  void side_row(int v, const Eigen::Vector3f& up_camera, std::int8_t* side) const;
  // The row's runs of candidates in open columns, joined to the previous row's.
  bool add_runs(int v, const std::uint16_t* depth_row, const std::uint8_t* flags,
                const std::int8_t* side);
  // Rules (a) and (d), and when a column closes, for one pixel of an open column.
  void step_column(int u, int v, bool measured, bool candidate, int side);
  // Sets the column's limit (rules a, d); stop_tracking ends its regions' scan.
  void close(int u, int limit);
  void stop_tracking(int u);
  int root(int run) const;
  void join(int a, int b);

  SkyFilterConfig config_;
  int width_, height_, max_runs_;
  float inv_fx_, inv_fy_, cx_, cy_;
  float sin2_margin_;  // sin² of the horizon margin
  static constexpr std::int16_t kNone = -1;
  // Per column: the first row not sky by (a)/(d) (height while open), the
  // column's current run of candidates (first row), a run that ended at most
  // max_gap_px rows ago (its first row), and the rows since the last candidate.
  std::unique_ptr<std::int16_t[]> limit_, run_start_, pending_start_, pending_gap_;
  std::unique_ptr<std::uint8_t[]> open_, limited_;  // still scanned; limit known
  // Candidate runs, row by row: runs of row v are [row_first_[v], row_first_[v+1]).
  std::unique_ptr<std::int16_t[]> run_begin_, run_end_;
  std::unique_ptr<std::int32_t[]> row_first_;
  std::unique_ptr<std::int32_t[]> parent_;  // union-find over runs
  std::unique_ptr<std::uint8_t[]> region_;  // at the root: kHigh, kLow
  std::unique_ptr<std::int32_t[]> area_;    // at the root: the region's pixels
  int min_region_px_ = 0;
  static constexpr std::uint8_t kHigh = 1, kLow = 2;
  std::unique_ptr<std::uint8_t[]> rows_;  // candidate_row's three rows
  std::unique_ptr<std::int8_t[]> side_;   // side_row's
  std::unique_ptr<std::uint8_t[]> live_;  // add_runs' open columns' candidates
  int open_columns_ = 0;
  int scanned_rows_ = 0;
  int sky_rows_ = 0;
};

}  // namespace zonemap
