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
  gate_.reset(new float[w]());
  sum_.reset(new std::uint32_t[w]());
  count_.reset(new std::uint32_t[w]());
}

std::size_t DepthFilter::reserved_bytes() const {
  if (radius_ == 0) return 0;
  const auto w = static_cast<std::size_t>(width_);
  return w * (static_cast<std::size_t>(ring_rows_ + 1) * sizeof(std::uint16_t) + sizeof(float) +
              2 * sizeof(std::uint32_t));
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

// Adds `tap` to the sums where it is a measurement within the centre's gate:
// |tap - centre| <= gate, in float (exact for 16-bit codes), branch-free so that
// the loops over a row vectorise.
inline void add_tap(std::uint16_t centre, float gate, std::uint16_t tap, std::uint32_t* sum,
                    std::uint32_t* count) {
  const float diff = static_cast<float>(tap) - static_cast<float>(centre);
  const std::uint32_t take = (tap != 0) & (diff <= gate) & (-diff <= gate);
  *sum += take * tap;
  *count += take;
}

// The mean of the taps taken, rounded; 0 where the centre is missing (it always
// takes itself, so count > 0 elsewhere).
inline std::uint16_t gated_mean(std::uint16_t centre, std::uint32_t sum, std::uint32_t count) {
  const float mean = static_cast<float>(sum) / static_cast<float>(std::max(count, 1u));
  return centre == 0 ? std::uint16_t{0} : static_cast<std::uint16_t>(mean + 0.5f);
}

}  // namespace

void DepthFilter::filter_along_row(const std::uint16_t* in, std::uint16_t* out) const {
  const int w = width_;
  const int r = radius_;
  float* gate = gate_.get();
  std::uint32_t* sum = sum_.get();
  std::uint32_t* count = count_.get();
  for (int u = 0; u < w; ++u) {
    const auto c = static_cast<float>(in[u]);
    gate[u] = gate_per_code2_ * c * c;  // eq. (1) at the centre's depth
    sum[u] = 0;
    count[u] = 0;
  }
  for (int k = -r; k <= r; ++k) {
    // Centres whose tap u + k lies in the row.
    const int begin = std::max(0, -k);
    const int end = std::min(w, w - k);
    for (int u = begin; u < end; ++u) add_tap(in[u], gate[u], in[u + k], &sum[u], &count[u]);
  }
  for (int u = 0; u < w; ++u) out[u] = gated_mean(in[u], sum[u], count[u]);
}

void DepthFilter::filter_along_column(int v, std::uint16_t* out) const {
  const int w = width_;
  const std::uint16_t* centre = ring_row(v);
  float* gate = gate_.get();
  std::uint32_t* sum = sum_.get();
  std::uint32_t* count = count_.get();
  for (int u = 0; u < w; ++u) {
    const auto c = static_cast<float>(centre[u]);
    gate[u] = gate_per_code2_ * c * c;
    sum[u] = 0;
    count[u] = 0;
  }
  const int first = std::max(0, v - radius_);
  const int last = std::min(height_ - 1, v + radius_);
  for (int t = first; t <= last; ++t) {
    const std::uint16_t* tap = ring_row(t);
    for (int u = 0; u < w; ++u) add_tap(centre[u], gate[u], tap[u], &sum[u], &count[u]);
  }
  for (int u = 0; u < w; ++u) out[u] = gated_mean(centre[u], sum[u], count[u]);
}

}  // namespace zonemap
