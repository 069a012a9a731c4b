// The doubling window minimum over a plane of columns.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "zonemap/containers/window_min.hpp"

// The doubling window minimum is the window's minimum by definition, for every
// radius (past the plane's size too), odd plane sizes, strips cut short and
// `none` entries.
TEST(WindowMin, IsTheWindowsMinimumByDefinition) {
  const std::int16_t none = INT16_MAX;
  std::uint32_t state = 12345u;
  const auto next = [&state] {
    state = state * 1664525u + 1013904223u;
    return state >> 8;
  };
  for (const auto& [nx, ny] :
       {std::pair{1, 1}, std::pair{2, 7}, std::pair{40, 3}, std::pair{33, 70}, std::pair{97, 41}}) {
    for (const int r : {0, 1, 2, 3, 9, 12, 36, 45}) {
      const std::size_t n = static_cast<std::size_t>(nx) * ny;
      std::vector<std::int16_t> in(n);
      for (auto& v : in) v = next() % 5 == 0 ? none : static_cast<std::int16_t>(next() % 200);
      std::vector<std::int16_t> out(n, -7);
      std::vector<std::int16_t> buffer(zonemap::window_min_buffer_size(nx, ny, r));
      zonemap::window_min_plane(in.data(), out.data(), nx, ny, r, none, buffer.data());
      for (int y = 0; y < ny; ++y) {
        for (int x = 0; x < nx; ++x) {
          std::int16_t expected = none;
          for (int j = std::max(0, y - r); j <= std::min(ny - 1, y + r); ++j) {
            for (int i = std::max(0, x - r); i <= std::min(nx - 1, x + r); ++i) {
              expected = std::min(expected, in[static_cast<std::size_t>(j) * nx + i]);
            }
          }
          ASSERT_EQ(out[static_cast<std::size_t>(y) * nx + x], expected)
              << nx << "x" << ny << " r " << r << " at " << x << "," << y;
        }
      }
    }
  }
}
