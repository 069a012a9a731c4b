// The minimum over a square window of a plane of values, in O(log r) work per
// value (vectorised): a window of 2r + 1 is two overlapping windows of the
// largest power of two L <= 2r + 1, and a window of 2h is two of h, so log2(L)
// passes of pairwise minima, each over whole rows, give it. Along x row by row;
// along y in strips of kWindowStrip columns, which keeps the buffer small.
#pragma once

#include <cstddef>
#include <cstdint>

namespace zonemap {

inline constexpr int kWindowStrip = 32;

// Values the buffer of window_min_plane must hold for an nx x ny plane and
// radii up to r.
constexpr std::size_t window_min_buffer_size(int nx, int ny, int r) {
  return 2 * static_cast<std::size_t>(nx + 2 * r) +
         static_cast<std::size_t>(kWindowStrip) * static_cast<std::size_t>(ny + 2 * r);
}

// out[y * nx + x] = the minimum of in over |dx| <= r, |dy| <= r inside the
// plane; `none` (at least every value) where nothing else is in the window.
// in and out may not overlap; `buffer` holds window_min_buffer_size(nx, ny, r).
void window_min_plane(const std::int16_t* in, std::int16_t* out, int nx, int ny, int r,
                      std::int16_t none, std::int16_t* buffer);

}  // namespace zonemap
