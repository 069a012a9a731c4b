// QuadtreePool: footprints as quadtrees in a fixed pool (paper eq. 8).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "core_test_support.hpp"
#include "zonemap/containers/quadtree.hpp"

namespace zonemap {
namespace {

TEST(Quadtree, RoundTripIsIdentical) {
  QuadtreePool pool(4096, 64);
  testing::Lcg rng(3);
  for (const auto& [w, h] :
       std::vector<std::pair<int, int>>{{1, 1}, {3, 5}, {17, 9}, {64, 64}, {33, 2}}) {
    for (double density : {0.0, 0.3, 0.8, 1.0}) {
      std::vector<std::uint8_t> in(static_cast<std::size_t>(w) * h);
      for (auto& c : in) c = rng.uniform() < density ? 1 : 0;
      QuadNode root;
      int side = 0;
      const std::size_t free_before = pool.groups_free();
      ASSERT_TRUE(pool.build(in.data(), w, h, &root, &side));
      EXPECT_GE(side, std::max(w, h));
      std::vector<std::uint8_t> out(in.size(), 7);
      pool.rasterize(root, side, w, h, out.data());
      EXPECT_EQ(out, in) << w << "x" << h << " density " << density;
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          ASSERT_EQ(pool.contains(root, side, x, y), in[static_cast<std::size_t>(y) * w + x] != 0);
      pool.release(&root);
      EXPECT_EQ(pool.groups_free(), free_before) << "every node goes back to the pool";
    }
  }
}

TEST(Quadtree, UniformSquaresAreOneNode) {
  QuadtreePool pool(16, 16);
  std::vector<std::uint8_t> full(16 * 16, 1);
  QuadNode root;
  int side = 0;
  ASSERT_TRUE(pool.build(full.data(), 16, 16, &root, &side));
  EXPECT_EQ(root.state, QuadState::kFull);
  EXPECT_EQ(pool.node_count(root), 1u);
  // Full but not square: the padding is empty, so the root splits.
  std::vector<std::uint8_t> wide(16 * 8, 1);
  ASSERT_TRUE(pool.build(wide.data(), 16, 8, &root, &side));
  EXPECT_EQ(root.state, QuadState::kMixed);
  EXPECT_EQ(pool.node_count(root), 5u);
}

TEST(Quadtree, ExhaustedPoolRefusesAndLeaksNothing) {
  QuadtreePool pool(2, 64);
  std::vector<std::uint8_t> checker(32 * 32);
  for (int i = 0; i < 32 * 32; ++i) {
    checker[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(((i % 32) + i / 32) % 2);
  }
  QuadNode root;
  int side = 0;
  EXPECT_FALSE(pool.build(checker.data(), 32, 32, &root, &side));
  EXPECT_EQ(pool.groups_free(), 2u);
  EXPECT_EQ(root.state, QuadState::kEmpty);
}

}  // namespace
}  // namespace zonemap
