#include "zonemap/depth/sky_filter.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace zonemap {

SkyFilter::SkyFilter(const SkyFilterConfig& config, const CameraModel& camera)
    : config_(config),
      width_(std::max(camera.width, 1)),
      height_(std::max(camera.height, 1)),
      max_runs_(kRunsPerRow * std::max(camera.height, 1)),
      inv_fx_(static_cast<float>(1.0 / camera.fx)),
      inv_fy_(static_cast<float>(1.0 / camera.fy)),
      cx_(static_cast<float>(camera.cx)),
      cy_(static_cast<float>(camera.cy)),
      sin2_margin_(
          static_cast<float>(std::pow(std::sin(config.horizon_margin_deg * M_PI / 180.0), 2))),
      limit_(new std::int16_t[static_cast<std::size_t>(width_)]()),
      run_start_(new std::int16_t[static_cast<std::size_t>(width_)]()),
      pending_start_(new std::int16_t[static_cast<std::size_t>(width_)]()),
      pending_gap_(new std::int16_t[static_cast<std::size_t>(width_)]()),
      open_(new std::uint8_t[static_cast<std::size_t>(width_)]()),
      limited_(new std::uint8_t[static_cast<std::size_t>(width_)]()),
      run_begin_(new std::int16_t[static_cast<std::size_t>(max_runs_)]()),
      run_end_(new std::int16_t[static_cast<std::size_t>(max_runs_)]()),
      row_first_(new std::int32_t[static_cast<std::size_t>(height_) + 1]()),
      parent_(new std::int32_t[static_cast<std::size_t>(max_runs_)]()),
      region_(new std::uint8_t[static_cast<std::size_t>(max_runs_)]()),
      area_(new std::int32_t[static_cast<std::size_t>(max_runs_)]()),
      min_region_px_(
          static_cast<int>(std::ceil(config.min_region_share * camera.width * camera.height))),
      rows_(new std::uint8_t[3 * static_cast<std::size_t>(width_)]()),
      side_(new std::int8_t[static_cast<std::size_t>(width_)]()),
      live_(new std::uint8_t[static_cast<std::size_t>(width_)]()) {}

std::size_t SkyFilter::reserved_bytes() const {
  const auto w = static_cast<std::size_t>(width_);
  const auto runs = static_cast<std::size_t>(max_runs_);
  return w * (4 * sizeof(std::int16_t) + 2 + 3 + 1 + 1) +
         runs * (2 * sizeof(std::int16_t) + 2 * sizeof(std::int32_t) + 1) +
         (static_cast<std::size_t>(height_) + 1) * sizeof(std::int32_t);
}

void SkyFilter::candidate_row(const std::uint8_t* left, int v, std::uint8_t* flags) const {
  const int w = width_;
  const int h = height_;
  const std::uint8_t* rows[3] = {left + static_cast<std::size_t>(std::max(v - 1, 0)) * w,
                                 left + static_cast<std::size_t>(v) * w,
                                 left + static_cast<std::size_t>(std::min(v + 1, h - 1)) * w};
  const auto min_intensity = static_cast<std::uint8_t>(config_.min_intensity);
  const auto max_gradient = static_cast<std::uint8_t>(config_.max_gradient);
  // Every neighbour n is within g of the centre c when max(n) - c <= g and
  // c - min(n) <= g: the 3 x 3 maximum and minimum, separably (columns first).
  std::uint8_t* column_max = flags + w;
  std::uint8_t* column_min = flags + 2 * static_cast<std::size_t>(w);
  for (int u = 0; u < w; ++u) {
    column_max[u] = std::max(std::max(rows[0][u], rows[1][u]), rows[2][u]);
    column_min[u] = std::min(std::min(rows[0][u], rows[1][u]), rows[2][u]);
  }
  // Edge columns repeat their neighbour (the image is clamped at its border).
  const auto flag = [&](std::uint8_t centre, std::uint8_t high, std::uint8_t low) {
    return static_cast<std::uint8_t>(centre >= min_intensity &&
                                     static_cast<std::uint8_t>(high - centre) <= max_gradient &&
                                     static_cast<std::uint8_t>(centre - low) <= max_gradient);
  };
  if (w < 3) {
    for (int u = 0; u < w; ++u) {
      const int l = std::max(u - 1, 0), r = std::min(u + 1, w - 1);
      flags[u] = flag(rows[1][u], std::max(column_max[l], column_max[r]),
                      std::min(column_min[l], column_min[r]));
    }
    return;
  }
  flags[0] = flag(rows[1][0], std::max(column_max[0], column_max[1]),
                  std::min(column_min[0], column_min[1]));
  flags[w - 1] = flag(rows[1][w - 1], std::max(column_max[w - 2], column_max[w - 1]),
                      std::min(column_min[w - 2], column_min[w - 1]));
  // The interior without clamping: plain byte arithmetic the compiler vectorises.
  for (int u = 1; u < w - 1; ++u) {
    const std::uint8_t high =
        std::max(std::max(column_max[u - 1], column_max[u]), column_max[u + 1]);
    const std::uint8_t low =
        std::min(std::min(column_min[u - 1], column_min[u]), column_min[u + 1]);
    flags[u] = flag(rows[1][u], high, low);
  }
}

