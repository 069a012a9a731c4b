#include "zonemap/integrator/local_grid.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "zonemap/common/config.hpp"

namespace zonemap {
namespace {

// Divides by 2^shift, rounding half away from zero, so that blur(-x) == -blur(x).
int symmetric_shift(int value, int shift) {
  const int half = 1 << (shift - 1);
  return value >= 0 ? (value + half) >> shift : -((-value + half) >> shift);
}

// A blur pass makes no cell free that was not free before it: a cell unknown (0)
// takes occupancy from its neighbours but not their free space. Blurring the
// free space beside a surface into the cells behind it, which no ray saw, would
// call the inside of a trunk free. Nor does a pass erase an occupied cell: where
// its free neighbours would take it to unknown or free, it keeps half its value.
// A post or pole thinner than a cell, seen from a few metres (eq. 1's Δd far
// under a cell), is one occupied cell between cells its neighbouring rays saw
// free: the plain kernel made it unknown in every frame, and it never entered
// the map (scene hover-near).
// One select: half of 0 is 0, and half of an occupied cell is what it keeps.
inline int blurred(int centre, int value) {
  return centre >= 0 && value <= 0 ? (centre + 1) >> 1 : value;
}

// out = (a + 2 b + c) / 4, rounded symmetrically, for int8 rows (out may be none
// of the inputs), as blurred() keeps it where b is not free. Sixteen cells
// at a time in 16-bit lanes (|a + 2 b + c| <= 256 for cell values in [-64, 64]);
// the rest one by one.
void blur_row3(const LocalCell* __restrict a, const LocalCell* __restrict b,
               const LocalCell* __restrict c, LocalCell* __restrict out, int n) {
  using I8x16 = std::int8_t __attribute__((vector_size(16)));
  using I8x8 = std::int8_t __attribute__((vector_size(8)));
  using I16x8 = std::int16_t __attribute__((vector_size(16)));
  const auto blur8 = [](I8x8 va, I8x8 vb, I8x8 vc) {
    const I16x8 centre = __builtin_convertvector(vb, I16x8);
    const I16x8 sum =
        __builtin_convertvector(va, I16x8) + 2 * centre + __builtin_convertvector(vc, I16x8);
    const auto negative = sum < 0;
    const I16x8 magnitude = negative ? -sum : sum;
    const I16x8 shifted = (magnitude + 2) >> 2;
    const I16x8 value = negative ? -shifted : shifted;
    const I16x8 kept = (centre >= 0 && value <= 0) ? (centre + 1) >> 1 : value;  // blurred()
    return __builtin_convertvector(kept, I8x8);
  };
  int x = 0;
  for (; x + 16 <= n; x += 16) {
    I8x16 va, vb, vc;
    std::memcpy(&va, a + x, sizeof va);
    std::memcpy(&vb, b + x, sizeof vb);
    std::memcpy(&vc, c + x, sizeof vc);
    const I8x8 lo = blur8(__builtin_shufflevector(va, va, 0, 1, 2, 3, 4, 5, 6, 7),
                          __builtin_shufflevector(vb, vb, 0, 1, 2, 3, 4, 5, 6, 7),
                          __builtin_shufflevector(vc, vc, 0, 1, 2, 3, 4, 5, 6, 7));
    const I8x8 hi = blur8(__builtin_shufflevector(va, va, 8, 9, 10, 11, 12, 13, 14, 15),
                          __builtin_shufflevector(vb, vb, 8, 9, 10, 11, 12, 13, 14, 15),
                          __builtin_shufflevector(vc, vc, 8, 9, 10, 11, 12, 13, 14, 15));
    const I8x16 result =
        __builtin_shufflevector(lo, hi, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    std::memcpy(out + x, &result, sizeof result);
  }
  for (; x < n; ++x) {
    const int sum = a[x] + 2 * b[x] + c[x];
    out[x] = static_cast<LocalCell>(blurred(b[x], symmetric_shift(sum, 2)));
  }
}

}  // namespace

LocalGrid::LocalGrid(const std::array<int, 3>& dims)
    : dims_(dims),
      cell_count_(static_cast<std::size_t>(dims[0]) * static_cast<std::size_t>(dims[1]) *
                  static_cast<std::size_t>(dims[2])),
      cells_(new LocalCell[cell_count_]()),
      line_(new std::int16_t[kMaxFinishParts *
                             static_cast<std::size_t>(dims[0] + 2 * kMaxBlurRadius)]()),
      saved_(new LocalCell[kMaxFinishParts * static_cast<std::size_t>(dims[0]) *
                           (2 * kMaxBlurRadius + 1)]()),
      sum_(new std::int16_t[kMaxFinishParts * static_cast<std::size_t>(dims[0])]()),
      spans_(new RowSpan[static_cast<std::size_t>(dims[1]) * static_cast<std::size_t>(dims[2])]()) {
  reset(CellIndex{});
}

std::size_t LocalGrid::reserved_bytes() const {
  const std::size_t row = static_cast<std::size_t>(dims_[0]);
  return cell_count_ * (sizeof(LocalCell) + (through_marks_ ? 1 : 0)) +
         kMaxFinishParts *
             ((row + 2 * kMaxBlurRadius) * sizeof(std::int16_t) +
              row * (2 * kMaxBlurRadius + 1) * sizeof(LocalCell) + row * sizeof(std::int16_t)) +
         static_cast<std::size_t>(dims_[1]) * static_cast<std::size_t>(dims_[2]) * sizeof(RowSpan) +
         (near_cells_ ? static_cast<std::size_t>(2 * near_half_ + 1) *
                            static_cast<std::size_t>(2 * near_half_ + 1) *
                            static_cast<std::size_t>(2 * near_half_ + 1)
                      : 0);
}

void LocalGrid::reset(const CellIndex& origin) {
  origin_ = origin;
  // Only the last frame's active region holds anything but kUntouched.
  if (cells_written_ && active_lo_[0] <= active_hi_[0] && active_lo_[1] <= active_hi_[1] &&
      active_lo_[2] <= active_hi_[2]) {
    const int n = active_hi_[0] - active_lo_[0] + 1;
    for (int z = active_lo_[2]; z <= active_hi_[2]; ++z)
      for (int y = active_lo_[1]; y <= active_hi_[1]; ++y)
        std::fill_n(cells_.get() + index(active_lo_[0], y, z), n, kUntouched);
  } else if (!cells_written_) {
    std::fill_n(cells_.get(), cell_count_, kUntouched);
  }
  cells_written_ = true;
  touched_lo_ = {dims_[0], dims_[1], dims_[2]};
  touched_hi_ = {-1, -1, -1};
  active_lo_ = touched_lo_;
  active_hi_ = touched_hi_;
}

void LocalGrid::extend_touched(int x0, int y0, int z0, int x1, int y1, int z1) {
  const int lo[3] = {x0, y0, z0};
  const int hi[3] = {x1, y1, z1};
  for (std::size_t a = 0; a < 3; ++a) {
    touched_lo_[a] = std::min(touched_lo_[a], std::max(lo[a], 0));
    touched_hi_[a] = std::max(touched_hi_[a], std::min(hi[a], dims_[a] - 1));
  }
}

// The part [*t0, *t1] of the segment start + t direction inside the grid box
// (slab method); false when none is.
bool LocalGrid::clip_to_grid(const Eigen::Vector3f& start, const Eigen::Vector3f& direction,
                             float* t0, float* t1) const {
  for (int a = 0; a < 3; ++a) {
    const float extent = static_cast<float>(dims_[a]);
    if (std::fabs(direction[a]) < 1e-12f) {
      if (start[a] < 0.0f || start[a] >= extent) return false;
      continue;
    }
    float ta = (0.0f - start[a]) / direction[a];
    float tb = (extent - start[a]) / direction[a];
    if (ta > tb) std::swap(ta, tb);
    *t0 = std::max(*t0, ta);
    *t1 = std::min(*t1, tb);
  }
  return *t0 < *t1;
}

int LocalGrid::draw_ray(const Eigen::Vector3f& start, const Eigen::Vector3f& direction,
                        const RayProfile& ray) {
  float t0 = ray.delta_begin;
  float t1 = ray.delta_end;
  if (!clip_to_grid(start, direction, &t0, &t1)) return 0;

  // Amanatides & Woo traversal: visit every cell the segment crosses, in order,
  // with the δ interval [t, t_exit] the ray spends inside it.
  int cell[3];
  int step[3];
  float t_next[3];
  float t_delta[3];
  const float inf = std::numeric_limits<float>::infinity();
  for (int a = 0; a < 3; ++a) {
    const float p = start[a] + t0 * direction[a];
    cell[a] = std::clamp(static_cast<int>(std::floor(p)), 0, dims_[a] - 1);
    if (direction[a] > 0.0f) {
      step[a] = 1;
      t_delta[a] = 1.0f / direction[a];
      t_next[a] = (static_cast<float>(cell[a] + 1) - start[a]) / direction[a];
    } else if (direction[a] < 0.0f) {
      step[a] = -1;
      t_delta[a] = -1.0f / direction[a];
      t_next[a] = (static_cast<float>(cell[a]) - start[a]) / direction[a];
    } else {
      step[a] = 0;
      t_delta[a] = inf;
      t_next[a] = inf;
    }
  }

  // The traversal is a straight segment: its first and last cells bound it.
  {
    int last[3];
    for (int a = 0; a < 3; ++a) {
      const float p = start[a] + t1 * direction[a];
      last[a] = std::clamp(static_cast<int>(std::floor(p)), 0, dims_[a] - 1);
    }
    extend_touched(std::min(cell[0], last[0]), std::min(cell[1], last[1]),
                   std::min(cell[2], last[2]), std::max(cell[0], last[0]),
                   std::max(cell[1], last[1]), std::max(cell[2], last[2]));
  }
  const int max_steps = dims_[0] + dims_[1] + dims_[2] + 3;
  float t = t0;
  int visited = 0;
  while (visited < max_steps) {
    int axis = 0;
    if (t_next[1] < t_next[axis]) axis = 1;
    if (t_next[2] < t_next[axis]) axis = 2;
    const float t_exit = std::min(std::max(t_next[axis], t), t1);
    const LocalCell value = to_local_cell(max_value_in_interval(ray, t, t_exit));
    write_max(cell[0], cell[1], cell[2], value);
    if (through_marks_) {
      // Past the measured depth (the whole interval behind it) the lower bar.
      const bool behind = !ray.free_only && t > ray.depth;
      const bool near_peak = value >= (behind ? near_peak_behind_ : near_peak_);
      through_marks_[index(cell[0], cell[1], cell[2])] |=
          (value == -kCellScale ? kSeenThrough : 0) | (near_peak ? kNearPeak : 0);
    }
    ++visited;
    if (t_exit >= t1) break;
    t = t_exit;
    cell[axis] += step[axis];
    if (cell[axis] < 0 || cell[axis] >= dims_[axis]) break;
    t_next[axis] += t_delta[axis];
  }
  return visited;
}

void LocalGrid::enable_see_through(LocalCell near_peak, LocalCell near_peak_behind) {
  near_peak_ = near_peak;
  near_peak_behind_ = std::min(near_peak_behind, near_peak);
  through_marks_.reset(new std::uint8_t[cell_count_]());
}

void LocalGrid::free_cells_seen_through() {
  if (touched_lo_[0] > touched_hi_[0] || touched_lo_[1] > touched_hi_[1] ||
      touched_lo_[2] > touched_hi_[2]) {
    return;
  }
  const int n = touched_hi_[0] - touched_lo_[0] + 1;
  for (int z = touched_lo_[2]; z <= touched_hi_[2]; ++z) {
    for (int y = touched_lo_[1]; y <= touched_hi_[1]; ++y) {
      const std::size_t first = index(touched_lo_[0], y, z);
      LocalCell* row = cells_.get() + first;
      std::uint8_t* marks = through_marks_.get() + first;
      for (int x = 0; x < n; ++x) {
        if (marks[x] == kSeenThrough) row[x] = static_cast<LocalCell>(-kCellScale);
        marks[x] = 0;
      }
    }
  }
}

void LocalGrid::enable_near_keep(int half_cells) {
  near_half_ = std::clamp(half_cells, 0, MapConfig::kMaxKeepNearCells);
  const auto side = static_cast<std::size_t>(2 * near_half_ + 1);
  near_cells_.reset(new LocalCell[side * side * side]());
}

void LocalGrid::record_near(const NearKeep& near) {
  for (int a = 0; a < 3; ++a) {
    const auto k = static_cast<std::size_t>(a);
    const int centre = static_cast<int>(std::floor(near.camera[a]));
    near_lo_[k] = std::max(centre - near_half_, active_lo_[k]);
    near_hi_[k] = std::min(centre + near_half_, active_hi_[k]);
  }
  near_ = near;
  // The cube's rows as they are, packed from near_lo_; restore_near picks the
  // positive ones within the depth (few: most of the cube is free or untouched).
  const auto n = static_cast<std::size_t>(std::max(near_hi_[0] - near_lo_[0] + 1, 0));
  std::size_t k = 0;
  for (int z = near_lo_[2]; z <= near_hi_[2]; ++z) {
    for (int y = near_lo_[1]; y <= near_hi_[1]; ++y, k += n) {
      std::memcpy(near_cells_.get() + k, cells_.get() + index(near_lo_[0], y, z), n);
    }
  }
}

void LocalGrid::restore_near() {
  const auto n = static_cast<std::size_t>(std::max(near_hi_[0] - near_lo_[0] + 1, 0));
  std::size_t k = 0;
  for (int z = near_lo_[2]; z <= near_hi_[2]; ++z) {
    for (int y = near_lo_[1]; y <= near_hi_[1]; ++y, k += n) {
      const LocalCell* before = near_cells_.get() + k;
      LocalCell* row = cells_.get() + index(near_lo_[0], y, z);
      for (std::size_t i = 0; i < n; ++i) {
        if (before[i] <= 0) continue;  // untouched (INT8_MIN), free or unknown
        const Eigen::Vector3f centre(static_cast<float>(near_lo_[0]) + static_cast<float>(i) + 0.5f,
                                     static_cast<float>(y) + 0.5f, static_cast<float>(z) + 0.5f);
        const float depth = near_.axis_per_cell.dot(centre - near_.camera);
        if (!(depth > 0.0f && depth <= near_.depth_m)) continue;
        // A positive cell stays positive through the blur, inside its row's span.
        row[i] = std::max(row[i], static_cast<LocalCell>((before[i] + 1) >> 1));
      }
    }
  }
}

void LocalGrid::finish(int blur_radius, WorkSplit* split, const NearKeep* near) {
  if (through_marks_) free_cells_seen_through();
  const int radius = std::clamp(blur_radius, 0, kMaxBlurRadius);
  for (int a = 0; a < 3; ++a) {
    const std::size_t k = static_cast<std::size_t>(a);
    active_lo_[k] = std::max(touched_lo_[k] - radius, 0);
    active_hi_[k] = std::min(touched_hi_[k] + radius, dims_[a] - 1);
  }
  if (active_lo_[0] > active_hi_[0] || active_lo_[1] > active_hi_[1] ||
      active_lo_[2] > active_hi_[2]) {
    return;
  }
  // Three steps, each shared among the split's parts (each its own scratch
  // rows): the x rows (unknown for untouched, their spans, the x blur), then the
  // y lines of each z plane, then the z lines of each y plane. Every part writes
  // rows, planes of its own: the grid is the same for any split.
  const bool keep_near = near != nullptr && near_cells_ != nullptr && radius > 0;
  if (keep_near) record_near(*near);
  const int parts = split == nullptr ? 1 : std::min(split->parts(), kMaxFinishParts);
  for (int step = 0; step <= (radius == 0 ? 0 : 2); ++step) {
    for_each_part(split, parts, [&](int part, int all) {
      if (step == 0) {
        finish_rows(radius, share_of(part, all), part);
      } else {
        blur_across(step, radius, share_of(part, all), part);
      }
    });
  }
  if (keep_near) restore_near();
}

// The x rows of planes z = first + k step: untouched cells to unknown (0), each
// row's span of non-zero cells, then (radius > 0) the x blur.
void LocalGrid::finish_rows(int radius, RowShare share, int part) {
  const int n = active_hi_[0] - active_lo_[0] + 1;
  for (int z = active_lo_[2] + share.first; z <= active_hi_[2]; z += share.step)
    for (int y = active_lo_[1]; y <= active_hi_[1]; ++y) {
      LocalCell* row = cells_.get() + index(active_lo_[0], y, z);
      LocalCell any = 0;
      for (int x = 0; x < n; ++x) {
        const LocalCell v = row[x] == kUntouched ? LocalCell{0} : row[x];
        row[x] = v;
        any = static_cast<LocalCell>(any | v);
      }
      RowSpan& span = spans_[span_index(y, z)];
      span = RowSpan{};
      if (any == 0) continue;
      int first = 0, last = n - 1;
      while (row[first] == 0) ++first;  // stops: some cell is non-zero
      while (row[last] == 0) --last;
      span.lo = active_lo_[0] + first;
      span.hi = active_lo_[0] + last;
      if (radius > 0) blur_x_row(y, z, radius, part);
    }
}

// One x row (y, z) blurred along x, in the part's scratch rows.
void LocalGrid::blur_x_row(int y, int z, int radius, int part) {
  const int x0 = active_lo_[0];
  const int n = active_hi_[0] - x0 + 1;
  RowSpan& span = spans_[span_index(y, z)];
  if (span.lo > span.hi) return;  // all 0: stays 0
  if (radius == 1) {
    // The default kernel: the row's original, padded with unknown (0) on both
    // sides, in the saved rows; one vectorised pass writes the row. Only the
    // row's span grown by one (outside it every input is 0).
    LocalCell* padded = saved_rows(part);
    span.lo = std::max(span.lo - 1, x0);
    span.hi = std::min(span.hi + 1, active_hi_[0]);
    const int count = span.hi - span.lo + 1;
    LocalCell* row = cells_.get() + index(span.lo, y, z);
    padded[0] = 0;
    std::copy_n(row, count, padded + 1);
    padded[count + 1] = 0;
    blur_row3(padded, padded + 1, padded + 2, row, count);
    return;
  }
  std::int16_t* line = line_.get() + static_cast<std::size_t>(part) *
                                         static_cast<std::size_t>(dims_[0] + 2 * kMaxBlurRadius);
  span = RowSpan{x0, active_hi_[0]};  // this kernel works on whole rows
  LocalCell* row = cells_.get() + index(x0, y, z);
  // Outside the active region every cell is unknown (0): zero padding is exact.
  for (int i = 0; i < radius; ++i) {
    line[i] = 0;
    line[radius + n + i] = 0;
  }
  for (int i = 0; i < n; ++i) line[radius + i] = row[i];
  for (int i = 0; i < n; ++i) {
    const std::int16_t* w = line + i;
    const int sum =
        radius == 1 ? w[0] + 2 * w[1] + w[2] : w[0] + 4 * w[1] + 6 * w[2] + 4 * w[3] + w[4];
    row[i] = static_cast<LocalCell>(blurred(w[radius], symmetric_shift(sum, 2 * radius)));
  }
}

void LocalGrid::blur_across(int axis, int radius, RowShare share, int part) {
  // Lines along `axis` are blurred all at once: each step combines whole x rows,
  // so the inner loops run over contiguous cells. The originals of the rows already
  // overwritten are kept in the part's saved rows (a ring of 2 * radius + 1 rows).
  // Sheets other = first + k step only.
  const int other = axis == 1 ? 2 : 1;  // the axis enumerating independent sheets
  // Radius 1: the two saved rows and the row of zeros start at 0; the saved rows
  // are kept 0 outside the span last copied into each.
  RowSpan saved_span[2];
  if (radius == 1) {
    const auto n = static_cast<std::size_t>(active_hi_[0] - active_lo_[0] + 1);
    std::fill_n(saved_rows(part), 3 * n, LocalCell{0});
  }
  for (int o = active_lo_[static_cast<std::size_t>(other)] + share.first;
       o <= active_hi_[static_cast<std::size_t>(other)]; o += share.step) {
    if (radius == 1) {
      blur_sheet_121(axis, o, part, saved_span);
    } else {
      blur_sheet_wide(axis, radius, o, part);
    }
  }
}

// The default kernel (1 2 1) over sheet o, in one pass per row: the previous
// row's original and this row's are kept in two saved rows (0 outside the span
// copied into them, saved_span), the next row is still untouched; rows outside
// the region are unknown (0). Only the union of the three rows' spans can be
// non-zero: the rest of the row stays 0, and the spans follow.
void LocalGrid::blur_sheet_121(int axis, int o, int part, RowSpan saved_span[2]) {
  LocalCell* saved = saved_rows(part);
  const int x0 = active_lo_[0];
  const int n = active_hi_[0] - x0 + 1;
  const int lo = active_lo_[static_cast<std::size_t>(axis)];
  const int hi = active_hi_[static_cast<std::size_t>(axis)];
  LocalCell* zeros = saved + 2 * static_cast<std::size_t>(n);
  for (int b = 0; b < 2; ++b) {  // the last sheet's rows: back to 0
    if (saved_span[b].lo <= saved_span[b].hi) {
      std::fill_n(saved + static_cast<std::size_t>(b) * n + (saved_span[b].lo - x0),
                  saved_span[b].hi - saved_span[b].lo + 1, LocalCell{0});
    }
    saved_span[b] = RowSpan{};
  }
  RowSpan prev_span;  // the original span of row c - 1
  for (int c = lo; c <= hi; ++c) {
    RowSpan& span = sheet_span(axis, c, o);
    const RowSpan cur_span = span;
    const RowSpan next_span = c < hi ? sheet_span(axis, c + 1, o) : RowSpan{};
    RowSpan out{std::numeric_limits<std::int32_t>::max(), -1};
    for (const RowSpan& near : {prev_span, cur_span, next_span}) {
      if (near.lo > near.hi) continue;
      out.lo = std::min(out.lo, near.lo);
      out.hi = std::max(out.hi, near.hi);
    }
    const int k = (c - lo) & 1;
    // saved[k] held row c - 2: back to 0, then this row's original span.
    LocalCell* cur = saved + static_cast<std::size_t>(k) * n;
    if (saved_span[k].lo <= saved_span[k].hi) {
      std::fill_n(cur + (saved_span[k].lo - x0), saved_span[k].hi - saved_span[k].lo + 1,
                  LocalCell{0});
    }
    saved_span[k] = cur_span;
    if (cur_span.lo <= cur_span.hi) {
      std::copy_n(sheet_row(axis, c, o) + (cur_span.lo - x0), cur_span.hi - cur_span.lo + 1,
                  cur + (cur_span.lo - x0));
    }
    span = out.lo <= out.hi ? out : RowSpan{};
    prev_span = cur_span;
    if (out.lo > out.hi) continue;
    const LocalCell* prev = saved + static_cast<std::size_t>(1 - k) * n;
    const LocalCell* next = c < hi ? sheet_row(axis, c + 1, o) : zeros;
    const int from = out.lo - x0;
    blur_row3(prev + from, cur + from, next + from, sheet_row(axis, c, o) + from,
              out.hi - out.lo + 1);
  }
}

// The wider kernel (1 4 6 4 1) over sheet o, whole rows at a time from partial
// sums, the originals of the rows overwritten kept in a ring.
void LocalGrid::blur_sheet_wide(int axis, int radius, int o, int part) {
  LocalCell* saved = saved_rows(part);
  const int x0 = active_lo_[0];
  const int n = active_hi_[0] - x0 + 1;
  const int lo = active_lo_[static_cast<std::size_t>(axis)];
  const int hi = active_hi_[static_cast<std::size_t>(axis)];
  static constexpr int kWeights[3][5] = {{1, 0, 0, 0, 0}, {1, 2, 1, 0, 0}, {1, 4, 6, 4, 1}};
  const int* weight = kWeights[radius];
  const int ring = 2 * radius + 1;
  auto saved_row = [&](int c) {
    return saved + static_cast<std::size_t>(((c % ring) + ring) % ring) * n;
  };
  for (int c = lo; c <= hi; ++c) {
    std::int16_t* sum = sum_.get() + static_cast<std::size_t>(part) * dims_[0];
    std::fill_n(sum, n, std::int16_t{0});
    for (int k = -radius; k <= radius; ++k) {
      const int cc = c + k;
      if (cc < lo || cc > hi) continue;  // outside the region: unknown (0)
      const LocalCell* src = cc < c ? saved_row(cc) : sheet_row(axis, cc, o);
      const int w = weight[k + radius];
      for (int x = 0; x < n; ++x) sum[x] = static_cast<std::int16_t>(sum[x] + w * src[x]);
    }
    LocalCell* dst = sheet_row(axis, c, o);
    const LocalCell* original = saved_row(c);
    std::copy_n(dst, n, saved_row(c));  // keep the original for the next rows
    for (int x = 0; x < n; ++x)
      dst[x] = static_cast<LocalCell>(blurred(original[x], symmetric_shift(sum[x], 2 * radius)));
    sheet_span(axis, c, o) = RowSpan{x0, active_hi_[0]};  // this kernel works on whole rows
  }
}

}  // namespace zonemap

namespace zonemap {

void LocalGrid::weight_occupancy_by_range(const Eigen::Vector3f& camera,
                                          const Eigen::Vector3f& axis_per_cell,
                                          float full_weight_depth_m, float min_weight) {
  const float full_squared = full_weight_depth_m * full_weight_depth_m;
  for (int z = active_lo_[2]; z <= active_hi_[2]; ++z) {
    for (int y = active_lo_[1]; y <= active_hi_[1]; ++y) {
      const RowSpan& span = spans_[span_index(y, z)];
      if (span.lo > span.hi) continue;
      const Eigen::Vector3f first(static_cast<float>(span.lo) + 0.5f, static_cast<float>(y) + 0.5f,
                                  static_cast<float>(z) + 0.5f);
      const float depth0 = axis_per_cell.dot(first - camera);
      LocalCell* row = cells_.get() + index(span.lo, y, z);
      for (int i = 0; i <= span.hi - span.lo; ++i) {
        if (row[i] <= 0) continue;
        const float depth = depth0 + static_cast<float>(i) * axis_per_cell.x();
        if (depth * depth <= full_squared) continue;
        const float scaled =
            static_cast<float>(row[i]) * std::max(min_weight, full_squared / (depth * depth));
        row[i] = static_cast<LocalCell>(std::max(1.0f, std::round(scaled)));
      }
    }
  }
}

}  // namespace zonemap
