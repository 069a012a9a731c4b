// Planner queries against brute force: every occupied cell (grid and feature
// shapes) tested against the segment with an exact slab test (no allocation:
// tests/test_core_allocations.cpp).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "outputs/query_world.hpp"
#include "zonemap/outputs/queries.hpp"

namespace zonemap {
namespace {

using testing::World;

bool brute_blocked(const World& w, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                   double* t_first) {
  const Eigen::Vector3d d = b - a;
  double best = INFINITY;
  for (const CellIndex& c : w.occupied) {
    const Eigen::Vector3d lo = Eigen::Vector3d(c.x, c.y, c.z) * w.config.cell_size_m;
    const Eigen::Vector3d hi = lo + Eigen::Vector3d::Constant(w.config.cell_size_m);
    double t0 = 0.0, t1 = 1.0;
    bool meets = true;
    for (int k = 0; k < 3 && meets; ++k) {
      if (std::fabs(d[k]) < 1e-15) {
        meets = a[k] >= lo[k] && a[k] <= hi[k];
        continue;
      }
      double ta = (lo[k] - a[k]) / d[k], tb = (hi[k] - a[k]) / d[k];
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
      meets = t0 <= t1;
    }
    if (meets) best = std::min(best, t0);
  }
  *t_first = best;
  return std::isfinite(best);
}

TEST(Queries, SegmentsAndRaysAgreeWithBruteForce) {
  World w;
  ASSERT_GT(w.features.count(), 0u);
  MapQueries q(w.features, w.zones, w.config.cell_size_m, 1);
  sim::Rng rng(5);
  int blocked = 0, free = 0;
  for (int i = 0; i < 3000; ++i) {
    // Segments across the live zones and the far feature-only zone.
    const Eigen::Vector3d a(rng.uniform() * 36.0 - 6.0, rng.uniform() * 12.0 - 2.0,
                            rng.uniform() * 6.0 - 1.0);
    const Eigen::Vector3d b(rng.uniform() * 36.0 - 6.0, rng.uniform() * 12.0 - 2.0,
                            rng.uniform() * 6.0 - 1.0);
    double t_first = 0.0;
    const bool expected = brute_blocked(w, a, b, &t_first);
    ASSERT_EQ(q.is_free(a, b), !expected) << "segment " << i;
    const RayHit hit = q.first_hit(a, b - a, (b - a).norm());
    ASSERT_EQ(hit.hit, expected) << "ray " << i;
    if (expected) {
      ASSERT_NEAR(hit.distance_m, t_first * (b - a).norm(), 1e-9) << "ray " << i;
      ++blocked;
    } else {
      ++free;
    }
  }
  EXPECT_GT(blocked, 100);
  EXPECT_GT(free, 100);
}

TEST(Queries, ObstaclesInBoxAgreeWithBruteForce) {
  World w;
  MapQueries q(w.features, w.zones, w.config.cell_size_m, 1);
  sim::Rng rng(9);
  std::vector<std::uint32_t> ids(64);
  int non_empty = 0;
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector3d lo(24.0 + rng.uniform() * 8.0, rng.uniform() * 8.0, rng.uniform() * 4.0);
    const Eigen::Vector3d hi =
        lo + Eigen::Vector3d(rng.uniform() * 3.0, rng.uniform() * 3.0, rng.uniform() * 2.0);
    std::vector<std::uint32_t> expected;
    for (const auto& [c, id] : w.obstacle_cells) {
      const Eigen::Vector3d centre =
          (Eigen::Vector3d(c.x, c.y, c.z) + Eigen::Vector3d::Constant(0.5)) * 0.5;
      // A cell counts when it overlaps the query box.
      const Eigen::Vector3d clo = centre - Eigen::Vector3d::Constant(0.25);
      const Eigen::Vector3d chi = centre + Eigen::Vector3d::Constant(0.25);
      if ((clo.array() < hi.array()).all() && (lo.array() < chi.array()).all() &&
          std::find(expected.begin(), expected.end(), id) == expected.end())
        expected.push_back(id);
    }
    const std::size_t n = q.obstacles_in(lo, hi, ids.data(), ids.size());
    std::vector<std::uint32_t> got(ids.begin(), ids.begin() + static_cast<long>(n));
    std::sort(got.begin(), got.end());
    std::sort(expected.begin(), expected.end());
    ASSERT_EQ(got, expected) << "box " << i;
    non_empty += expected.empty() ? 0 : 1;
  }
  EXPECT_GT(non_empty, 50);
  EXPECT_LT(non_empty, 450);
}

}  // namespace
}  // namespace zonemap
