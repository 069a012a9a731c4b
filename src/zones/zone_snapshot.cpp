#include "zonemap/zones/zone_snapshot.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

#include "common/simd_u16.hpp"

namespace zonemap {

// Capture reads lanes and flag bytes as little-endian words.
static_assert(std::endian::native == std::endian::little);

int coarse_level_step(const MapConfig& config) {
  const int saturation = to_fixed(static_cast<float>(config.saturation_units));
  int step = kMinLevelStep;
  while (saturation > 256 * step) step *= 2;
  return step;
}

namespace {
// A level step as a shift: a power of two (levels are taken of whole zone planes,
// where a shift vectorises and a division does not).
int shift_of(int level_step) {
  return std::countr_zero(std::bit_ceil(static_cast<unsigned>(std::max(level_step, 1))));
}
}  // namespace

ZoneSnapshot::ZoneSnapshot(const std::array<int, 3>& dims, int level_step)
    : dims_(dims),
      cells_(static_cast<std::size_t>(dims[0]) * static_cast<std::size_t>(dims[1]) *
             static_cast<std::size_t>(dims[2])),
      level_shift_(shift_of(level_step)),
      occupied_(new std::uint64_t[(cells_ + 63) / 64]()),
      rank_(new std::uint32_t[((cells_ + 63) / 64 + kRankWords - 1) / kRankWords]()),
      level_capacity_(cells_ / 16),
      levels_(new std::uint8_t[level_capacity_]()),
      column_known_(new std::uint8_t[static_cast<std::size_t>(dims[0]) * dims[1]]()) {}

std::size_t ZoneSnapshot::reserved_bytes() const {
  const std::size_t words = (cells_ + 63) / 64;
  return words * sizeof(std::uint64_t) +
         (words + kRankWords - 1) / kRankWords * sizeof(std::uint32_t) + level_capacity_ +
         static_cast<std::size_t>(dims_[0]) * dims_[1];
}

void ZoneSnapshot::capture(const ZoneView& zone, FusedCell occupied_threshold,
                           const PeakTrim* trim) {
  key_ = zone.key;
  origin_ = zone.origin;
  const std::size_t columns = static_cast<std::size_t>(dims_[0]) * dims_[1];
  std::uint8_t* known = column_known_.get();
  std::fill_n(known, columns, std::uint8_t{0});
  const FusedCell* cells = zone.cells;
  // One pass over the cells (a zone is 4 MB at 0.5 m: read once, on the frame
  // that discards it), sixteen at a time: the occupied flags as bits of the
  // word, the non-zero flags OR-ed into their columns.
  const std::size_t full_words = cells_ / 64;
  std::size_t column = 0;  // the column of the word's first cell
  const simd::I16x8 threshold = simd::I16x8{} + occupied_threshold;
  for (std::size_t w = 0; w < full_words; ++w) {
    const FusedCell* p = cells + w * 64;
    std::uint64_t word = 0;
    simd::U8x16 nonzero[4];
    for (int q = 0; q < 4; ++q) {
      simd::I16x8 a, b;
      std::memcpy(&a, p + 16 * q, sizeof a);
      std::memcpy(&b, p + 16 * q + 8, sizeof b);
      word |= std::uint64_t{simd::bits_of_masks(simd::narrow_masks(a > threshold, b > threshold))}
              << (16 * q);
      nonzero[q] = simd::narrow_masks(a != simd::I16x8{}, b != simd::I16x8{}) & 1;
    }
    occupied_[w] = word;
    if (column + 64 <= columns) {
      for (int q = 0; q < 4; ++q) {
        simd::U8x16 k;
        std::memcpy(&k, known + column + 16 * q, sizeof k);
        k |= nonzero[q];
        std::memcpy(known + column + 16 * q, &k, sizeof k);
      }
      column += 64;
      if (column == columns) column = 0;
    } else {  // the word runs into the next plane
      std::uint8_t flags[64];
      std::memcpy(flags, nonzero, sizeof flags);
      for (int b = 0; b < 64; ++b) {
        known[column] |= flags[b];
        if (++column == columns) column = 0;
      }
    }
  }
  if (full_words * 64 < cells_) occupied_[full_words] = 0;
  for (std::size_t i = full_words * 64; i < cells_; ++i) {
    if (cells[i] > occupied_threshold) occupied_[i >> 6] |= std::uint64_t{1} << (i & 63);
    known[column] |= static_cast<std::uint8_t>(cells[i] != 0);
    if (++column == columns) column = 0;
  }
  if (trim != nullptr && trim->enabled()) trim->apply(zone, occupied_.get());
  capture_levels(cells);
}

void ZoneSnapshot::capture_levels(const FusedCell* cells) {
  // Occupied cells are few (surfaces): their levels in cell order, found by rank.
  std::size_t rank = 0;
  levels_complete_ = true;
  const std::size_t words = (cells_ + 63) / 64;
  for (std::size_t w = 0; w < words; ++w) {
    if (w % kRankWords == 0) rank_[w / kRankWords] = static_cast<std::uint32_t>(rank);
    for (std::uint64_t bits = occupied_[w]; bits != 0; bits &= bits - 1u) {
      if (rank >= level_capacity_) {
        levels_complete_ = false;
        break;
      }
      const std::size_t i = w * 64 + static_cast<std::size_t>(std::countr_zero(bits));
      levels_[rank++] = static_cast<std::uint8_t>(std::min(cells[i] >> level_shift_, 255));
    }
  }
}

namespace {

// A fused value as a coarse level (2^level_shift units, 0..255).
inline std::uint8_t level_of(FusedCell value, int level_shift) {
  return static_cast<std::uint8_t>(std::clamp(value >> level_shift, 0, 255));
}

// A row's levels; the shift a constant, so that the loop vectorises on 16-bit
// lanes as it did before the step followed the saturation (a shift held in a
// variable cost 1.5% more instructions on flight 2's mapping plus extraction).
template <int kShift>
void row_levels(const FusedCell* in, std::uint8_t* out, int n) {
  for (int x = 0; x < n; ++x) {
    out[x] = static_cast<std::uint8_t>(std::clamp(in[x] >> kShift, 0, 255));
  }
}
void row_levels(const FusedCell* in, std::uint8_t* out, int n, int level_shift) {
  switch (level_shift) {
    case 4:
      return row_levels<4>(in, out, n);
    case 5:
      return row_levels<5>(in, out, n);
    case 6:
      return row_levels<6>(in, out, n);
    default:
      for (int x = 0; x < n; ++x) out[x] = level_of(in[x], level_shift);
  }
}

}  // namespace

PeakTrim::PeakTrim(const std::array<int, 3>& dims, double fraction, int radius_xy, int level_step)
    : dims_(dims),
      fraction_256_(static_cast<int>(std::lround(std::clamp(fraction, 0.0, 1.0) * 256.0))),
      radius_(std::max(radius_xy, 0)),
      level_shift_(shift_of(level_step)) {
  if (enabled()) {
    planes_.reset(new std::uint8_t[4 * static_cast<std::size_t>(dims[0]) * dims[1]]());
  }
}

PeakTrim make_peak_trim(const MapConfig& config) {
  return PeakTrim(config.zone_cells, config.features.peak_fraction,
                  static_cast<int>(std::lround(config.features.peak_window_m / config.cell_size_m)),
                  coarse_level_step(config));
}

std::size_t PeakTrim::reserved_bytes() const {
  return enabled() ? 4 * static_cast<std::size_t>(dims_[0]) * dims_[1] : 0;
}

void PeakTrim::plane_maxima(const ZoneView& zone, int z, std::uint8_t* out) const {
  const int nx = dims_[0];
  const int ny = dims_[1];
  const std::size_t plane = static_cast<std::size_t>(nx) * ny;
  std::uint8_t* pass = planes_.get() + 3 * plane;
  const FusedCell* cells = zone.cells + static_cast<std::size_t>(z) * plane;
  const int r = radius_;
  // Along x: each row's levels, then the maximum over the window (rows vectorise).
  for (int y = 0; y < ny; ++y) {
    const FusedCell* in = cells + static_cast<std::size_t>(y) * nx;
    std::uint8_t* row = pass + static_cast<std::size_t>(y) * nx;
    std::uint8_t* levels = out + static_cast<std::size_t>(y) * nx;  // out as scratch
    row_levels(in, levels, nx, level_shift_);
    for (int x = 0; x < nx; ++x) row[x] = levels[x];
    for (int k = 1; k <= r; ++k) {
      for (int x = 0; x + k < nx; ++x) row[x] = std::max(row[x], levels[x + k]);
      for (int x = k; x < nx; ++x) row[x] = std::max(row[x], levels[x - k]);
    }
  }
  // Along y: whole rows at a time.
  for (int y = 0; y < ny; ++y) {
    std::uint8_t* row = out + static_cast<std::size_t>(y) * nx;
    const int y0 = std::max(0, y - r);
    const int y1 = std::min(ny - 1, y + r);
    std::copy_n(pass + static_cast<std::size_t>(y0) * nx, nx, row);
    for (int j = y0 + 1; j <= y1; ++j) {
      const std::uint8_t* other = pass + static_cast<std::size_t>(j) * nx;
      for (int x = 0; x < nx; ++x) row[x] = std::max(row[x], other[x]);
    }
  }
}

void PeakTrim::apply(const ZoneView& zone, std::uint64_t* occupied) const {
  const int nz = dims_[2];
  const std::size_t plane = static_cast<std::size_t>(dims_[0]) * dims_[1];
  const auto ring = [&](int z) { return planes_.get() + static_cast<std::size_t>(z % 3) * plane; };
  const auto has_occupied = [&](int z) {
    const std::size_t first = static_cast<std::size_t>(z) * plane;
    const std::size_t last = first + plane - 1;
    for (std::size_t w = first >> 6; w <= last >> 6; ++w) {
      if (occupied[w] != 0) return true;
    }
    return false;
  };
  // Planes without occupied cells are skipped: their maxima are never asked for,
  // and what they hold under the threshold cannot outweigh an occupied cell.
  bool below = false;
  bool here = nz > 0 && has_occupied(0);
  if (here) plane_maxima(zone, 0, ring(0));
  for (int z = 0; z < nz; ++z) {
    const bool above = z + 1 < nz && has_occupied(z + 1);
    if (above) plane_maxima(zone, z + 1, ring(z + 1));
    if (here) {
      // The plane's occupied cells, a word at a time (they are few: surfaces).
      const std::size_t first = static_cast<std::size_t>(z) * plane;
      const std::size_t end = first + plane;
      for (std::size_t w = first >> 6; w <= (end - 1) >> 6; ++w) {
        std::uint64_t bits = occupied[w];
        if (w * 64 < first) bits &= ~std::uint64_t{0} << (first - w * 64);
        if (w * 64 + 64 > end) bits &= ~std::uint64_t{0} >> (w * 64 + 64 - end);
        for (; bits != 0; bits &= bits - 1u) {
          const std::size_t i = w * 64 + static_cast<std::size_t>(std::countr_zero(bits));
          const std::size_t j = i - first;
          std::uint8_t peak = ring(z)[j];
          if (below) peak = std::max(peak, ring(z - 1)[j]);
          if (above) peak = std::max(peak, ring(z + 1)[j]);
          if (256 * level_of(zone.cells[i], level_shift_) < fraction_256_ * peak) {
            occupied[w] &= ~(std::uint64_t{1} << (i & 63));
          }
        }
      }
    }
    below = here;
    here = above;
  }
}

}  // namespace zonemap
