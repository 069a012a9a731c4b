// The minimum over a sliding window of a line of values, in constant work per
// value whatever the window (van Herk / Gil-Werman): the line is padded by r
// `none`s on each side and cut into blocks of 2r + 1; every window is then one
// block's suffix and the next block's prefix.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>

namespace zonemap {

// Values a line buffer for running_min must hold for n values and radius r.
constexpr std::size_t running_min_line_size(int n, int r) {
  return 3 * static_cast<std::size_t>(n + 2 * r);
}

// out[i * step] = the minimum of in[j * step] over |j - i| <= r, j in [0, n), for
// each i in [0, n); `none` (at least every value) where nothing else is in the
// window. `line` holds running_min_line_size(n, r) values; in and out may not
// overlap.
inline void running_min(const std::int16_t* in, std::int16_t* out, int n, std::ptrdiff_t step,
                        int r, std::int16_t none, std::int16_t* line) {
  const int k = 2 * r + 1;
  const int m = n + 2 * r;
  std::int16_t* padded = line;
  std::int16_t* prefix = line + m;
  std::int16_t* suffix = line + 2 * m;
  for (int i = 0; i < m; ++i) {
    padded[i] = i < r || i >= r + n ? none : in[static_cast<std::ptrdiff_t>(i - r) * step];
  }
  for (int start = 0; start < m; start += k) {
    const int end = std::min(start + k, m);  // one block: [start, end)
    prefix[start] = padded[start];
    for (int i = start + 1; i < end; ++i) prefix[i] = std::min(prefix[i - 1], padded[i]);
    suffix[end - 1] = padded[end - 1];
    for (int i = end - 2; i >= start; --i) suffix[i] = std::min(suffix[i + 1], padded[i]);
  }
  for (int i = 0; i < n; ++i) {
    out[static_cast<std::ptrdiff_t>(i) * step] = std::min(suffix[i], prefix[i + 2 * r]);
  }
}

}  // namespace zonemap