int SkyFilter::side_at(int u, float s0, float n0, const Eigen::Vector3f& up_camera) const {
  // The pixel's ray (x, y, 1) against the up direction: sin(elevation) = s / |ray|,
  // beyond the margin where s² > sin²(margin) |ray|².
  const float x = (static_cast<float>(u) - cx_) * inv_fx_;
  const float s = up_camera.x() * x + s0;
  if (!(s * s > sin2_margin_ * (x * x + n0))) return 0;
  return s > 0.0f ? 1 : -1;
}

void SkyFilter::side_row(int v, const Eigen::Vector3f& up_camera, std::int8_t* side) const {
  const float y = (static_cast<float>(v) - cy_) * inv_fy_;
  const float s0 = up_camera.y() * y + up_camera.z();
  const float n0 = y * y + 1.0f;
  // Along a row s is linear in x and s² - sin²(margin) |ray|² quadratic: the side
  // changes only at their roots. Between them it is one value (a pixel inside the
  // stretch says which); the pixels next to each root are taken one by one.
  const double a = up_camera.x(), k = sin2_margin_;
  double roots[3];
  int n = 0;
  const auto add_root = [&](double x) {
    const double u = x / inv_fx_ + cx_;
    if (u > -2.0 && u < width_ + 1.0) roots[n++] = u;
  };
  if (a != 0.0) add_root(-s0 / a);
  const double qa = a * a - k, qb = 2.0 * a * s0, qc = double{s0} * s0 - k * n0;
  if (std::abs(qa) > 1e-12) {
    const double discriminant = qb * qb - 4.0 * qa * qc;
    if (discriminant > 0.0) {
      const double r = std::sqrt(discriminant);
      add_root((-qb - r) / (2.0 * qa));
      add_root((-qb + r) / (2.0 * qa));
    }
  } else if (qb != 0.0) {
    add_root(-qc / qb);
  }
  // At most three: sorted by compare-and-swap.
  for (int i = 0; i + 1 < n; ++i)
    for (int j = i + 1; j < n; ++j)
      if (roots[j] < roots[i]) std::swap(roots[i], roots[j]);
  int start = 0;
  for (int i = 0; i <= n; ++i) {
    const int end =
        i < n ? std::clamp(static_cast<int>(std::floor(roots[i])) + 1, start, width_) : width_;
    if (end > start) {
      const int value = side_at((start + end - 1) / 2, s0, n0, up_camera);
      std::fill(side + start, side + end, static_cast<std::int8_t>(value));
    }
    start = end;
  }
  for (int i = 0; i < n; ++i) {
    const int near = static_cast<int>(std::floor(roots[i]));
    for (int u = std::max(near - 1, 0); u <= std::min(near + 2, width_ - 1); ++u) {
      side[u] = static_cast<std::int8_t>(side_at(u, s0, n0, up_camera));
    }
  }
}

int SkyFilter::root(int run) const {
  while (parent_[static_cast<std::size_t>(run)] != run)
    run = parent_[static_cast<std::size_t>(run)];
  return run;
}

