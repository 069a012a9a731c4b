// DepthRangeTable: any rectangle's depth range in O(1), built whole or in parts.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <tuple>
#include <utility>

#include "zonemap/common/work_split.hpp"
#include "zonemap/depth/depth_range_table.hpp"

namespace zonemap {
namespace {

// A small deterministic generator (the core's tests link the core alone).
class Lcg {
 public:
  explicit Lcg(std::uint64_t seed) : state_(seed * 2862933555777941757ULL + 3037000493ULL) {}
  double uniform() {  // [0, 1)
    state_ = state_ * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<double>(state_ >> 11) * (1.0 / 9007199254740992.0);
  }

 private:
  std::uint64_t state_;
};

// Runs a split's parts one after the other, last first: any order must give the
// same table.
class BackwardsSplit final : public WorkSplit {
 public:
  explicit BackwardsSplit(int parts) : parts_(parts) {}
  int parts() const override { return parts_; }
  void run(Job job, void* context) override {
    for (int p = parts_ - 1; p >= 0; --p) job(context, p, parts_);
  }

 private:
  int parts_;
};

TEST(DepthRangeTable, RangesMatchBruteForce) {
  // Odd sizes so that squares are cut at the right and bottom edges; missing,
  // far and real codes mixed, with whole missing patches. Built whole and in
  // three bands of rows.
  BackwardsSplit three(3);
  for (const auto& [width, height, split] : {std::tuple<int, int, WorkSplit*>{37, 23, nullptr},
                                             {200, 130, nullptr},
                                             {1, 9, nullptr},
                                             {37, 23, &three},
                                             {200, 130, &three},
                                             {1, 9, &three}}) {
    DepthRangeTable table(width, height);
    Lcg rng(static_cast<std::uint64_t>(width * 1000 + height));
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
