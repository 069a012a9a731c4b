#include "zonemap/zone_snapshot.hpp"

#include <algorithm>
#include <bit>
#include <cstring>

namespace zonemap {

// The bit packing below reads eight flag bytes as one little-endian word.
static_assert(std::endian::native == std::endian::little);

ZoneSnapshot::ZoneSnapshot(const std::array<int, 3>& dims)
    : dims_(dims),
      cells_(static_cast<std::size_t>(dims[0]) * static_cast<std::size_t>(dims[1]) *
             static_cast<std::size_t>(dims[2])),
      occupied_(new std::uint64_t[(cells_ + 63) / 64]()),
      rank_(new std::uint32_t[(cells_ + 63) / 64]()),
      level_capacity_(cells_ / 16),
      levels_(new std::uint8_t[level_capacity_]()),
      column_known_(new std::uint8_t[static_cast<std::size_t>(dims[0]) * dims[1]]()) {}

std::size_t ZoneSnapshot::reserved_bytes() const {
  return (cells_ + 63) / 64 * (sizeof(std::uint64_t) + sizeof(std::uint32_t)) + level_capacity_ +
         static_cast<std::size_t>(dims_[0]) * dims_[1];
}

namespace {

// 64 flag bytes (each 0 or 1) as the bits of one word: for bytes b_i in {0, 1},
// (x * 0x0102040810204080) >> 56 = sum b_i 2^i, eight at a time.
std::uint64_t pack_flags(const std::uint8_t* flags) {
  std::uint64_t word = 0;
  for (int k = 0; k < 8; ++k) {
    std::uint64_t x = 0;
    std::memcpy(&x, flags + 8 * k, 8);
    word |= ((x * 0x0102040810204080ull) >> 56) << (8 * k);
  }
  return word;
}

}  // namespace

void ZoneSnapshot::capture(const ZoneView& zone, FusedCell occupied_threshold) {
  key_ = zone.key;
  origin_ = zone.origin;
  const std::size_t columns = static_cast<std::size_t>(dims_[0]) * dims_[1];
  std::uint8_t* known = column_known_.get();
  std::fill_n(known, columns, std::uint8_t{0});
  const FusedCell* cells = zone.cells;
  // One pass over the cells (a zone is 4 MB at 0.5 m: read once, on the frame
  // that discards it), 64 at a time: the occupied flags packed into a word, the
  // non-zero flags OR-ed into their columns (both vectorise).
  const std::size_t full_words = cells_ / 64;
  std::size_t column = 0;  // the column of the word's first cell
  for (std::size_t w = 0; w < full_words; ++w) {
    const FusedCell* p = cells + w * 64;
    // 64 flags as bytes (a vectorised compare), then packed into bits.
    std::uint8_t flags[64];
    std::uint8_t nonzero[64];
    for (int b = 0; b < 64; ++b) {
      flags[b] = static_cast<std::uint8_t>(p[b] > occupied_threshold);
      nonzero[b] = static_cast<std::uint8_t>(p[b] != 0);
    }
    occupied_[w] = pack_flags(flags);
    if (column + 64 <= columns) {
      for (int b = 0; b < 64; ++b) known[column + static_cast<std::size_t>(b)] |= nonzero[b];
      column += 64;
      if (column == columns) column = 0;
    } else {  // the word runs into the next plane
      for (int b = 0; b < 64; ++b) {
        known[column] |= nonzero[b];
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
  capture_levels(cells);
}

void ZoneSnapshot::capture_levels(const FusedCell* cells) {
  // Occupied cells are few (surfaces): their levels in cell order, found by rank.
  std::size_t rank = 0;
  levels_complete_ = true;
  const std::size_t words = (cells_ + 63) / 64;
  for (std::size_t w = 0; w < words; ++w) {
    rank_[w] = static_cast<std::uint32_t>(rank);
    for (std::uint64_t bits = occupied_[w]; bits != 0; bits &= bits - 1u) {
      if (rank >= level_capacity_) {
        levels_complete_ = false;
        break;
      }
      const std::size_t i = w * 64 + static_cast<std::size_t>(std::countr_zero(bits));
      levels_[rank++] = static_cast<std::uint8_t>(std::min(cells[i] / kLevelStep, 255));
    }
  }
}

}  // namespace zonemap
