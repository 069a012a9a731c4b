#include "zonemap/containers/window_min.hpp"

#include <algorithm>
#include <utility>

namespace zonemap {

namespace {

// dst[i] = min(a[i], b[i]) (a and b may be the same array; dst is apart).
inline void min_of(std::int16_t* __restrict dst, const std::int16_t* __restrict a,
                   const std::int16_t* __restrict b, int n) {
  for (int i = 0; i < n; ++i) dst[i] = std::min(a[i], b[i]);
}

// dst[i] = min(dst[i], b[i]) (b apart from dst).
inline void min_into(std::int16_t* __restrict dst, const std::int16_t* __restrict b, int n) {
  for (int i = 0; i < n; ++i) dst[i] = std::min(dst[i], b[i]);
}

int largest_power_of_two_within(int k) {
  int power = 1;
  while (2 * power <= k) power *= 2;
  return power;
}

}  // namespace

void window_min_plane(const std::int16_t* in, std::int16_t* out, int nx, int ny, int r,
                      std::int16_t none, std::int16_t* buffer) {
  const int k = 2 * r + 1;
  const int power = largest_power_of_two_within(k);
  // Along x: each row padded with r `none`s on both sides; after the passes,
  // line[i] is the minimum of the padded row's [i, i + power).
  const int padded_w = nx + 2 * r;
  std::int16_t* const line_a = buffer;
  std::int16_t* const line_b = buffer + padded_w;
  for (int y = 0; y < ny; ++y) {
    std::fill_n(line_a, r, none);
    std::copy_n(in + static_cast<std::ptrdiff_t>(y) * nx, nx, line_a + r);
    std::fill_n(line_a + r + nx, r, none);
    std::int16_t* line = line_a;
    std::int16_t* next = line_b;
    for (int h = 1; 2 * h <= k; h *= 2) {
      min_of(next, line, line + h, padded_w - 2 * h + 1);
      std::swap(line, next);
    }
    min_of(out + static_cast<std::ptrdiff_t>(y) * nx, line, line + (k - power), nx);
  }
  // Along y, in place in out, a strip of columns at a time (rows of the strip
  // padded above and below as the rows were).
  const int padded_h = ny + 2 * r;
  std::int16_t* const strip = buffer + 2 * static_cast<std::ptrdiff_t>(padded_w);
  for (int x0 = 0; x0 < nx; x0 += kWindowStrip) {
    const int sw = std::min(kWindowStrip, nx - x0);
    const auto strip_row = [&](int i) { return strip + static_cast<std::ptrdiff_t>(i) * sw; };
    const auto out_row = [&](int y) { return out + static_cast<std::ptrdiff_t>(y) * nx + x0; };
    std::fill_n(strip, static_cast<std::ptrdiff_t>(r) * sw, none);
    for (int y = 0; y < ny; ++y) std::copy_n(out_row(y), sw, strip_row(y + r));
    std::fill_n(strip_row(r + ny), static_cast<std::ptrdiff_t>(r) * sw, none);
    // Rows in increasing order: row i + h is read before its own turn.
    for (int h = 1; 2 * h <= k; h *= 2) {
      for (int i = 0; i + 2 * h <= padded_h; ++i) min_into(strip_row(i), strip_row(i + h), sw);
    }
    for (int y = 0; y < ny; ++y) min_of(out_row(y), strip_row(y), strip_row(y + k - power), sw);
  }
}

}  // namespace zonemap
