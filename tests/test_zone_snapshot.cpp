// Zone snapshots: what the extraction thread gets of a zone (one bit per cell,
// one byte per column), checked cell by cell against the zone.
#include <gtest/gtest.h>

#include <array>
#include <vector>

#include "tools/sim/scene.hpp"
#include "zonemap/zone_snapshot.hpp"

namespace zonemap {
namespace {

TEST(ZoneSnapshot, BitsAndColumnsMatchTheZoneCellByCell) {
  // Odd sizes: the last word is partial. Values around the threshold, zeros and
  // whole unknown columns.
  const std::array<int, 3> dims{13, 7, 11};
  const std::size_t n = 13 * 7 * 11;
  std::vector<FusedCell> cells(n);
  sim::Rng rng(77);
  for (std::size_t i = 0; i < n; ++i) {
    const double r = rng.uniform();
    cells[i] = r < 0.4 ? 0 : static_cast<FusedCell>(static_cast<int>(rng.uniform() * 400) - 200);
  }
  for (int z = 0; z < 11; ++z) cells[static_cast<std::size_t>(3 + 13 * (2 + 7 * z))] = 0;
  ZoneView view{{1, -2, 3}, {13, -14, 33}, dims, cells.data()};
  ZoneSnapshot snapshot(dims);
  snapshot.capture(view, 96);
  EXPECT_EQ(snapshot.key(), view.key);
  EXPECT_EQ(snapshot.origin(), view.origin);
  int occupied = 0;
  for (int z = 0; z < 11; ++z)
    for (int y = 0; y < 7; ++y)
      for (int x = 0; x < 13; ++x) {
        const std::size_t i = view.index(x, y, z);
        ASSERT_EQ(snapshot.occupied(i), cells[i] > 96) << x << "," << y << "," << z;
        occupied += snapshot.occupied(i) ? 1 : 0;
      }
  EXPECT_GT(occupied, 50);
  for (int y = 0; y < 7; ++y)
    for (int x = 0; x < 13; ++x) {
      bool known = false;
      for (int z = 0; z < 11; ++z) known = known || cells[view.index(x, y, z)] != 0;
      EXPECT_EQ(snapshot.column_known(x, y), known) << x << "," << y;
    }
  EXPECT_FALSE(snapshot.column_known(3, 2));
}

}  // namespace
}  // namespace zonemap
