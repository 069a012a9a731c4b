#include "zonemap/depth_filter.hpp"

#include <algorithm>
#include <cmath>

namespace zonemap {

DepthFilter::DepthFilter(int width, int height, int radius, float resolution_per_code2)
    : width_(std::max(width, 1)),
      height_(std::max(height, 1)),
      radius_(std::clamp(radius, 0, kMaxDepthFilterRadius)),
      ring_rows_(2 * radius_ + 1),
      gate_per_code2_(kDepthFilterGate * resolution_per_code2) {
  if (radius_ == 0) return;
  const auto w = static_cast<std::size_t>(width_);
  ring_.reset(new std::uint16_t[static_cast<std::size_t>(ring_rows_) * w]());
  out_.reset(new std::uint16_t[w]());
  gate_.reset(new std::int32_t[w]());
  sum_.reset(new std::int32_t[w]());
  count_.reset(new std::int32_t[w]());
}

std::size_t DepthFilter::reserved_bytes() const {
  if (radius_ == 0) return 0;
  const auto w = static_cast<std::size_t>(width_);
  return w * (static_cast<std::size_t>(ring_rows_ + 1) * sizeof(std::uint16_t) +
              3 * sizeof(std::int32_t));
}

void DepthFilter::begin(const std::uint16_t* depth) {
  depth_ = depth;
  rows_done_ = 0;
}

const std::uint16_t* DepthFilter::row(int v) {
  const std::uint16_t* raw = depth_ + static_cast<std::size_t>(v) * width_;
  if (radius_ == 0) return raw;
  // Rows up to v + r filtered along the row (each once per frame: bounded by the height).
  const int needed = std::min(v + radius_, height_ - 1);
  for (; rows_done_ <= needed; ++rows_done_) {
    filter_along_row(depth_ + static_cast<std::size_t>(rows_done_) * width_,
                     ring_.get() + static_cast<std::size_t>(rows_done_ % ring_rows_) * width_);
  }
  filter_along_column(v, out_.get());
  return out_.get();
}

namespace {

// Adds each tap to its centre's sums where it is a measurement within the
// centre's gate (|tap - centre| <= gate, codes), branch-free in 32-bit lanes so
// that the loop over a row vectorises.
inline void add_taps(const std::uint16_t* __restrict centre, const std::int32_t* __restrict gate,
                     const std::uint16_t* __restrict tap, std::int32_t* __restrict sum,
                     std::int32_t* __restrict count, int n) {
  for (int u = 0; u < n; ++u) {
    const std::int32_t t = tap[u];
    const std::int32_t diff = t - static_cast<std::int32_t>(centre[u]);
    const std::int32_t take =
        static_cast<std::int32_t>((t != 0) & (diff <= gate[u]) & (-diff <= gate[u]));
    sum[u] += take * t;
    count[u] += take;
  }
}

// The centres' gates (eq. 1 at each centre's depth, codes) and zeroed sums.
inline void start_row(const std::uint16_t* __restrict centre, float gate_per_code2,
                      std::int32_t* __restrict gate, std::int32_t* __restrict sum,
                      std::int32_t* __restrict count, int n) {
  for (int u = 0; u < n; ++u) {
    const auto c = static_cast<float>(centre[u]);
    gate[u] = static_cast<std::int32_t>(std::min(gate_per_code2 * c * c, 65535.0f));
    sum[u] = 0;
    count[u] = 0;
  }
}

// The mean of the taps taken, rounded; 0 where the centre is missing (it always
// takes itself, so count > 0 elsewhere).
inline void gated_means(const std::uint16_t* __restrict centre, const std::int32_t* __restrict sum,
                        const std::int32_t* __restrict count, std::uint16_t* __restrict out,
                        int n) {
  for (int u = 0; u < n; ++u) {
    const float mean =
        static_cast<float>(sum[u]) / static_cast<float>(std::max(count[u], std::int32_t{1}));
    out[u] = centre[u] == 0 ? std::uint16_t{0} : static_cast<std::uint16_t>(mean + 0.5f);
  }
}

}  // namespace

void DepthFilter::filter_along_row(const std::uint16_t* in, std::uint16_t* out) const {
  const int w = width_;
  const int r = radius_;
  std::int32_t* gate = gate_.get();
  std::int32_t* sum = sum_.get();
  std::int32_t* count = count_.get();
  start_row(in, gate_per_code2_, gate, sum, count, w);
  for (int k = -r; k <= r; ++k) {
    // Centres whose tap u + k lies in the row.
    const int begin = std::max(0, -k);
    const int end = std::min(w, w - k);
    add_taps(in + begin, gate + begin, in + begin + k, sum + begin, count + begin, end - begin);
  }
  gated_means(in, sum, count, out, w);
}

void DepthFilter::filter_along_column(int v, std::uint16_t* out) const {
  const int w = width_;
  const std::uint16_t* centre = ring_row(v);
  std::int32_t* gate = gate_.get();
  std::int32_t* sum = sum_.get();
  std::int32_t* count = count_.get();
  start_row(centre, gate_per_code2_, gate, sum, count, w);
  const int first = std::max(0, v - radius_);
  const int last = std::min(height_ - 1, v + radius_);
  for (int t = first; t <= last; ++t) add_taps(centre, gate, ring_row(t), sum, count, w);
  gated_means(centre, sum, count, out, w);
}

}  // namespace zonemap
