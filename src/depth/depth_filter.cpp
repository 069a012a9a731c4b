#include "zonemap/depth/depth_filter.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "common/simd_u16.hpp"

namespace zonemap {

DepthFilter::DepthFilter(int width, int height, int radius, float resolution_per_code2)
    : width_(std::max(width, 1)),
      height_(std::max(height, 1)),
      radius_(std::clamp(radius, 0, kMaxDepthFilterRadius)),
      ring_rows_(2 * radius_ + 1),
      gate_per_code2_(kDepthFilterGate * resolution_per_code2),
      gate_cap_(static_cast<float>(32767 / ring_rows_)),
      centre_cap_(static_cast<std::uint16_t>(
          gate_per_code2_ > 0.0f
              ? std::min(65535.0, std::ceil(std::sqrt(static_cast<double>(gate_cap_) /
                                                      static_cast<double>(gate_per_code2_))) +
                                      1.0)
              : 65535.0)) {
  if (radius_ == 0) return;
  const auto w = static_cast<std::size_t>(width_);
  ring_.reset(new std::uint16_t[static_cast<std::size_t>(ring_rows_) * w]());
  out_.reset(new std::uint16_t[w]());
}

std::size_t DepthFilter::reserved_bytes() const {
  if (radius_ == 0) return 0;
  const auto w = static_cast<std::size_t>(width_);
  return w * static_cast<std::size_t>(ring_rows_ + 1) * sizeof(std::uint16_t);
}

void DepthFilter::begin(const std::uint16_t* depth, int first_row) {
  depth_ = depth;
  rows_done_ = std::max(0, first_row - radius_);
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

using simd::I16x8;
using simd::store_u16;
using simd::U16x8;
using F32x8 = float __attribute__((vector_size(32)));
using I32x8 = std::int32_t __attribute__((vector_size(32)));

// Eight centres at once. A tap is taken when it lies in its centre's window
// [lo, hi] = [max(centre - gate, 1), centre + gate] (saturated): a measurement
// within the gate, as |tap - centre| <= gate && tap != 0 says, in three
// instructions. Taken taps are summed modulo 2^16; the sum of their differences
// from the centre (at most 2r gates < 32768) comes out exact in diff_sum.
struct Lanes8 {
  U16x8 centre, lo, hi;
  U16x8 sum;    // the centre (it takes itself) and the taps taken, modulo 2^16
  I16x8 count;  // 1 + the taps taken
};
inline Lanes8 start_lanes(U16x8 centre, U16x8 gate) {
  const U16x8 lo = simd::max_u16(simd::saturating_sub(centre, gate), simd::splat_u16(1));
  return {centre, lo, simd::saturating_add(centre, gate), centre, I16x8{} + 1};
}
inline void take(Lanes8* lanes, U16x8 tap) {
  const I16x8 taken = simd::max_u16(simd::min_u16(tap, lanes->hi), lanes->lo) == tap;
  lanes->sum += tap & reinterpret_cast<U16x8>(taken);
  lanes->count -= taken;
}
inline I16x8 diff_sum(const Lanes8& lanes) {
  return reinterpret_cast<I16x8>(lanes.sum - lanes.centre * reinterpret_cast<U16x8>(lanes.count));
}

// The same for one centre (the row's ends).
inline void accumulate(std::uint16_t centre, std::uint16_t gate, std::uint16_t tap,
                       std::int32_t* sum, std::int32_t* count) {
  const int diff = static_cast<int>(tap) - static_cast<int>(centre);
  if (tap != 0 && std::abs(diff) <= gate) {
    *sum += diff;
    ++*count;
  }
}

// A centre's gate: eq. (1) at its depth, in codes, capped (one lane, or eight).
inline std::uint16_t gate_of(std::uint16_t centre, float gate_per_code2, float cap) {
  const auto c = static_cast<float>(centre);
  return static_cast<std::uint16_t>(std::min(gate_per_code2 * c * c, cap));
}
// Eight at once. The centres are first capped a code past where their gate
// reaches the cap (centre_cap: past float rounding too), so that the 32-bit products neither
// overflow nor wrap when narrowed; the 16-bit minimum then gives exactly the one-lane gate.
inline U16x8 gate_of(U16x8 centre, float gate_per_code2, U16x8 centre_cap, U16x8 cap) {
  const F32x8 c = __builtin_convertvector(simd::min_u16(centre, centre_cap), F32x8);
  const I32x8 whole = __builtin_convertvector(gate_per_code2 * c * c, I32x8);
  return simd::min_u16(__builtin_convertvector(whole, U16x8), cap);
}

// centre + the mean difference of the taps taken, rounded half up (truncating
// a positive number floors it: |mean| <= the gate < 32768); 0 where the centre
// is missing (it always takes itself, so count > 0 elsewhere).
inline std::uint16_t mean_of(std::uint16_t centre, std::int32_t sum, std::int32_t count) {
  const float mean = static_cast<float>(sum) / static_cast<float>(std::max(count, 1));
  const int step = static_cast<int>(mean + 32768.5f) - 32768;
  return centre == 0 ? std::uint16_t{0} : static_cast<std::uint16_t>(centre + step);
}
inline U16x8 mean_of(const Lanes8& lanes) {  // count >= 1 in every lane
  const F32x8 n = __builtin_convertvector(lanes.count, F32x8);
  const F32x8 mean = __builtin_convertvector(diff_sum(lanes), F32x8) / n;
  const I32x8 step = __builtin_convertvector(mean + 32768.5f, I32x8) - 32768;
  const U16x8 out = lanes.centre + __builtin_convertvector(step, U16x8);
  const I16x8 missing = lanes.centre == U16x8{};
  return reinterpret_cast<U16x8>(reinterpret_cast<I16x8>(out) & ~missing);
}

// Rows: eight centres at a time, their 2R other taps beside them in the row,
// from u while all of them lie in it; returns the first centre not done.
template <int R>
int row_lanes(const std::uint16_t* in, std::uint16_t* out, int u, int w, float gate_per_code2,
              U16x8 centre_cap, U16x8 cap) {
  for (; u + 8 + R <= w; u += 8) {
    const U16x8 centre = simd::load_u16(in + u);
    Lanes8 lanes = start_lanes(centre, gate_of(centre, gate_per_code2, centre_cap, cap));
    for (int k = 1; k <= R; ++k) {
      take(&lanes, simd::load_u16(in + u - k));
      take(&lanes, simd::load_u16(in + u + k));
    }
    store_u16(out + u, mean_of(lanes));
  }
  return u;
}

// Columns: eight centres at a time with `count` other rows' taps (R of them on
// either side inside the frame; count <= 2R at its top and bottom); returns
// the first centre not done.
template <int R>
int column_lanes(const std::uint16_t* centre_row, const std::uint16_t* const* taps, int count,
                 std::uint16_t* out, int w, float gate_per_code2, U16x8 centre_cap, U16x8 cap) {
  int u = 0;
  const auto lanes_at = [&](int at) {
    const U16x8 centre = simd::load_u16(centre_row + at);
    return start_lanes(centre, gate_of(centre, gate_per_code2, centre_cap, cap));
  };
  if (count == 2 * R) {  // the frame's inner rows: every tap, unrolled
    for (; u + 8 <= w; u += 8) {
      Lanes8 lanes = lanes_at(u);
      for (int t = 0; t < 2 * R; ++t) take(&lanes, simd::load_u16(taps[t] + u));
      store_u16(out + u, mean_of(lanes));
    }
  } else {
    for (; u + 8 <= w; u += 8) {
      Lanes8 lanes = lanes_at(u);
      for (int t = 0; t < count; ++t) take(&lanes, simd::load_u16(taps[t] + u));
      store_u16(out + u, mean_of(lanes));
    }
  }
  return u;
}

// The radius as a constant (the tap loops unroll): f.template operator()<R>().
template <class F>
int with_radius(int radius, F&& f) {
  static_assert(kMaxDepthFilterRadius == 8, "one case a radius");
  switch (radius) {
    case 1:
      return f.template operator()<1>();
    case 2:
      return f.template operator()<2>();
    case 3:
      return f.template operator()<3>();
    case 4:
      return f.template operator()<4>();
    case 5:
      return f.template operator()<5>();
    case 6:
      return f.template operator()<6>();
    case 7:
      return f.template operator()<7>();
    default:
      return f.template operator()<8>();
  }
}

}  // namespace

void DepthFilter::filter_along_row(const std::uint16_t* in, std::uint16_t* out) const {
  const int w = width_;
  const int r = radius_;
  // Eight centres at a time where all their taps lie in the row, one at a time
  // at the ends.
  const U16x8 cap = simd::splat_u16(static_cast<std::uint16_t>(gate_cap_));
  const U16x8 centre_cap = simd::splat_u16(centre_cap_);
  const auto one = [&](int u) {
    const std::uint16_t gate = gate_of(in[u], gate_per_code2_, gate_cap_);
    std::int32_t sum = 0, count = 0;
    for (int k = std::max(-r, -u); k <= std::min(r, w - 1 - u); ++k) {
      accumulate(in[u], gate, in[u + k], &sum, &count);
    }
    out[u] = mean_of(in[u], sum, count);
  };
  int u = 0;
  for (; u < std::min(r, w); ++u) one(u);
  u = with_radius(
      r, [&]<int R>() { return row_lanes<R>(in, out, u, w, gate_per_code2_, centre_cap, cap); });
  for (; u < w; ++u) one(u);
}

void DepthFilter::filter_along_column(int v, std::uint16_t* out) const {
  const int w = width_;
  const std::uint16_t* centre = ring_row(v);
  const int first = std::max(0, v - radius_);
  const int last = std::min(height_ - 1, v + radius_);
  const U16x8 cap = simd::splat_u16(static_cast<std::uint16_t>(gate_cap_));
  const U16x8 centre_cap = simd::splat_u16(centre_cap_);
  // The other rows (the centre takes itself).
  const std::uint16_t* taps[2 * kMaxDepthFilterRadius];
  int count = 0;
  for (int row = first; row <= last; ++row) {
    if (row != v) taps[count++] = ring_row(row);
  }
  int u = with_radius(radius_, [&]<int R>() {
    return column_lanes<R>(centre, taps, count, out, w, gate_per_code2_, centre_cap, cap);
  });
  for (; u < w; ++u) {
    const std::uint16_t gate = gate_of(centre[u], gate_per_code2_, gate_cap_);
    std::int32_t sum = 0, n = 1;  // the centre takes itself: difference 0
    for (int t = 0; t < count; ++t) accumulate(centre[u], gate, taps[t][u], &sum, &n);
    out[u] = mean_of(centre[u], sum, n);
  }
}

}  // namespace zonemap