void SkyFilter::join(int a, int b) {
  a = root(a);
  b = root(b);
  if (a == b) return;
  // The older run is the root: every parent precedes its child, so one pass in
  // order flattens the forest.
  if (b < a) std::swap(a, b);
  parent_[static_cast<std::size_t>(b)] = a;
  region_[static_cast<std::size_t>(a)] |= region_[static_cast<std::size_t>(b)];
}

bool SkyFilter::add_runs(int v, const std::uint16_t* depth_row, const std::uint8_t* flags,
                         const std::int8_t* side) {
  // Live: an open column's candidate. One pass of byte arithmetic that vectorises.
  std::uint8_t* live = live_.get();
  for (int u = 0; u < width_; ++u) {
    live[u] = static_cast<std::uint8_t>(open_[static_cast<std::size_t>(u)] &
                                        (depth_row[u] == 0 ? 1 : 0) & flags[u]);
  }
  int count = row_first_[static_cast<std::size_t>(v)];
  const int previous_end = count;
  int previous = v > 0 ? row_first_[static_cast<std::size_t>(v) - 1] : count;
  for (int u = 0; u < width_;) {
    if (live[u] == 0) {
      ++u;
      continue;
    }
    if (count == max_runs_) return false;
    const int begin = u;
    // The run's end: the next 0 byte (memchr scans many bytes at a time).
    const void* zero = std::memchr(live + u, 0, static_cast<std::size_t>(width_ - u));
    u = zero == nullptr ? width_ : static_cast<int>(static_cast<const std::uint8_t*>(zero) - live);
    std::int8_t highest = -1, lowest = 1;
    for (int k = begin; k < u; ++k) {
      highest = std::max(highest, side[k]);
      lowest = std::min(lowest, side[k]);
    }
    const unsigned reach = (highest > 0 ? kHigh : 0u) | (lowest < 0 ? kLow : 0u);
    const auto r = static_cast<std::size_t>(count);
    run_begin_[r] = static_cast<std::int16_t>(begin);
    run_end_[r] = static_cast<std::int16_t>(u);
    parent_[r] = count;
    region_[r] = static_cast<std::uint8_t>(reach);
    // The previous row's runs touching this one (8-connected): [pb, pe) meets
    // [begin, u) when pb <= u and begin <= pe. Both rows are sorted by column.
    while (previous < previous_end && run_end_[static_cast<std::size_t>(previous)] < begin) {
      ++previous;
    }
    for (int p = previous; p < previous_end && run_begin_[static_cast<std::size_t>(p)] <= u; ++p) {
      join(p, count);
    }
    ++count;
  }
  row_first_[static_cast<std::size_t>(v) + 1] = count;
  return true;
}

void SkyFilter::close(int u, int limit) {
  limit_[static_cast<std::size_t>(u)] = static_cast<std::int16_t>(limit);
  limited_[static_cast<std::size_t>(u)] = 1;
}

void SkyFilter::stop_tracking(int u) {
  open_[static_cast<std::size_t>(u)] = 0;
  --open_columns_;
}

void SkyFilter::step_column(int u, int v, bool measured, bool candidate, int side) {
  const auto c = static_cast<std::size_t>(u);
  std::int16_t& run = run_start_[c];
  std::int16_t& pending = pending_start_[c];
  std::int16_t& gap = pending_gap_[c];  // rows since the last candidate (or the top)
  if (measured) {
    // (a) closes the column; (d) refuses the column's run resting on the surface.
    close(u, run != kNone ? run : (pending != kNone ? pending : v));
    return;
  }
  if (candidate) {
    if (run == kNone) {
      // A run that resumes within the gap is the same run (a thin line of texture
      // across it): it keeps the earlier start.
      run = pending != kNone ? pending : static_cast<std::int16_t>(v);
      pending = kNone;
    }
    gap = 0;
    // Below the horizon - margin its region is refused (c); nothing under it counts.
    if (side < 0) close(u, v);
    return;
  }
  if (run != kNone) {
    pending = run;
    run = kNone;
  }
  // (a) A band of texture (a roof, a tree crown, far ground) ends what may be sky
  // in this column: sky is what lies above everything else.
  if (++gap > config_.max_gap_px) close(u, v - config_.max_gap_px);
}

