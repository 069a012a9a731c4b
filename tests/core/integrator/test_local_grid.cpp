// The local grid M̂: ray traversal, max-write, blur (paper §III-C).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "core_test_support.hpp"
#include "zonemap/common/config.hpp"
#include "zonemap/integrator/local_grid.hpp"
#include "zonemap/zones/zone_map.hpp"

namespace zonemap {
namespace {

RayProfile hit_ray(float d_min, float depth, float resolution) {
  RayProfile ray;
  ray.delta_begin = d_min;
  ray.depth = depth;
  ray.range_resolution = resolution;
  ray.delta_end = depth + resolution;
  return ray;
}

TEST(LocalGrid, CellValuesAreQ6ClampedToOne) {
  static_assert(to_local_cell(1.0f) == kCellScale);
  EXPECT_EQ(to_local_cell(0.5f), 32);
  EXPECT_EQ(to_local_cell(-0.5f), -32);  // rounds half away from zero, symmetric
  EXPECT_EQ(to_local_cell(1.0f / 128.0f), 1);
  EXPECT_EQ(to_local_cell(-1.0f / 128.0f), -1);
  EXPECT_EQ(to_local_cell(3.0f), kCellScale);
  EXPECT_EQ(to_local_cell(-3.0f), -kCellScale);
  EXPECT_NE(to_local_cell(-1.0f), kUntouched);  // free is never "untouched"
}

TEST(LocalGrid, SingleRayFreeThenPeakThenUnknown) {
  LocalGrid grid({40, 5, 5});
  grid.reset(CellIndex{});
  // Along +x from the corner of cell (0, 2, 2): cell x spans δ in [x, x + 1].
  // d = 20.5, Δd = 0.5: free up to δ = 19.5, peak at 20.5, no influence past 21.
  const int visited =
      grid.draw_ray({0.0f, 2.5f, 2.5f}, {1.0f, 0.0f, 0.0f}, hit_ray(2.0f, 20.5f, 0.5f));
  EXPECT_EQ(visited, 19);  // cells 2..20
  grid.finish(0);
  EXPECT_EQ(grid.at(0, 2, 2), 0) << "before d_min: unknown";
  EXPECT_EQ(grid.at(1, 2, 2), 0);
  for (int x = 2; x <= 18; ++x) EXPECT_EQ(grid.at(x, 2, 2), -kCellScale) << "free at x=" << x;
  EXPECT_EQ(grid.at(19, 2, 2), 0) << "δ in [19, 20]: m̂ rises from -1 to 0";
  EXPECT_EQ(grid.at(20, 2, 2), kCellScale) << "the peak cell";
  for (int x = 21; x < 40; ++x) EXPECT_EQ(grid.at(x, 2, 2), 0) << "unknown behind, x=" << x;
  // Neighbouring rows untouched.
  EXPECT_EQ(grid.at(20, 1, 2), 0);
  EXPECT_EQ(grid.at(20, 2, 3), 0);
}

TEST(LocalGrid, DiagonalRayVisitsAConnectedChainOfCells) {
  LocalGrid grid({16, 16, 16});
  grid.reset(CellIndex{});
  const Eigen::Vector3f dir = Eigen::Vector3f(1.0f, 0.7f, 0.3f);
  const int visited = grid.draw_ray({0.5f, 0.5f, 0.5f}, dir, hit_ray(0.0f, 14.0f, 0.3f));
  grid.finish(0);
  // Exact traversal: every step changes one coordinate, so the count is the
  // Manhattan distance from the first to the last cell plus one.
  const Eigen::Vector3f end = Eigen::Vector3f(0.5f, 0.5f, 0.5f) + (14.0f + 0.3f) * dir;
  const int manhattan = static_cast<int>(std::floor(std::min(end.x(), 15.99f))) +
                        static_cast<int>(std::floor(end.y())) +
                        static_cast<int>(std::floor(end.z()));
  EXPECT_EQ(visited, manhattan + 1);
  const Eigen::Vector3f hit = Eigen::Vector3f(0.5f, 0.5f, 0.5f) + 14.0f * dir;
  if (hit.x() < 16.0f) {
    EXPECT_EQ(
        grid.at(static_cast<int>(hit.x()), static_cast<int>(hit.y()), static_cast<int>(hit.z())),
        kCellScale);
  }
}

TEST(LocalGrid, RaysLeavingTheGridAreClipped) {
  LocalGrid grid({8, 8, 8});
  grid.reset(CellIndex{});
  // Starts outside, crosses the grid, ends outside: only inside cells are written.
  const int visited =
      grid.draw_ray({-5.0f, 4.5f, 4.5f}, {1.0f, 0.0f, 0.0f}, hit_ray(0.0f, 30.0f, 1.0f));
  EXPECT_EQ(visited, 8);
  // Entirely outside: nothing.
  EXPECT_EQ(grid.draw_ray({-5.0f, 20.5f, 4.5f}, {1.0f, 0.0f, 0.0f}, hit_ray(0.0f, 30.0f, 1.0f)), 0);
}

TEST(LocalGrid, MaxWriteKeepsTheHighestValueWhateverTheOrder) {
  for (int order = 0; order < 2; ++order) {
    LocalGrid grid({20, 20, 4});
    grid.reset(CellIndex{});
    // Ray A along +x through row y = 10 ends on cell (10, 10); ray B along +y
    // through column x = 10 passes cell (10, 10) as free space.
    const auto ray_a = [&] {
      grid.draw_ray({0.0f, 10.5f, 1.5f}, {1.0f, 0, 0}, hit_ray(1.0f, 10.5f, 0.4f));
    };
    const auto ray_b = [&] {
      grid.draw_ray({10.5f, 0.0f, 1.5f}, {0, 1.0f, 0}, hit_ray(1.0f, 18.5f, 0.4f));
    };
    if (order == 0) {
      ray_a();
      ray_b();
    } else {
      ray_b();
      ray_a();
    }
    grid.finish(0);
    EXPECT_EQ(grid.at(10, 10, 1), kCellScale) << "order " << order;
    EXPECT_EQ(grid.at(10, 5, 1), -kCellScale);
    EXPECT_EQ(grid.at(5, 10, 1), -kCellScale);
  }
}

TEST(LocalGrid, BlurKeepsTheSignStructureAndIsSymmetric) {
  const std::array<int, 3> dims = {20, 20, 20};
  LocalGrid grid({20, 20, 20});
  LocalGrid negated({20, 20, 20});
  grid.reset(CellIndex{});
  negated.reset(CellIndex{});
  grid.extend_touched(0, 0, 0, 19, 19, 19);
  negated.extend_touched(0, 0, 0, 19, 19, 19);
  for (int z = 0; z < dims[2]; ++z)
    for (int y = 0; y < dims[1]; ++y)
      for (int x = 0; x < dims[0]; ++x) {
        const bool inside = x >= 8 && x < 12 && y >= 8 && y < 12 && z >= 8 && z < 12;
        const LocalCell v = static_cast<LocalCell>(inside ? kCellScale : -kCellScale / 2);
        grid.write_max(x, y, z, v);
        negated.write_max(x, y, z, static_cast<LocalCell>(-v));
      }
  grid.finish(1);
  negated.finish(1);
  EXPECT_GT(grid.at(9, 9, 9), 0) << "an occupied block stays occupied";
  EXPECT_GT(grid.at(10, 10, 10), kCellScale / 2);
  EXPECT_LT(grid.at(4, 4, 4), 0) << "free space stays free";
  EXPECT_EQ(grid.at(4, 4, 4), -kCellScale / 2) << "far from edges the blur of a constant is itself";
  EXPECT_LT(grid.at(6, 10, 10), 0) << "two cells away from the block: still free";
  for (int z = 0; z < dims[2]; ++z)
    for (int y = 0; y < dims[1]; ++y)
      for (int x = 0; x < dims[0]; ++x)
        ASSERT_EQ(grid.at(x, y, z), -negated.at(x, y, z)) << x << "," << y << "," << z;
  // The grid border blurs against unknown (0), so it weakens but keeps its sign.
  EXPECT_LT(grid.at(0, 0, 0), 0);
  EXPECT_GT(grid.at(0, 0, 0), -kCellScale / 2);
}

// The blur written the plain way: three passes of the binomial kernel, each
// rounded symmetrically, the cells outside the active region unknown (0), a
// cell not free before a pass not made free by it.
std::vector<int> reference_blur(std::vector<int> v, const std::array<int, 3>& n,
                                const std::array<int, 3>& lo, const std::array<int, 3>& hi,
                                int radius) {
  const int weights[3][5] = {{1, 0, 0, 0, 0}, {1, 2, 1, 0, 0}, {1, 4, 6, 4, 1}};
  const auto at = [&](const std::vector<int>& g, int x, int y, int z) {
    if (x < lo[0] || x > hi[0] || y < lo[1] || y > hi[1] || z < lo[2] || z > hi[2]) return 0;
    return g[static_cast<std::size_t>(x + n[0] * (y + n[1] * z))];
  };
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<int> out = v;
    for (int z = lo[2]; z <= hi[2]; ++z)
      for (int y = lo[1]; y <= hi[1]; ++y)
        for (int x = lo[0]; x <= hi[0]; ++x) {
          int sum = 0;
          for (int k = -radius; k <= radius; ++k) {
            const int dx = axis == 0 ? k : 0, dy = axis == 1 ? k : 0, dz = axis == 2 ? k : 0;
            sum += weights[radius][k + radius] * at(v, x + dx, y + dy, z + dz);
          }
          const int shift = 2 * radius, half = 1 << (shift - 1);
          const int value = sum >= 0 ? (sum + half) >> shift : -((-sum + half) >> shift);
          // A pass makes no cell free that was not free before it, and leaves an
          // occupied cell half its value where its neighbours would erase it.
          const int centre = at(v, x, y, z);
          out[static_cast<std::size_t>(x + n[0] * (y + n[1] * z))] =
              centre > 0 && value <= 0   ? (centre + 1) / 2
              : centre == 0 && value < 0 ? 0
                                         : value;
        }
    v = out;
  }
  return v;
}

TEST(LocalGrid, BlurEqualsThePlainThreePassBinomial) {
  // Random values in a touched box inside a larger grid, both kernel radii; then
  // with most x rows left empty (the blur and fusion pass over all-zero rows:
  // lone rows, pairs and runs of them, next to the region's faces); then with
  // short runs of values at shifting places (they work on each row's span only).
  // Each also blurred in three parts (the mapping workers' split).
  const std::array<int, 3> n = {23, 17, 11};
  const std::array<int, 3> touched_lo = {3, 2, 1}, touched_hi = {19, 14, 9};
  std::uint32_t state = 12345;
  testing::BackwardsSplit three(3);
  for (int variant = 0; variant < 12; ++variant) {
    WorkSplit* split = variant >= 6 ? &three : nullptr;
    const int radius = 1 + variant % 2;
    const bool sparse_rows = variant % 6 == 2 || variant % 6 == 3;
    const bool short_runs = variant % 6 >= 4;  // values in a few cells of each row, here and there
    LocalGrid grid(n);
    grid.reset(CellIndex{});
    grid.extend_touched(touched_lo[0], touched_lo[1], touched_lo[2], touched_hi[0], touched_hi[1],
                        touched_hi[2]);
    std::vector<int> values(static_cast<std::size_t>(n[0] * n[1] * n[2]), 0);
    for (int z = touched_lo[2]; z <= touched_hi[2]; ++z)
      for (int y = touched_lo[1]; y <= touched_hi[1]; ++y) {
        if (sparse_rows && (y * 7 + z * 3) % 5 != 0 && !(y == touched_lo[1] && z == 4)) continue;
        const int run_start = touched_lo[0] + (y * 5 + z * 11) % 15, run_length = (y + z) % 4;
        for (int x = touched_lo[0]; x <= touched_hi[0]; ++x) {
          if (short_runs && (x < run_start || x > run_start + run_length)) continue;
          state = state * 1664525u + 1013904223u;
          if ((state >> 28) < 3) continue;  // some cells stay untouched (unknown)
          const int v = static_cast<int>((state >> 8) % (2 * kCellScale + 1)) - kCellScale;
          grid.write_max(x, y, z, static_cast<LocalCell>(v));
          values[static_cast<std::size_t>(x + n[0] * (y + n[1] * z))] = v;
        }
      }
    grid.finish(radius, split);
    std::array<int, 3> lo{}, hi{};
    for (int a = 0; a < 3; ++a) {
      lo[static_cast<std::size_t>(a)] =
          std::max(touched_lo[static_cast<std::size_t>(a)] - radius, 0);
      hi[static_cast<std::size_t>(a)] = std::min(touched_hi[static_cast<std::size_t>(a)] + radius,
                                                 n[static_cast<std::size_t>(a)] - 1);
    }
    const std::vector<int> expected = reference_blur(values, n, lo, hi, radius);
    int differing = 0, unflagged = 0, zero_rows = 0;
    for (int z = 0; z < n[2]; ++z)
      for (int y = 0; y < n[1]; ++y) {
        bool row_zero = true;
        for (int x = 0; x < n[0]; ++x) {
          const bool active =
              x >= lo[0] && x <= hi[0] && y >= lo[1] && y <= hi[1] && z >= lo[2] && z <= hi[2];
          if (!active) continue;
          const int want = expected[static_cast<std::size_t>(x + n[0] * (y + n[1] * z))];
          differing += grid.at(x, y, z) != want;
          row_zero = row_zero && want == 0;
        }
        const bool in_region = y >= lo[1] && y <= hi[1] && z >= lo[2] && z <= hi[2];
        if (!in_region) continue;
        zero_rows += row_zero;
        // Fusion reads only the row's span: a value outside it would be lost.
        int span_lo = 0, span_hi = -1;
        const bool has_span = grid.row_span(y, z, &span_lo, &span_hi);
        for (int x = lo[0]; x <= hi[0]; ++x) {
          const bool inside = has_span && x >= span_lo && x <= span_hi;
          unflagged +=
              !inside && expected[static_cast<std::size_t>(x + n[0] * (y + n[1] * z))] != 0;
        }
      }
    EXPECT_EQ(differing, 0) << "variant " << variant;
    EXPECT_EQ(unflagged, 0) << "variant " << variant;
    if (sparse_rows) {
      EXPECT_GT(zero_rows, 0);  // the skipping was exercised
    }
  }
}

TEST(LocalGrid, TheBlurMakesNoCellFreeThatWasNotFree) {
  // One x row: free cells, then cells no ray reached (the inside of a trunk beside
  // the free space around it), then an occupied cell and unknown beyond it.
  LocalGrid grid({12, 3, 3});
  grid.reset(CellIndex{});
  grid.extend_touched(0, 0, 0, 11, 2, 2);
  for (int x = 0; x < 4; ++x) grid.write_max(x, 1, 1, static_cast<LocalCell>(-kCellScale));
  grid.write_max(8, 1, 1, static_cast<LocalCell>(kCellScale));
  grid.finish(1);
  EXPECT_LT(grid.at(3, 1, 1), 0) << "seen free stays free";
  EXPECT_EQ(grid.at(4, 1, 1), 0) << "unknown beside free space stays unknown";
  EXPECT_EQ(grid.at(3, 0, 1), 0) << "so does the row beside it";
  EXPECT_GT(grid.at(8, 1, 1), 0);
  EXPECT_GT(grid.at(9, 1, 1), 0) << "occupancy still spreads into unknown cells";
  EXPECT_GT(grid.at(8, 0, 1), 0);

  // A weakly occupied cell in free space: its free neighbours would make it free;
  // each of the three passes leaves it half instead.
  LocalGrid lone({5, 5, 5});
  lone.reset(CellIndex{});
  lone.extend_touched(0, 0, 0, 4, 4, 4);
  for (int z = 0; z < 5; ++z)
    for (int y = 0; y < 5; ++y)
      for (int x = 0; x < 5; ++x)
        lone.write_max(x, y, z,
                       static_cast<LocalCell>(x == 2 && y == 2 && z == 2 ? 8 : -kCellScale));
  lone.finish(1);
  EXPECT_EQ(lone.at(2, 2, 2), 1) << "8 halved by each pass, never erased";
  EXPECT_LT(lone.at(0, 0, 0), 0);
}

// A 7 x 7 x 6 grid: the column x = y = 3 occupied (m̂ = 1), every other cell free.
void draw_thin_post(LocalGrid& grid) {
  grid.reset(CellIndex{});
  grid.extend_touched(0, 0, 0, 6, 6, 5);
  for (int z = 0; z < 6; ++z)
    for (int y = 0; y < 7; ++y)
      for (int x = 0; x < 7; ++x)
        grid.write_max(x, y, z,
                       static_cast<LocalCell>(x == 3 && y == 3 ? kCellScale : -kCellScale));
}

TEST(LocalGrid, AThinPostSeenUpCloseStaysOccupiedThroughTheBlur) {
  // A post thinner than a cell seen from a few metres: one column of cells its
  // rays ended in (m̂ = 1), every cell around it crossed free by the rays that
  // passed beside it. The kernel alone gives the column (-1 + 2 - 1) / 4 = 0 in
  // x and then free in y; it stays occupied, a quarter of its value (x, y
  // passes), the column's own z neighbours keeping it there in z.
  LocalGrid grid({7, 7, 6});
  draw_thin_post(grid);
  grid.finish(1);
  for (int z = 1; z < 5; ++z) EXPECT_EQ(grid.at(3, 3, z), kCellScale / 4) << "z " << z;
  EXPECT_LT(grid.at(3, 2, 2), 0) << "the free space beside it stays free";
  EXPECT_LT(grid.at(1, 3, 2), 0);
}

// MapConfig::blur_keep_near_m: near the camera eq. (1)'s Δd is far under a cell,
// and the post of the test above keeps half its value instead of a quarter;
// beyond the depth, behind the camera or without the reservation, the plain rule.
TEST(LocalGrid, AThinPostNearTheCameraKeepsHalfItsValueThroughTheBlur) {
  const auto post_after = [](bool reserve, float camera_y, float depth_m) {
    LocalGrid grid({7, 7, 6});
    if (reserve) grid.enable_near_keep(MapConfig::kMaxKeepNearCells);
    draw_thin_post(grid);
    // 0.5 m cells, the camera looking along +y: the post 0.5 (3.5 - camera_y) m ahead.
    const LocalGrid::NearKeep near{{3.5f, camera_y, 3.0f}, {0.0f, 0.5f, 0.0f}, depth_m};
    grid.finish(1, nullptr, &near);
    for (int z = 1; z < 5; ++z) EXPECT_EQ(grid.at(3, 3, z), grid.at(3, 3, 2)) << "z " << z;
    EXPECT_LT(grid.at(3, 2, 2), 0) << "the free space beside it stays free";
    EXPECT_LT(grid.at(2, 3, 2), 0);
    return static_cast<int>(grid.at(3, 3, 2));
  };
  EXPECT_EQ(post_after(true, -2.0f, 8.0f), kCellScale / 2) << "2.75 m ahead, within 8 m";
  EXPECT_EQ(post_after(true, -2.0f, 2.5f), kCellScale / 4) << "beyond 2.5 m: the plain blur";
  EXPECT_EQ(post_after(true, 5.0f, 8.0f), kCellScale / 4) << "behind the camera";
  EXPECT_EQ(post_after(false, -2.0f, 8.0f), kCellScale / 4) << "nothing reserved";
}

TEST(LocalGrid, UntouchedCellsBecomeUnknown) {
  LocalGrid grid({4, 4, 4});
  grid.reset(CellIndex{});
  grid.extend_touched(0, 0, 0, 3, 3, 3);
  grid.finish(1);
  for (int z = 0; z < 4; ++z)
    for (int y = 0; y < 4; ++y)
      for (int x = 0; x < 4; ++x) EXPECT_EQ(grid.at(x, y, z), 0);
}

TEST(LocalGrid, RangeWeightingScalesFarOccupiedEvidenceOnly) {
  // Camera at grid x = 0 looking along +x, 1 m cells: δ of cell x is x + 0.5.
  LocalGrid grid({40, 3, 3});
  grid.reset(CellIndex{});
  grid.extend_touched(0, 0, 0, 39, 2, 2);
  for (const int x : {4, 13, 19, 39}) grid.write_max(x, 1, 1, kCellScale);
  grid.write_max(30, 1, 1, -kCellScale);  // free evidence, far: unchanged
  grid.write_max(20, 1, 1, 1);            // the smallest positive value stays positive
  grid.finish(0);
  const float full_m = 9.5f;  // full weight up to δ 9.5 m
  grid.weight_occupancy_by_range({0.0f, 1.5f, 1.5f}, {1.0f, 0.0f, 0.0f}, full_m, 0.25f);
  const auto expected = [&](float depth) {
    const float w = std::clamp(full_m * full_m / (depth * depth), 0.25f, 1.0f);
    return static_cast<LocalCell>(std::lround(static_cast<float>(kCellScale) * w));
  };
  EXPECT_EQ(grid.at(4, 1, 1), kCellScale) << "near: full weight";
  EXPECT_EQ(grid.at(13, 1, 1), expected(13.5f));  // ~0.5
  EXPECT_EQ(grid.at(19, 1, 1), expected(19.5f));  // the floor
  EXPECT_EQ(grid.at(39, 1, 1), kCellScale / 4) << "never below min_weight";
  EXPECT_EQ(grid.at(30, 1, 1), -kCellScale) << "free evidence keeps its weight";
  EXPECT_EQ(grid.at(20, 1, 1), 1);
  EXPECT_EQ(grid.at(10, 1, 1), 0) << "unknown stays unknown";
}

// Along one row of 1 m cells: ray A measures 10 m with Δd 2 (free up to 6 m,
// m̂ 0 at 8 m, peak at 10 m, gone at 12 m); ray B passes the same cells free up
// to 18 m. Drawn into a fresh 20 x 3 x 3 grid and finished without blur.
void draw_band_and_passing_ray(LocalGrid& grid) {
  grid.reset(CellIndex{});
  const Eigen::Vector3f start(0.0f, 1.5f, 1.5f), along_x(1.0f, 0.0f, 0.0f);
  RayProfile a;
  a.delta_begin = 0.0f;
  a.delta_end = 12.0f;
  a.depth = 10.0f;
  a.range_resolution = 2.0f;
  RayProfile b = a;
  b.delta_end = 19.5f;
  b.depth = 19.0f;
  b.range_resolution = 0.5f;
  grid.draw_ray(start, along_x, a);
  grid.draw_ray(start, along_x, b);
  grid.finish(0);
}

TEST(LocalGrid, SeeingThroughFreesTheBandWhereARayPassedFree) {
  // Max-write keeps A's band; seeing through (0.5) frees the cells where A
  // stayed below m̂ 0.5 and keeps the rest.
  for (const bool see_through : {false, true}) {
    LocalGrid grid({20, 3, 3});
    if (see_through)
      grid.enable_see_through(static_cast<LocalCell>(kCellScale / 2),
                              static_cast<LocalCell>(kCellScale / 2));
    draw_band_and_passing_ray(grid);
    EXPECT_EQ(grid.at(6, 1, 1), see_through ? -kCellScale : -kCellScale / 2) << see_through;
    EXPECT_EQ(grid.at(7, 1, 1), see_through ? -kCellScale : 0) << see_through;
    EXPECT_EQ(grid.at(8, 1, 1), kCellScale / 2) << "A reaches 0.5 in it: kept";
    EXPECT_EQ(grid.at(10, 1, 1), kCellScale) << "A's depth is in it";
    EXPECT_EQ(grid.at(15, 1, 1), -kCellScale);
    EXPECT_EQ(grid.at(2, 1, 1), -kCellScale);
  }
}

TEST(LocalGrid, SeeingThroughKeepsWhatLiesJustBehindAMeasuredSurface) {
  // The same rays, seeing through at 0.7. Cell 8 lies in front of
  // A's depth (m̂ 0.5 at most): seen through. Cell 11 lies behind it (A ended
  // before it, m̂ 0.5 at its near end): with see_through_behind 0.5 A keeps it
  // (the inside of a trunk whose edge rays pass by); at 0.7 it is freed.
  const auto q6 = [](double v) { return static_cast<LocalCell>(to_fixed(static_cast<float>(v))); };
  for (const double behind : {0.5, 0.7}) {
    LocalGrid grid({20, 3, 3});
    grid.enable_see_through(q6(0.7), q6(behind));
    draw_band_and_passing_ray(grid);
    EXPECT_EQ(grid.at(8, 1, 1), -kCellScale) << "in front of the surface: seen through";
    EXPECT_EQ(grid.at(9, 1, 1), kCellScale) << "A's depth ends it: kept";
    EXPECT_EQ(grid.at(10, 1, 1), kCellScale) << "A's depth is in it";
    EXPECT_EQ(grid.at(11, 1, 1), behind == 0.5 ? kCellScale / 2 : -kCellScale) << behind;
  }
}

TEST(Fusion, AddsAndSaturatesAtTheConfiguredRange) {
  MapConfig config;
  config.zone_cells = {4, 4, 4};
  config.saturation_units = 4.0;
  config.occupied_threshold_units = 1.5;
  ZoneMap zones(config);
  LocalGrid local(config.zone_cells);
  const CellIndex origin{0, 0, 0};  // exactly one zone
  zones.move_environment(origin);
  ASSERT_EQ(zones.live_zone_count(), 1);
  for (int frame = 0; frame < 100; ++frame) {
    local.reset(origin);
    local.extend_touched(0, 0, 0, 3, 3, 3);
    local.write_max(1, 1, 1, kCellScale);
    local.write_max(2, 2, 2, -kCellScale);
    local.write_max(3, 3, 3, kCellScale / 4);
    local.finish(0);
    zones.fuse(local);
    FusedCell v = 0;
    ASSERT_TRUE(zones.value_at({3, 3, 3}, &v));
    // Eq. (7): the sum of the frames so far, until the limit.
    EXPECT_EQ(v, std::min((frame + 1) * kCellScale / 4, 4 * kCellScale));
  }
  FusedCell v = 0;
  ASSERT_TRUE(zones.value_at({1, 1, 1}, &v));
  EXPECT_EQ(v, 4 * kCellScale);
  ASSERT_TRUE(zones.value_at({2, 2, 2}, &v));
  EXPECT_EQ(v, -4 * kCellScale);
  ASSERT_TRUE(zones.value_at({0, 0, 0}, &v));
  EXPECT_EQ(v, 0) << "unknown stays unknown";
}

}  // namespace
}  // namespace zonemap
