// DepthRangeTable: any rectangle's depth range in O(1), built whole or in parts.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <tuple>
#include <utility>

#include "core_test_support.hpp"
#include "zonemap/common/work_split.hpp"
#include "zonemap/depth/depth_range_table.hpp"

namespace zonemap {
namespace {

TEST(DepthRangeTable, RangesMatchBruteForce) {
  // Odd sizes so that squares are cut at the right and bottom edges; missing,
  // far and real codes mixed, with whole missing patches. Built whole and in
  // three bands of rows.
  testing::BackwardsSplit three(3);
  for (const auto& [width, height, split] : {std::tuple<int, int, WorkSplit*>{37, 23, nullptr},
                                             {200, 130, nullptr},
                                             {1, 9, nullptr},
                                             {37, 23, &three},
                                             {200, 130, &three},
                                             {1, 9, &three}}) {
    DepthRangeTable table(width, height);
    testing::Lcg rng(static_cast<std::uint64_t>(width * 1000 + height));
    for (int i = 0; i < width * height; ++i) {
      const double r = rng.uniform();
      table.base()[i] = r < 0.2   ? DepthRangeTable::kMissing
                        : r < 0.3 ? DepthRangeTable::kFar
                                  : static_cast<std::uint16_t>(1.0 + rng.uniform() * 65000.0);
    }
    for (int y = 3; y < std::min(height, 12); ++y)
      for (int x = 0; x < std::min(width, 15); ++x)
        table.base()[y * width + x] = DepthRangeTable::kMissing;
    table.build(split);
    for (int k = 0; k < 6000; ++k) {
      const auto pick = [&](int n) { return static_cast<int>(rng.uniform() * n); };
      int x0 = pick(width), x1 = pick(width), y0 = pick(height), y1 = pick(height);
      if (x0 > x1) std::swap(x0, x1);
      if (y0 > y1) std::swap(y0, y1);
      if (k % 2 == 1) {  // small and elongated rectangles, the footprints' sizes
        x1 = std::min(width - 1, x0 + pick(40));
        y1 = std::min(height - 1, y0 + pick(k % 4 == 1 ? 12 : 40));
      }
      std::uint16_t lo_expected = DepthRangeTable::kMissing, hi_expected = 0;
      for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x) {
          const std::uint16_t v = table.codes()[y * width + x];
          if (v == DepthRangeTable::kMissing) continue;
          lo_expected = std::min(lo_expected, v);
          hi_expected = std::max(hi_expected, v);
        }
      std::uint16_t lo = 0, hi = 0;
      table.range(x0, y0, x1, y1, &lo, &hi);
      ASSERT_EQ(lo, lo_expected) << x0 << "," << y0 << " .. " << x1 << "," << y1;
      ASSERT_EQ(hi, hi_expected) << x0 << "," << y0 << " .. " << x1 << "," << y1;
    }
  }
}

}  // namespace
}  // namespace zonemap