void SkyFilter::scan(const std::uint16_t* depth, const std::uint8_t* left,
                     const Eigen::Vector3f& up_camera) {
  const int w = width_;
  std::fill_n(run_start_.get(), w, kNone);
  std::fill_n(pending_start_.get(), w, kNone);
  std::fill_n(pending_gap_.get(), w, std::int16_t{0});
  std::fill_n(open_.get(), w, std::uint8_t{1});
  std::fill_n(limited_.get(), w, std::uint8_t{0});
  std::fill_n(limit_.get(), w, static_cast<std::int16_t>(height_));
  open_columns_ = w;
  row_first_[0] = 0;
  std::uint8_t* flags = rows_.get();
  std::int8_t* side = side_.get();
  int v = 0;
  for (; v < height_ && open_columns_ > 0; ++v) {
    candidate_row(left, v, flags);
    side_row(v, up_camera, side);
    const std::uint16_t* depth_row = depth + static_cast<std::size_t>(v) * w;
    if (!add_runs(v, depth_row, flags, side)) {
      // Out of run storage: nothing from this row down is taken for sky.
      for (int u = 0; u < w; ++u) {
        if (limited_[static_cast<std::size_t>(u)] == 0) close(u, v);
      }
      break;
    }
    // add_runs left each open column's candidates in live_.
    const std::uint8_t* live = live_.get();
    const std::uint8_t* open = open_.get();
    const std::uint8_t* limited = limited_.get();
    std::int16_t* gap = pending_gap_.get();
    for (int u = 0; u < w; ++u) {
      if (open[u] == 0) continue;
      const auto c = static_cast<std::size_t>(u);
      if (limited[u] == 0) {
        // The common case, a candidate continuing its column's run, on the spot.
        if (live[u] != 0 && run_start_[c] != kNone && side[u] >= 0) {
          gap[u] = 0;
          continue;
        }
        step_column(u, v, depth_row[u] != 0, live[u] != 0, side[u]);
      }
      // A column whose limit is known still joins its candidates into regions
      // down to the horizon - margin: a white facade cut by window rows reaches
      // its foot through the piers between them (c).
      if (limited[u] != 0 && side[u] < 0) stop_tracking(u);
    }
  }
  scanned_rows_ = v;
  // Every run's region at hand (parents precede children).
  const int runs = row_first_[static_cast<std::size_t>(v)];
  for (int r = 0; r < runs; ++r) {
    const auto k = static_cast<std::size_t>(r);
    parent_[k] = parent_[static_cast<std::size_t>(parent_[k])];
    area_[k] = 0;
  }
  // (e) counts what could be sky: a region's pixels above their columns' limits.
  for (int row = 0; row < v; ++row) {
    const auto next = static_cast<std::size_t>(row) + 1;
    for (int r = row_first_[next - 1]; r < row_first_[next]; ++r) {
      const auto k = static_cast<std::size_t>(r);
      int open_pixels = 0;
      for (int u = run_begin_[k]; u < run_end_[k]; ++u) {
        open_pixels += row < limit_[static_cast<std::size_t>(u)] ? 1 : 0;
      }
      area_[static_cast<std::size_t>(parent_[k])] += open_pixels;
    }
  }
  sky_rows_ = std::min<int>(scanned_rows_, *std::max_element(limit_.get(), limit_.get() + w));
}

void SkyFilter::sky_mask_row(int v, std::uint8_t* mask) const {
  std::fill_n(mask, width_, std::uint8_t{0});
  if (v >= sky_rows_) return;
  const auto row = static_cast<std::size_t>(v);
  for (int r = row_first_[row]; r < row_first_[row + 1]; ++r) {
    const auto region = static_cast<std::size_t>(parent_[static_cast<std::size_t>(r)]);
    // (b) above the horizon, (c) never below it, (e) not a small patch.
    if (region_[region] != kHigh || area_[region] < min_region_px_) continue;
    for (int u = run_begin_[static_cast<std::size_t>(r)]; u < run_end_[static_cast<std::size_t>(r)];
         ++u) {
      mask[u] = v < limit_[static_cast<std::size_t>(u)] ? 1 : 0;
    }
  }
}

}  // namespace zonemap
