// A fixed-size latency histogram (log-spaced bins from 1 µs to ~100 s), for
// per-stage and end-to-end timing without allocation. One writer; read after.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>

namespace zonemap {

class LatencyHistogram {
 public:
  static constexpr int kBins = 160;  // 20 bins per decade over 8 decades
  void record(double ms) {
    ++count_;
    max_ms_ = std::fmax(max_ms_, ms);
    ++bins_[static_cast<std::size_t>(bin_of(ms))];
  }
  // The upper edge of the bin holding the q-quantile (q in [0, 1]), in ms.
  double percentile(double q) const {
    if (count_ == 0) return 0.0;
    const auto target = static_cast<std::uint64_t>(std::ceil(q * static_cast<double>(count_)));
    std::uint64_t seen = 0;
    for (int b = 0; b < kBins; ++b) {
      seen += bins_[static_cast<std::size_t>(b)];
      if (seen >= target && seen > 0) return std::fmin(upper_edge(b), max_ms_);
    }
    return max_ms_;
  }
  std::uint64_t count() const { return count_; }
  static double upper_edge(int b) { return 1e-3 * std::pow(10.0, b / 20.0); }
  // Samples in bin b (its upper edge: upper_edge(b)), for plotting.
  std::uint64_t bin_count(int b) const { return bins_[static_cast<std::size_t>(b)]; }
  double max_ms() const { return max_ms_; }
  std::uint64_t count_above(double ms) const {
    std::uint64_t n = 0;
    for (int b = bin_of(ms) + 1; b < kBins; ++b) n += bins_[static_cast<std::size_t>(b)];
    return n;
  }

 private:
  static int bin_of(double ms) {
    if (!(ms > 1e-3)) return 0;
    const int b = static_cast<int>(std::floor(std::log10(ms / 1e-3) * 20.0)) + 1;
    return b < 0 ? 0 : (b >= kBins ? kBins - 1 : b);
  }

  std::array<std::uint64_t, kBins> bins_{};
  std::uint64_t count_ = 0;
  double max_ms_ = 0.0;
};

}  // namespace zonemap
