// What feature extraction (paper §IV-A) reads of a zone, small enough to hand to
// another thread: one bit per cell (occupied: above the features' threshold), a coarse value
// level per occupied cell (splitting objects that touch) and
// one byte per column (any cell of it known, free or occupied: the ground
// coverage test). At 160x160x80 that is 0.27 MB instead of the zone's 4 MB.
// Reserved once; capture() does not allocate.
#pragma once

#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <memory>

#include "zonemap/common/cell.hpp"
#include "zonemap/common/config.hpp"
#include "zonemap/zones/zone_map.hpp"

namespace zonemap {

// Past the paper: which occupied cells belong to objects. Far views smear a
// surface's occupancy over Δd along their rays and the blur widens it by a cell
// on every side; that halo stays above the occupied threshold, joining objects
// across narrow gaps. Kept: cells holding at least `fraction` of the largest
// fused value within radius_xy cells in x and y and one cell in z (a halo is
// weaker than the surface it surrounds). fraction 0: every occupied cell.
// Scratch for one capturing thread: three planes of x-y maxima and one pass
// plane, as coarse levels (value / level_step); reserved at construction.
class PeakTrim {
 public:
  PeakTrim(const std::array<int, 3>& dims, double fraction, int radius_xy, int level_step);

  bool enabled() const { return fraction_256_ > 0; }
  // Clears the bits (cell i: bit i % 64 of word i / 64) of the occupied cells of
  // `zone` below the fraction of their neighbourhood's peak.
  void apply(const ZoneView& zone, std::uint64_t* occupied) const;
  std::size_t reserved_bytes() const;

 private:
  // Plane z's levels, maximised over ±radius_xy in x, then in y, into `out`.
  void plane_maxima(const ZoneView& zone, int z, std::uint8_t* out) const;
  std::array<int, 3> dims_;
  int fraction_256_;  // fraction in 1/256
  int radius_;
  int level_shift_;  // levels are value >> level_shift_
  std::unique_ptr<std::uint8_t[]>
      planes_;  // three planes (z - 1, z, z + 1 by z % 3), then the pass plane
};

// The trim a configuration names (features.peak_fraction, peak_window_m).
PeakTrim make_peak_trim(const MapConfig& config);

// Fused values as coarse levels (0..255) for the trim and the split: a quarter
// sensor-model unit a level, coarser where the saturation would not fit in 255
// of them (a power of two: levels are a shift, which vectorises over a zone's
// planes). A saturated surface reads as its limit: had the levels stopped short
// of it, a halo near saturation would read as the surface's equal.
inline constexpr int kMinLevelStep = 16;  // fixed-point units: a quarter sensor-model unit
int coarse_level_step(const MapConfig& config);

class ZoneSnapshot {
 public:
  explicit ZoneSnapshot(const std::array<int, 3>& dims, int level_step = kMinLevelStep);

  // Copies what extraction needs of `zone` (same dims) at this instant; with
  // `trim`, only the occupied cells it keeps.
  void capture(const ZoneView& zone, FusedCell occupied_threshold, const PeakTrim* trim = nullptr);

  bool occupied(std::size_t i) const { return (occupied_[i >> 6] >> (i & 63)) & 1u; }
  // The fused value of an occupied cell, coarsely (value / level_step(), at most
  // 255), for splitting objects that touch; 0 when the zone held more occupied
  // cells than the snapshot keeps levels for (levels_complete() is then false).
  int level_step() const { return 1 << level_shift_; }
  std::uint8_t level(std::size_t i) const {
    const std::size_t w = i >> 6;
    const std::uint64_t below = occupied_[w] & ((std::uint64_t{1} << (i & 63)) - 1u);
    std::size_t rank = rank_[w / kRankWords] + static_cast<std::size_t>(std::popcount(below));
    for (std::size_t k = w - w % kRankWords; k < w; ++k) {
      rank += static_cast<std::size_t>(std::popcount(occupied_[k]));
    }
    return rank < level_capacity_ ? levels_[rank] : std::uint8_t{0};
  }
  bool levels_complete() const { return levels_complete_; }
  bool column_known(int x, int y) const {
    return column_known_[static_cast<std::size_t>(y) * dims_[0] + x] != 0;
  }
  // 64 cells at a time (cell i is bit i % 64 of word i / 64), for skipping.
  std::uint64_t occupied_word(std::size_t w) const { return occupied_[w]; }

  const ZoneKey& key() const { return key_; }
  const CellIndex& origin() const { return origin_; }
  const std::array<int, 3>& dims() const { return dims_; }
  std::size_t cell_count() const { return cells_; }
  std::size_t index(int x, int y, int z) const {
    return static_cast<std::size_t>(x) +
           static_cast<std::size_t>(dims_[0]) *
               (static_cast<std::size_t>(y) +
                static_cast<std::size_t>(dims_[1]) * static_cast<std::size_t>(z));
  }
  std::size_t reserved_bytes() const;

 private:
  void capture_levels(const FusedCell* cells);
  std::array<int, 3> dims_;
  std::size_t cells_;
  int level_shift_;  // levels are value >> level_shift_
  ZoneKey key_;
  CellIndex origin_;
  std::unique_ptr<std::uint64_t[]> occupied_;
  // Per kRankWords words: occupied cells before them (the words between counted
  // at look-up: a quarter of the memory of a count per word).
  static constexpr std::size_t kRankWords = 4;
  std::unique_ptr<std::uint32_t[]> rank_;
  std::size_t level_capacity_;              // a sixteenth of the cells
  std::unique_ptr<std::uint8_t[]> levels_;  // per occupied cell, in cell order
  bool levels_complete_ = true;
  std::unique_ptr<std::uint8_t[]> column_known_;
};

}  // namespace zonemap
