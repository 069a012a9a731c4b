// Zone snapshots: what the extraction thread gets of a zone (one bit per cell,
// one byte per column), checked cell by cell against the zone.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <vector>

#include "core_test_support.hpp"
#include "zonemap/common/config.hpp"
#include "zonemap/zones/zone_snapshot.hpp"

namespace zonemap {
namespace {

TEST(ZoneSnapshot, BitsAndColumnsMatchTheZoneCellByCell) {
  // Odd sizes: the last word is partial and words run across planes; planes of
  // whole words (the sixteen-at-a-time path throughout). Values around the
  // threshold and at the ends of the range, zeros and whole unknown columns.
  for (const std::array<int, 3>& dims : {std::array<int, 3>{13, 7, 11}, {32, 6, 5}}) {
    const int nx = dims[0], ny = dims[1], nz = dims[2];
    const std::size_t n = static_cast<std::size_t>(nx) * ny * nz;
    std::vector<FusedCell> cells(n);
    testing::Lcg rng(77);
    for (std::size_t i = 0; i < n; ++i) {
      const double r = rng.uniform();
      cells[i] = r < 0.4 ? 0 : static_cast<FusedCell>(static_cast<int>(rng.uniform() * 400) - 200);
    }
    cells[1] = 96;
    cells[2] = 97;
    cells[5] = INT16_MAX;
    cells[6] = INT16_MIN;
    for (int z = 0; z < nz; ++z) cells[static_cast<std::size_t>(3 + nx * (2 + ny * z))] = 0;
    ZoneView view{{1, -2, 3}, {13, -14, 33}, dims, cells.data()};
    ZoneSnapshot snapshot(dims);
    snapshot.capture(view, 96);
    EXPECT_EQ(snapshot.key(), view.key);
    EXPECT_EQ(snapshot.origin(), view.origin);
    int occupied = 0;
    for (int z = 0; z < nz; ++z)
      for (int y = 0; y < ny; ++y)
        for (int x = 0; x < nx; ++x) {
          const std::size_t i = view.index(x, y, z);
          ASSERT_EQ(snapshot.occupied(i), cells[i] > 96) << x << "," << y << "," << z;
          occupied += snapshot.occupied(i) ? 1 : 0;
        }
    EXPECT_GT(occupied, 50);
    for (int y = 0; y < ny; ++y)
      for (int x = 0; x < nx; ++x) {
        bool known = false;
        for (int z = 0; z < nz; ++z) known = known || cells[view.index(x, y, z)] != 0;
        EXPECT_EQ(snapshot.column_known(x, y), known) << x << "," << y;
      }
    EXPECT_FALSE(snapshot.column_known(3, 2));
  }
}

// Brute force: the largest level within ±r in x and y and ±1 in z.
int peak_level(const std::vector<FusedCell>& cells, const ZoneView& view, int x, int y, int z,
               int r) {
  int peak = 0;
  for (int k = std::max(0, z - 1); k <= std::min(view.dims[2] - 1, z + 1); ++k)
    for (int j = std::max(0, y - r); j <= std::min(view.dims[1] - 1, y + r); ++j)
      for (int i = std::max(0, x - r); i <= std::min(view.dims[0] - 1, x + r); ++i)
        peak = std::max(peak, std::clamp(cells[view.index(i, j, k)] / 16, 0, 255));
  return peak;
}

TEST(PeakTrim, KeepsTheCellsHoldingTheFractionOfTheirNeighbourhoodsPeak) {
  // Odd sizes: planes do not start on a word, the last word is partial.
  const std::array<int, 3> dims{17, 9, 7};
  const std::size_t n = 17 * 9 * 7;
  std::vector<FusedCell> cells(n);
  testing::Lcg rng(5);
  for (std::size_t i = 0; i < n; ++i) {
    cells[i] = rng.uniform() < 0.5 ? 0 : static_cast<FusedCell>(rng.uniform() * 3000 - 500);
  }
  ZoneView view{{0, 0, 0}, {0, 0, 0}, dims, cells.data()};
  for (const int radius : {0, 1, 3}) {
    const PeakTrim trim(dims, 0.5, radius, kMinLevelStep);
    ZoneSnapshot snapshot(dims);
    snapshot.capture(view, 96, &trim);
    int kept = 0, trimmed = 0;
    for (int z = 0; z < 7; ++z)
      for (int y = 0; y < 9; ++y)
        for (int x = 0; x < 17; ++x) {
          const std::size_t i = view.index(x, y, z);
          const bool expected =
              cells[i] > 96 && 2 * (cells[i] / 16) >= peak_level(cells, view, x, y, z, radius);
          ASSERT_EQ(snapshot.occupied(i), expected) << x << "," << y << "," << z << " r " << radius;
          kept += expected ? 1 : 0;
          trimmed += cells[i] > 96 && !expected ? 1 : 0;
        }
    EXPECT_GT(kept, 20) << radius;
    if (radius > 0) {
      EXPECT_GT(trimmed, 20) << radius;
    }
  }
}

TEST(PeakTrim, TheHaloGoesAWeakThingApartStays) {
  // A wall (x = 10, 20 units) with the blur's halo in front and behind it
  // (5 units: occupied, a quarter of the wall), and a weak post (3 units) 4 cells
  // off: the halo goes, the wall and the post stay. Fraction 0 keeps everything.
  const std::array<int, 3> dims{24, 12, 6};
  std::vector<FusedCell> cells(24 * 12 * 6, 0);
  ZoneView view{{0, 0, 0}, {0, 0, 0}, dims, cells.data()};
  for (int z = 0; z < 6; ++z)
    for (int y = 0; y < 12; ++y) {
      cells[view.index(10, y, z)] = 20 * 64;
      cells[view.index(9, y, z)] = 5 * 64;
      cells[view.index(11, y, z)] = 5 * 64;
    }
  for (int z = 0; z < 6; ++z) cells[view.index(15, 6, z)] = 3 * 64;
  const PeakTrim trim(dims, 0.5, 3, kMinLevelStep);
  ZoneSnapshot snapshot(dims);
  snapshot.capture(view, 96, &trim);
  for (int z = 0; z < 6; ++z) {
    for (int y = 0; y < 12; ++y) {
      EXPECT_TRUE(snapshot.occupied(view.index(10, y, z)));
      EXPECT_FALSE(snapshot.occupied(view.index(9, y, z)));
      EXPECT_FALSE(snapshot.occupied(view.index(11, y, z)));
    }
    EXPECT_TRUE(snapshot.occupied(view.index(15, 6, z))) << "the post is 5 cells from the wall";
  }
  const PeakTrim off(dims, 0.0, 3, kMinLevelStep);
  EXPECT_FALSE(off.enabled());
  snapshot.capture(view, 96, &off);
  EXPECT_TRUE(snapshot.occupied(view.index(9, 0, 0)));
}

TEST(PeakTrim, LevelsReachTheSaturation) {
  // A post seen from every side saturates; the band its views leave in front of
  // it all round nears the limit it would have had at 64 units. Levels that stop
  // at 64 units read that halo as the post's equal; levels up to the saturation
  // (128 units here) leave it out.
  MapConfig config;
  EXPECT_EQ(coarse_level_step(config), kMinLevelStep) << "64 units: a quarter unit a level";
  config.saturation_units = 128.0;
  EXPECT_EQ(coarse_level_step(config), 32);
  config.saturation_units = 500.0;
  EXPECT_EQ(coarse_level_step(config), 128) << "a power of two: levels are a shift";
  config.saturation_units = 128.0;

  const std::array<int, 3> dims{12, 12, 3};
  std::vector<FusedCell> cells(12 * 12 * 3, 0);
  ZoneView view{{0, 0, 0}, {0, 0, 0}, dims, cells.data()};
  for (int z = 0; z < 3; ++z)
    for (int y = 4; y <= 7; ++y)
      for (int x = 4; x <= 7; ++x) {
        const bool post = x >= 5 && x <= 6 && y >= 5 && y <= 6;
        cells[view.index(x, y, z)] = static_cast<FusedCell>(post ? 128 * 64 : 60 * 64);
      }
  const int step = coarse_level_step(config);
  const PeakTrim trim(dims, 0.5, 3, step);
  ZoneSnapshot snapshot(dims, step);
  snapshot.capture(view, 96, &trim);
  EXPECT_TRUE(snapshot.occupied(view.index(5, 5, 1)));
  EXPECT_FALSE(snapshot.occupied(view.index(4, 5, 1))) << "60 of 128 units: the halo";
  EXPECT_EQ(snapshot.level(view.index(5, 5, 1)), 255);

  const PeakTrim clipped(dims, 0.5, 3, kMinLevelStep);
  ZoneSnapshot clipped_snapshot(dims);
  clipped_snapshot.capture(view, 96, &clipped);
  EXPECT_TRUE(clipped_snapshot.occupied(view.index(4, 5, 1)))
      << "levels clipped at 64 units: 60 reads as the post's equal";
}

}  // namespace
}  // namespace zonemap
