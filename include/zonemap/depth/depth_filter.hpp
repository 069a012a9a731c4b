// Per-pixel depth noise reduced before the sensor model (past the paper): each
// valid depth becomes the mean of the valid depths around it that lie within
// kDepthFilterGate range resolutions (eq. 1's Δd at its own depth) of it, first
// along the row, then along the column (2r + 1 taps each).
//
// Why: a cell far away holds dozens of rays, and max-write keeps the most
// occupied of them, so the nearest noisy depth in the cell decides it: at 45 m
// (Δd 2.5 m) a tree's occupancy reached 2-4 m towards the camera. Averaging
// depths of one surface narrows that spread; the gate keeps depth edges
// (silhouettes) and thin things (a post one pixel wide keeps its own depth, as
// nothing beside it is within the gate) as they were. Missing depth stays
// missing. Depths are in raw codes (camera.depth_scale per metre); the gate is
// capped at 32767 / (2r + 1) codes (6553 at r = 2: 6.5 m in millimetres).
//
// Streaming: rows are filtered on demand, in increasing order, from a ring of
// 2r + 1 row-filtered rows; nothing is allocated after construction.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>

#include "zonemap/common/config.hpp"  // kMaxDepthFilterRadius

namespace zonemap {

inline constexpr float kDepthFilterGate = 2.0f;  // in range resolutions Δd

class DepthFilter {
 public:
  // radius 0: rows pass through unchanged. resolution_per_code2 is eq. (1)'s
  // Δd / d² in raw codes: σ / (b f) / depth_scale.
  DepthFilter(int width, int height, int radius, float resolution_per_code2);

  bool enabled() const { return radius_ > 0; }
  // A new frame (width x height raw codes, 0 = no measurement); kept by pointer
  // until the next begin(). Rows from first_row on will be asked for (a part of
  // the frame: the filter reads r rows before it).
  void begin(const std::uint16_t* depth, int first_row = 0);
  // The filtered row v (>= first_row). Calls must ask for rows in increasing
  // order within a frame.
  const std::uint16_t* row(int v);

  std::size_t reserved_bytes() const;

 private:
  void filter_along_row(const std::uint16_t* in, std::uint16_t* out) const;
  void filter_along_column(int v, std::uint16_t* out) const;
  const std::uint16_t* ring_row(int v) const {
    return ring_.get() + static_cast<std::size_t>(v % ring_rows_) * width_;
  }

  int width_;
  int height_;
  int radius_;
  int ring_rows_;
  float gate_per_code2_;
  float gate_cap_;            // 32767 / (2r + 1) codes: a row's sums fit 16 bits
  std::uint16_t centre_cap_;  // the least depth whose gate reaches the cap
  const std::uint16_t* depth_ = nullptr;
  int rows_done_ = 0;  // rows of the frame filtered along the row so far
  std::unique_ptr<std::uint16_t[]> ring_;
  std::unique_ptr<std::uint16_t[]> out_;
};

}  // namespace zonemap
