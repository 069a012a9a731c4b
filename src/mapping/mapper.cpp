#include "zonemap/mapping/mapper.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>

#include "common/simd_u16.hpp"

namespace zonemap {

namespace {

struct RowCounts {
  std::uint16_t missing = 0, near = 0, far = 0;
};

// Raw depths to range-table codes: missing (0) and too near (raw <= near_last)
// to kMissing, beyond d_max (raw > far_last) to kFar; the row's counts on the
// way. Eight pixels at a time (the counts in per-lane 16-bit counters, at most
// width / 8 each), the rest one by one.
RowCounts convert_row(const std::uint16_t* __restrict raw_row, std::uint16_t* __restrict out,
                      int width, std::uint16_t near_last, std::uint16_t far_last) {
  using simd::U16x8;
  const auto convert = [&](auto raw, auto one, auto max_code, auto near_v, auto far_v,
                           auto missing_code, auto far_code) {
    // raw - 1 wraps a missing 0 to 0xFFFF: never near.
    const auto raw_minus_one = static_cast<decltype(raw)>(raw - one);
    const auto is_ignored = (raw_minus_one == missing_code) | (raw_minus_one < near_v);
    const auto code = raw < max_code ? raw : max_code;
    return is_ignored ? missing_code : (raw > far_v ? far_code : code);
  };
  U16x8 missing_lanes{}, far_lanes{}, ignored_lanes{};
  int u = 0;
  for (; u + 8 <= width; u += 8) {
    const U16x8 raw = simd::load_u16(raw_row + u);
    const U16x8 code =
        convert(raw, simd::splat_u16(1), simd::splat_u16(DepthRangeTable::kMaxDepthCode),
                simd::splat_u16(near_last), simd::splat_u16(far_last),
                simd::splat_u16(DepthRangeTable::kMissing), simd::splat_u16(DepthRangeTable::kFar));
    std::memcpy(out + u, &code, sizeof code);
    // Comparisons give all-ones (0xFFFF) lanes: subtracting them counts.
    missing_lanes -= reinterpret_cast<U16x8>(raw == U16x8{});
    far_lanes -= reinterpret_cast<U16x8>(code == simd::splat_u16(DepthRangeTable::kFar));
    ignored_lanes -= reinterpret_cast<U16x8>(code == simd::splat_u16(DepthRangeTable::kMissing));
  }
  int missing = 0, far = 0, ignored = 0;
  for (int i = 0; i < 8; ++i) {
    missing += missing_lanes[i];
    far += far_lanes[i];
    ignored += ignored_lanes[i];
  }
  for (; u < width; ++u) {
    const std::uint16_t raw = raw_row[u];
    const std::uint16_t code =
        convert(raw, std::uint16_t{1}, DepthRangeTable::kMaxDepthCode, near_last, far_last,
                DepthRangeTable::kMissing, DepthRangeTable::kFar);
    out[u] = code;
    missing += raw == 0 ? 1 : 0;
    far += code == DepthRangeTable::kFar ? 1 : 0;
    ignored += code == DepthRangeTable::kMissing ? 1 : 0;
  }
  RowCounts counts;
  counts.missing = static_cast<std::uint16_t>(missing);
  counts.near = static_cast<std::uint16_t>(ignored - missing);
  counts.far = static_cast<std::uint16_t>(far);
  return counts;
}

struct SkyCounts {
  std::uint16_t sky = 0, refused = 0;
};

// Missing pixels flagged bright and flat (candidates) become kFar (free up to
// d_max) where SkyFilter's mask says sky; the others stay missing (refused).
SkyCounts mark_sky(const std::uint16_t* __restrict raw_row, const std::uint8_t* __restrict flags,
                   const std::uint8_t* __restrict sky_mask, std::uint16_t* __restrict out,
                   int width) {
  static_assert(DepthRangeTable::kFar == DepthRangeTable::kMissing - 1);
  int candidates = 0, sky = 0;
  for (int u = 0; u < width; ++u) {
    const int candidate = (raw_row[u] == 0 ? 1 : 0) & flags[u];
    const int is_sky = candidate & sky_mask[u];
    candidates += candidate;
    sky += is_sky;
    // A missing pixel's code is kMissing: minus one makes it kFar.
    out[u] = static_cast<std::uint16_t>(out[u] - is_sky);
  }
  return {static_cast<std::uint16_t>(sky), static_cast<std::uint16_t>(candidates - sky)};
}

// Missing pixels flagged bright and flat, in a row where nothing is sky.
std::uint16_t count_candidates(const std::uint16_t* __restrict raw_row,
                               const std::uint8_t* __restrict flags, int width) {
  int candidates = 0;
  for (int u = 0; u < width; ++u) candidates += (raw_row[u] == 0 ? 1 : 0) & flags[u];
  return static_cast<std::uint16_t>(candidates);
}

// The first raw depth whose float depth (raw * depth_to_m, as the reference path
// computes it) reaches `limit` (>= when inclusive, > otherwise); 0x10000 when
// none in 16 bits does.
std::uint32_t first_raw_reaching(float limit, float depth_to_m, bool inclusive) {
  const float estimate = std::clamp(limit / depth_to_m, 0.0f, 65536.0f);
  std::uint32_t r = static_cast<std::uint32_t>(estimate);
  r = r > 2 ? r - 2 : 0;
  while (r <= 0xFFFF && (inclusive ? static_cast<float>(r) * depth_to_m < limit
                                   : static_cast<float>(r) * depth_to_m <= limit)) {
    ++r;
  }
  return r;
}

}  // namespace

bool is_valid_pose(const Eigen::Isometry3d& pose) {
  if (!pose.matrix().allFinite()) return false;
  const Eigen::Matrix3d r = pose.linear();
  const double orthonormal_error = (r.transpose() * r - Eigen::Matrix3d::Identity()).norm();
  return orthonormal_error < 1e-3 && r.determinant() > 0.0;
}

Mapper::Mapper(const MapConfig& config, const CameraModel& camera)
    : config_(config),
      camera_(camera),
      local_(config.zone_cells),
      zones_(config),
      filter_(camera.width, camera.height, config.depth_filter_radius_px,
              static_cast<float>(camera.match_sigma_px /
                                 (camera.baseline_m * camera.fx * camera.depth_scale))),
      depths_(config.integration == MapConfig::Integration::kProjective ? camera.width : 1,
              config.integration == MapConfig::Integration::kProjective ? camera.height : 1),
      projective_(config, camera),
      occupied_threshold_(
          static_cast<FusedCell>(to_fixed(static_cast<float>(config.occupied_threshold_units)))),
      free_threshold_(
          static_cast<FusedCell>(to_fixed(static_cast<float>(config.free_threshold_units)))),
      sky_(config.sky, camera),
      sky_flags_(new std::uint8_t[kMaxDepthParts * 3 *
                                  static_cast<std::size_t>(std::max(camera.width, 1))]()) {
  if (config.see_through > 0.0 && config.integration == MapConfig::Integration::kReference) {
    local_.enable_see_through(
        static_cast<LocalCell>(to_fixed(static_cast<float>(config.see_through))),
        static_cast<LocalCell>(to_fixed(static_cast<float>(config.near_peak_behind()))));
  }
  if (config.blur_keep_near_m > 0.0) {
    local_.enable_near_keep(
        static_cast<int>(std::ceil(config.blur_keep_near_m / config.cell_size_m - 1e-9)));
  }
  part_filters_.reserve(kMaxDepthParts - 1);
  for (int p = 1; p < kMaxDepthParts; ++p) {
    part_filters_.emplace_back(
        camera.width, camera.height, config.depth_filter_radius_px,
        static_cast<float>(camera.match_sigma_px /
                           (camera.baseline_m * camera.fx * camera.depth_scale)));
  }
  // d_min <= d <= d_max as raw codes, fixed for the run: the last raw values
  // that are too near / not yet beyond d_max (16 bits; a limit past the code
  // range never applies).
  const auto depth_to_m = static_cast<float>(1.0 / camera.depth_scale);
  const std::uint32_t raw_near =
      first_raw_reaching(static_cast<float>(config.d_min_m), depth_to_m, true);
  const std::uint32_t raw_far =
      first_raw_reaching(static_cast<float>(config.d_max_m), depth_to_m, false);
  raw_near_last_ = static_cast<std::uint16_t>(raw_near > 0 ? raw_near - 1 : 0);
  raw_far_last_ = static_cast<std::uint16_t>(std::min<std::uint32_t>(raw_far - 1, 0xFFFF));
  // Eq. (1): Δd = δ² σ / (b f) reaches full_weight_resolution_cells cells here.
  const double resolution_factor = camera.match_sigma_px / (camera.baseline_m * camera.fx);
  full_weight_depth_m_ =
      static_cast<float>(std::sqrt(config.full_weight_resolution_cells * config.cell_size_m /
                                   std::max(resolution_factor, 1e-12)));
}

CellIndex Mapper::cell_of(const Eigen::Vector3d& point) const {
  const Eigen::Vector3d c = point / config_.cell_size_m;
  return CellIndex{static_cast<std::int32_t>(std::floor(c.x())),
                   static_cast<std::int32_t>(std::floor(c.y())),
                   static_cast<std::int32_t>(std::floor(c.z()))};
}

Eigen::Vector3d Mapper::cell_center(const CellIndex& cell) const {
  return Eigen::Vector3d(cell.x + 0.5, cell.y + 0.5, cell.z + 0.5) * config_.cell_size_m;
}

FrameReport Mapper::integrate(const DepthFrameView& frame,
                              const Eigen::Isometry3d& world_T_camera) {
  FrameReport report;
  if (frame.depth == nullptr || frame.width != camera_.width || frame.height != camera_.height) {
    report.status = FrameStatus::kBadFrame;
    return report;
  }
  if (!is_valid_pose(world_T_camera)) {
    report.status = FrameStatus::kBadPose;
    return report;
  }

  // The environment cube follows the camera (centred, or reaching below it).
  const CellIndex camera_cell = cell_of(world_T_camera.translation());
  const CellIndex origin = zones_.environment_origin(camera_cell, camera_.world_z_up);
  report.zones_allocated = zones_.move_environment(origin, split_);
  local_.reset(origin);
  filter_.begin(frame.depth);
  if (config_.sky.enabled && frame.left != nullptr) {
    const Eigen::Vector3d up_world(0.0, 0.0, camera_.world_z_up ? 1.0 : -1.0);
    sky_.scan(frame.depth, frame.left,
              (world_T_camera.linear().transpose() * up_world).cast<float>());
  }
  sample_hits_below(frame, world_T_camera, origin, &report);

  // Ray geometry in grid units relative to the local grid's minimum corner.
  // Subtract in double first so that large world coordinates keep their precision.
  const double inv_cell = 1.0 / config_.cell_size_m;
  const Eigen::Vector3d origin_m =
      Eigen::Vector3d(origin.x, origin.y, origin.z) * config_.cell_size_m;
  const Eigen::Vector3f start =
      ((world_T_camera.translation() - origin_m) * inv_cell).cast<float>();
  if (config_.integration == MapConfig::Integration::kProjective) {
    integrate_projective(frame, world_T_camera, &report);
  } else {
    integrate_reference(frame, start, (world_T_camera.linear() * inv_cell).cast<float>(), &report);
  }
  finish_and_fuse(start, world_T_camera);
  return report;
}

void Mapper::integrate_projective(const DepthFrameView& frame,
                                  const Eigen::Isometry3d& world_T_camera, FrameReport* report) {
  classify_depths(frame, report);
  depths_.build(split_);
  const ProjectiveStats drawn = projective_.draw(depths_, world_T_camera, local_, split_);
  report->cells_visited = drawn.cells_evaluated;
  report->cells_block_free = drawn.cells_block_free;
  report->cells_box_free = drawn.cells_box_free;
  report->cells_hidden = drawn.cells_hidden;
  report->cells_exact = drawn.cells_exact;
  report->rays_exact = drawn.rays_exact;
}

void Mapper::classify_depths(const DepthFrameView& frame, FrameReport* report) {
  // Level 0 of the range table: each pixel's depth code, kFar for free-only
  // rays, or missing. pixel_step is a reference-path option: every pixel is used.
  // Bands of rows, one per part (each band's filter reads the r rows before it):
  // the codes and the integer sums are the same for any number of parts.
  const int parts = split_ == nullptr ? 1 : std::min(split_->parts(), kMaxDepthParts);
  for_each_part(split_, parts, [&](int part, int all) {
    const int h = frame.height;
    const int first = h * part / all, end = h * (part + 1) / all;
    DepthFilter& filter = part == 0 ? filter_ : part_filters_[static_cast<std::size_t>(part - 1)];
    std::uint8_t* sky = sky_flags_.get() +
                        static_cast<std::size_t>(part) * 3 * static_cast<std::size_t>(frame.width);
    filter.begin(frame.depth, first);
    part_counts_[static_cast<std::size_t>(part)] = classify_rows(frame, first, end, filter, sky);
  });
  DepthCounts all;
  for (int p = 0; p < parts; ++p) {
    const DepthCounts& c = part_counts_[static_cast<std::size_t>(p)];
    all.hit += c.hit;
    all.near += c.near;
    all.far += c.far;
    all.missing += c.missing;
    all.sky += c.sky;
    all.sky_refused += c.sky_refused;
  }
  report->rays_hit += all.hit;
  report->rays_free += all.far;
  report->pixels_too_near += all.near;
  report->pixels_missing += all.missing;
  report->pixels_sky += all.sky;
  report->pixels_sky_refused += all.sky_refused;
}

Mapper::DepthCounts Mapper::classify_rows(const DepthFrameView& frame, int first, int end,
                                          DepthFilter& filter, std::uint8_t* sky_flags) {
  const bool sky_filter = config_.sky.enabled && frame.left != nullptr;
  std::uint16_t* base = depths_.base();
  const std::uint16_t near_last = raw_near_last_, far_last = raw_far_last_;
  DepthCounts counts;
  for (int v = first; v < end; ++v) {
    const std::uint16_t* depth_row = filter.row(v);
    std::uint16_t* out = base + static_cast<std::size_t>(v) * frame.width;
    const RowCounts row = convert_row(depth_row, out, frame.width, near_last, far_last);
    counts.near += row.near;
    counts.far += row.far;
    counts.hit += frame.width - row.missing - row.near - row.far;
    counts.missing += row.missing;
    // Missing pixels of a bright, textureless patch are sky where SkyFilter's
    // scan left their column open: free up to d_max.
    if (row.missing > 0 && sky_filter) {
      sky_.candidate_row(frame.left, v, sky_flags);
      SkyCounts row_sky;
      if (v < sky_.sky_rows()) {
        std::uint8_t* sky_mask = sky_flags + frame.width;  // candidate_row's scratch, free now
        sky_.sky_mask_row(v, sky_mask);
        row_sky = mark_sky(depth_row, sky_flags, sky_mask, out, frame.width);
      } else {
        row_sky.refused = count_candidates(depth_row, sky_flags, frame.width);
      }
      counts.sky += row_sky.sky;
      counts.sky_refused += row_sky.refused;
      counts.missing -= row_sky.sky;
      counts.far += row_sky.sky;
    }
  }
  return counts;
}

void Mapper::integrate_reference(const DepthFrameView& frame, const Eigen::Vector3f& start,
                                 const Eigen::Matrix3f& rotation_cells, FrameReport* report) {
  const float d_min = static_cast<float>(config_.d_min_m);
  const float d_max = static_cast<float>(config_.d_max_m);
  const float depth_to_m = static_cast<float>(1.0 / camera_.depth_scale);
  const float resolution_factor =
      static_cast<float>(camera_.match_sigma_px / (camera_.baseline_m * camera_.fx));
  const float inv_fx = static_cast<float>(1.0 / camera_.fx);
  const float inv_fy = static_cast<float>(1.0 / camera_.fy);
  const float cx = static_cast<float>(camera_.cx);
  const float cy = static_cast<float>(camera_.cy);
  const bool sky_filter = config_.sky.enabled && frame.left != nullptr;
  const int step = config_.pixel_step;
  for (int v = 0; v < frame.height; v += step) {
    const std::uint16_t* depth_row = filter_.row(v);
    bool sky_known = false;
    for (int u = 0; u < frame.width; u += step) {
      RayProfile ray;
      ray.delta_begin = d_min;
      const std::uint16_t raw = depth_row[u];
      if (raw == 0) {
        if (sky_filter && !sky_known) {
          sky_.candidate_row(frame.left, v, sky_flags_.get());
          sky_.sky_mask_row(v, sky_flags_.get() + frame.width);
          sky_known = true;
        }
        const bool candidate = sky_filter && sky_flags_[static_cast<std::size_t>(u)] != 0;
        if (candidate && sky_flags_[static_cast<std::size_t>(frame.width + u)] != 0) {
          ++report->pixels_sky;
          ray.free_only = true;
        } else {
          report->pixels_sky_refused += candidate ? 1 : 0;
          ++report->pixels_missing;
          continue;
        }
      } else {
        const float d = static_cast<float>(raw) * depth_to_m;
        if (d < d_min) {
          ++report->pixels_too_near;
          continue;
        }
        ray.free_only = d > d_max;
        ray.depth = d;
        ray.range_resolution = std::max(d * d * resolution_factor, 1e-6f);  // eq. (1)
      }
      if (ray.free_only) {
        ray.delta_end = d_max;
        ++report->rays_free;
      } else {
        ray.delta_end = std::min(ray.depth + ray.range_resolution, d_max);
        ++report->rays_hit;
      }
      // Pinhole ray: the point at depth-plane distance δ is δ * (x, y, 1).
      const Eigen::Vector3f pixel_ray((static_cast<float>(u) - cx) * inv_fx,
                                      (static_cast<float>(v) - cy) * inv_fy, 1.0f);
      report->cells_visited += local_.draw_ray(start, rotation_cells * pixel_ray, ray);
    }
  }
}

void Mapper::sample_hits_below(const DepthFrameView& frame, const Eigen::Isometry3d& world_T_camera,
                               const CellIndex& origin, FrameReport* report) const {
  const double cell = config_.cell_size_m;
  // z up: the bottom face is the environment's lowest z; NED: its highest. A
  // measurement counts as under it one cell past it (stereo noise straddles a
  // ground that lies just on the face).
  const double bottom_m =
      camera_.world_z_up ? (origin.z - 1) * cell : (origin.z + config_.zone_cells[2] + 1) * cell;
  const double to_m = 1.0 / camera_.depth_scale;
  for (int v = kBelowSampleStep / 2; v < frame.height; v += kBelowSampleStep) {
    for (int u = kBelowSampleStep / 2; u < frame.width; u += kBelowSampleStep) {
      const double d = frame.depth[static_cast<std::size_t>(v) * frame.width + u] * to_m;
      if (d < config_.d_min_m || d > config_.d_max_m) continue;  // (0: no measurement)
      const Eigen::Vector3d end =
          world_T_camera *
          Eigen::Vector3d((u - camera_.cx) / camera_.fx * d, (v - camera_.cy) / camera_.fy * d, d);
      ++report->sampled_hits;
      const bool below = camera_.world_z_up ? end.z() < bottom_m : end.z() > bottom_m;
      report->sampled_hits_below_environment += below ? 1 : 0;
    }
  }
}

void Mapper::finish_and_fuse(const Eigen::Vector3f& camera_cells,
                             const Eigen::Isometry3d& world_T_camera) {
  const Eigen::Vector3f axis_per_cell =
      (world_T_camera.linear().col(2) * config_.cell_size_m).cast<float>();
  const LocalGrid::NearKeep near{camera_cells, axis_per_cell,
                                 static_cast<float>(config_.blur_keep_near_m)};
  local_.finish(config_.blur_radius, split_, config_.blur_keep_near_m > 0.0 ? &near : nullptr);
  if (config_.fusion == MapConfig::Fusion::kRangeWeighted) {
    local_.weight_occupancy_by_range(camera_cells, axis_per_cell, full_weight_depth_m_,
                                     static_cast<float>(config_.min_weight));
  }
  zones_.fuse(local_, split_);
}

}  // namespace zonemap
