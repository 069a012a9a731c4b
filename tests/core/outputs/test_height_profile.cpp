// The height profile (paper fig. 11) folded from zones, against brute force.
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <map>
#include <utility>
#include <vector>

#include "zonemap/outputs/height_profile.hpp"

namespace zonemap {
namespace {

TEST(HeightProfile, FoldKeepsEachColumnsTopAndCountsColumnsOutside) {
  // A zone half outside the picture's rectangle, random occupancy, both
  // vertical conventions, folded twice (the second zone above the first):
  // every column's top is the brute-force highest occupied cell.
  const std::array<int, 3> dims = {7, 5, 6};
  std::vector<FusedCell> cells(static_cast<std::size_t>(dims[0] * dims[1] * dims[2]));
  std::uint32_t state = 99;
  for (const bool z_up : {true, false}) {
    HeightProfile profile(-3, -2, 1, 10, 10, z_up);  // columns x -3..1, y -2..10
    std::map<std::pair<int, int>, std::int32_t> expected;
    std::int64_t outside_columns = 0;
    for (int zone_index = 0; zone_index < 2; ++zone_index) {
      ZoneView zone{ZoneKey{}, CellIndex{-5, -1, zone_index * dims[2]}, dims, cells.data()};
      for (auto& c : cells) {
        state = state * 1664525u + 1013904223u;
        c = static_cast<FusedCell>((state >> 24) % 16 < 3 ? 20 : 5);
      }
      for (int y = 0; y < dims[1]; ++y)
        for (int x = 0; x < dims[0]; ++x) {
          const int wx = zone.origin.x + x, wy = zone.origin.y + y;
          bool any = false;
          for (int z = 0; z < dims[2]; ++z) {
            if (cells[zone.index(x, y, z)] <= 10) continue;
            any = true;
            const std::int32_t up = z_up ? zone.origin.z + z : -(zone.origin.z + z);
            auto [it, inserted] = expected.emplace(std::pair{wx, wy}, up);
            if (!inserted) it->second = std::max(it->second, up);
          }
          if (any && (wx < -3 || wx > 1 || wy < -2 || wy > 10)) ++outside_columns;
        }
      profile.fold(zone);
    }
    int checked = 0;
    for (int wx = -3; wx <= 1; ++wx)
      for (int wy = -2; wy <= 10; ++wy) {
        std::int32_t top = 0;
        const auto it = expected.find({wx, wy});
        ASSERT_EQ(profile.top(wx, wy, &top), it != expected.end()) << wx << "," << wy;
        if (it == expected.end()) continue;
        EXPECT_EQ(top, it->second) << wx << "," << wy << (z_up ? " z up" : " NED");
        ++checked;
      }
    EXPECT_GT(checked, 5);
    EXPECT_GT(outside_columns, 0);
    EXPECT_EQ(profile.columns_outside(), outside_columns);
  }
}

}  // namespace
}  // namespace zonemap
