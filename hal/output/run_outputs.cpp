#include "hal/output/run_outputs.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>

#include "hal/replay/png_io.hpp"

namespace zonemap::hal {
namespace {

constexpr std::int32_t kNoTop = std::numeric_limits<std::int32_t>::min();

// 5x7 bitmap glyphs for the picture's labels: one byte per row, low 5 bits, MSB left.
struct Glyph {
  char c;
  std::array<std::uint8_t, 7> rows;
};
constexpr Glyph kGlyphs[] = {
    {'0', {0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E}},
    {'1', {0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E}},
    {'2', {0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F}},
    {'3', {0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E}},
    {'4', {0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02}},
    {'5', {0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E}},
    {'6', {0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E}},
    {'7', {0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08}},
    {'8', {0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E}},
    {'9', {0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C}},
    {'.', {0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C}},
    {'-', {0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00}},
    {'m', {0x00, 0x00, 0x1A, 0x15, 0x15, 0x11, 0x11}},
    {'x', {0x00, 0x00, 0x11, 0x0A, 0x04, 0x0A, 0x11}},
    {'y', {0x00, 0x00, 0x11, 0x11, 0x0F, 0x01, 0x0E}},
    {'N', {0x11, 0x19, 0x15, 0x13, 0x11, 0x11, 0x11}},
    {'E', {0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F}},
    {'z', {0x00, 0x00, 0x1F, 0x02, 0x04, 0x08, 0x1F}},
    {' ', {0, 0, 0, 0, 0, 0, 0}},
};

struct Canvas {
  int width;
  int height;
  std::vector<std::uint8_t> rgb;
  Canvas(int w, int h) : width(w), height(h), rgb(static_cast<std::size_t>(w) * h * 3, 255) {}
  void set(int x, int y, std::array<std::uint8_t, 3> c) {
    if (x < 0 || y < 0 || x >= width || y >= height) return;
    std::copy(c.begin(), c.end(), rgb.begin() + (static_cast<std::size_t>(y) * width + x) * 3);
  }
  void fill(int x0, int y0, int w, int h, std::array<std::uint8_t, 3> c) {
    for (int y = y0; y < y0 + h; ++y)
      for (int x = x0; x < x0 + w; ++x) set(x, y, c);
  }
  void text(int x, int y, const std::string& s, int scale) {
    for (char ch : s) {
      for (const Glyph& g : kGlyphs) {
        if (g.c != ch) continue;
        for (int r = 0; r < 7; ++r)
          for (int col = 0; col < 5; ++col)
            if (g.rows[static_cast<std::size_t>(r)] & (0x10 >> col))
              fill(x + col * scale, y + r * scale, scale, scale, {0, 0, 0});
      }
      x += 6 * scale;
    }
  }
  void line(int x0, int y0, int x1, int y1, std::array<std::uint8_t, 3> c, int thickness) {
    const int steps = std::max({std::abs(x1 - x0), std::abs(y1 - y0), 1});
    for (int i = 0; i <= steps; ++i) {
      const int x = x0 + (x1 - x0) * i / steps;
      const int y = y0 + (y1 - y0) * i / steps;
      fill(x - thickness / 2, y - thickness / 2, thickness, thickness, c);
    }
  }
};

// A perceptually ordered blue -> green -> yellow -> red ramp for heights.
std::array<std::uint8_t, 3> height_colour(double f) {
  f = std::clamp(f, 0.0, 1.0);
  static constexpr std::array<std::array<double, 3>, 5> stops = {
      {{48, 18, 160}, {30, 140, 220}, {60, 200, 90}, {240, 210, 40}, {200, 30, 20}}};
  const double pos = f * (stops.size() - 1);
  const std::size_t i = std::min(static_cast<std::size_t>(pos), stops.size() - 2);
  const double t = pos - static_cast<double>(i);
  std::array<std::uint8_t, 3> out{};
  for (std::size_t k = 0; k < 3; ++k)
    out[k] = static_cast<std::uint8_t>(stops[i][k] + t * (stops[i + 1][k] - stops[i][k]));
  return out;
}

std::string format_metres(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), std::fabs(v) < 10.0 ? "%.1fm" : "%.0fm", v);
  return buf;
}

}  // namespace

double percentile(std::vector<double> values, double fraction) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const double rank = std::ceil(fraction * static_cast<double>(values.size()));
  const std::size_t index =
      static_cast<std::size_t>(std::clamp(rank, 1.0, static_cast<double>(values.size()))) - 1;
  return values[index];
}

bool write_stats_json(const std::string& path, const RunStats& s, std::string* error) {
  std::ofstream out(path);
  if (!out) {
    *error = path + ": cannot create";
    return false;
  }
  char ms[160];
  std::snprintf(ms, sizeof(ms), "{\"p50\": %.3f, \"p99\": %.3f, \"max\": %.3f}", s.frame_ms_p50,
                s.frame_ms_p99, s.frame_ms_max);
  out << "{\n"
      << "  \"frames_in\": " << s.frames_in << ",\n"
      << "  \"frames_mapped\": " << s.frames_mapped << ",\n"
      << "  \"frames_skipped_no_pose\": " << s.frames_skipped_no_pose << ",\n"
      << "  \"frames_rejected\": " << s.frames_rejected << ",\n"
      << "  \"frame_ms\": " << ms << ",\n"
      << "  \"heap_allocations_after_init\": " << s.heap_allocations_after_init << ",\n"
      << "  \"static_memory_bytes\": " << s.static_memory_bytes << ",\n"
      << "  \"zones_allocated\": " << s.zones_allocated << ",\n"
      << "  \"features\": " << s.features << ",\n"
      << "  \"cell_size_m\": " << s.cell_size_m << ",\n"
      << "  \"heap_frees_after_init\": " << s.heap_frees_after_init << ",\n"
      << "  \"zones_discarded\": " << s.zones_discarded << ",\n"
      << "  \"frames_rejected_bad_pose\": " << s.frames_rejected_bad_pose << ",\n"
      << "  \"frames_rejected_bad_image\": " << s.frames_rejected_bad_image << ",\n"
      << "  \"frames_rejected_time_order\": " << s.frames_rejected_time_order << ",\n"
      << "  \"poses_rejected\": " << s.poses_rejected << ",\n"
      << "  \"left_images_rejected\": " << s.left_images_rejected << ",\n"
      << "  \"cells_visited\": " << s.cells_visited << ",\n"
      << "  \"rays_hit\": " << s.rays_hit << ",\n"
      << "  \"rays_free\": " << s.rays_free << ",\n"
      << "  \"pixels_sky\": " << s.pixels_sky << ",\n"
      << "  \"pixels_missing\": " << s.pixels_missing << ",\n"
      << "  \"pixels_too_near\": " << s.pixels_too_near << ",\n"
      << "  \"frames_ground_below_environment\": " << s.frames_ground_below_environment << ",\n"
      << "  \"occupied_cells_final\": " << s.occupied_cells_final << ",\n"
      << "  \"height_profile_columns_outside\": " << s.height_profile_columns_outside << ",\n"
      << "  \"obstacle_boxes\": " << s.obstacle_boxes << ",\n"
      << "  \"ground_boxes\": " << s.ground_boxes << ",\n"
      << "  \"feature_counters\": {\"extractions\": " << s.feature_counters.extractions
      << ", \"added\": " << s.feature_counters.features_added
      << ", \"updated\": " << s.feature_counters.features_updated
      << ", \"removed\": " << s.feature_counters.features_removed
      << ", \"evicted\": " << s.feature_counters.features_evicted
      << ", \"dropped\": " << s.feature_counters.features_dropped
      << ", \"objects_too_small\": " << s.feature_counters.objects_too_small
      << ", \"objects_split\": " << s.feature_counters.objects_split
      << ", \"shapes_truncated\": " << s.feature_counters.shapes_truncated
      << ", \"cells_reintegrated\": " << s.feature_counters.cells_reintegrated << "},\n"
      << "  \"extract_ms\": {\"p50\": " << s.extract_ms_p50 << ", \"max\": " << s.extract_ms_max
      << "},\n"
      << "  \"pipeline\": " << (s.pipeline ? "true" : "false") << ",\n"
      << "  \"drops\": {\"mapper_behind\": " << s.dropped_mapper_behind
      << ", \"pool_full\": " << s.dropped_pool_full
      << ", \"outputs_skipped\": " << s.outputs_skipped << "},\n"
      << "  \"pose_waits\": " << s.pose_waits << ",\n"
      << "  \"outputs_published\": " << s.outputs_published << ",\n"
      << "  \"deadline_misses\": " << s.deadline_misses << ",\n"
      << "  \"end_to_end_ms\": {\"p50\": " << s.end_to_end_ms_p50
      << ", \"p99\": " << s.end_to_end_ms_p99 << ", \"p99.9\": " << s.end_to_end_ms_p999
      << ", \"max\": " << s.end_to_end_ms_max << "},\n"
      << "  \"queue_ms_p99\": " << s.queue_ms_p99 << ",\n"
      << "  \"rss_bytes\": {\"after_start\": " << s.rss_after_start
      << ", \"at_end\": " << s.rss_at_end << "},\n"
      << "  \"memory_bytes\": {\"zone_pool\": " << s.zone_pool_bytes
      << ", \"local_grid\": " << s.local_grid_bytes << ", \"feature_map\": " << s.feature_map_bytes
      << ", \"depth_table\": " << s.depth_table_bytes << ", \"pipeline\": " << s.pipeline_bytes
      << "}";
  // Counters by name, as one object each (only when there are any).
  auto named = [&out](const char* key, const std::vector<std::pair<std::string, std::int64_t>>& v) {
    if (v.empty()) return;
    out << ",\n  \"" << key << "\": {";
    for (std::size_t i = 0; i < v.size(); ++i) {
      out << (i == 0 ? "" : ", ") << "\"" << v[i].first << "\": " << v[i].second;
    }
    out << "}";
  };
  named("rejections", s.rejections);
  named("links", s.links);  // the daemon's vehicle-link counters
  named("recording", s.recording);
  named("stereo", s.stereo);
  out << "\n}\n";
  out.close();
  if (!out) {
    *error = path + ": write failed";
    return false;
  }
  return true;
}

bool write_boxes_csv(const std::string& path, const ObstacleBox* boxes, std::size_t count,
                     std::string* error) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) {
    *error = path + ": cannot create";
    return false;
  }
  std::fprintf(f, "id,kind,xmin,ymin,zmin,xmax,ymax,zmax,cells,last_seen_s\n");
  for (std::size_t i = 0; i < count; ++i) {
    const ObstacleBox& b = boxes[i];
    std::fprintf(f, "%u,%s,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%d,%.3f\n", b.id,
                 b.kind == FeatureKind::kObstacle ? "obstacle" : "ground", b.min.x(), b.min.y(),
                 b.min.z(), b.max.x(), b.max.y(), b.max.z(), b.cells, b.last_seen_s);
  }
  if (std::fclose(f) != 0) {
    *error = path + ": write failed";
    return false;
  }
  return true;
}

std::int64_t write_occupied_ply(const std::string& path, Mapper& mapper, std::string* error) {
  struct Point {
    float x, y, z;
    int value;
  };
  std::vector<Point> points;
  mapper.for_each_occupied_cell([&](const Eigen::Vector3d& c, FusedCell v) {
    points.push_back(
        {static_cast<float>(c.x()), static_cast<float>(c.y()), static_cast<float>(c.z()), v});
  });
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) {
    *error = path + ": cannot create";
    return -1;
  }
  std::fprintf(f,
               "ply\nformat ascii 1.0\ncomment zonemap occupied cells (world frame, metres); "
               "value = fused cell, %d per sensor-model unit\nelement vertex %zu\n"
               "property float x\nproperty float y\nproperty float z\nproperty int value\n"
               "end_header\n",
               kCellScale, points.size());
  for (const Point& p : points) std::fprintf(f, "%.4f %.4f %.4f %d\n", p.x, p.y, p.z, p.value);
  if (std::fclose(f) != 0) {
    *error = path + ": write failed";
    return -1;
  }
  return static_cast<std::int64_t>(points.size());
}

HeightProfile::HeightProfile(std::int32_t min_x, std::int32_t min_y, std::int32_t max_x,
                             std::int32_t max_y, FusedCell occupied_threshold, bool world_z_up)
    : min_x_(min_x),
      min_y_(min_y),
      width_(std::max(1, max_x - min_x + 1)),
      height_(std::max(1, max_y - min_y + 1)),
      threshold_(occupied_threshold),
      z_up_(world_z_up),
      tops_(static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_), kNoTop) {}

void HeightProfile::fold(const ZoneView& zone) {
  // It runs on the mapping thread when a zone leaves: plane by plane along
  // contiguous x rows (a column-by-column scan strides a whole plane per step,
  // 10-20 ms a zone). A column's top is the largest "up" coordinate of its
  // occupied cells, so the planes may come in any order.
  const auto clip = [](std::int32_t v, int n) { return static_cast<int>(std::clamp(v, 0, n)); };
  const int x0 = clip(min_x_ - zone.origin.x, zone.dims[0]);
  const int x1 = clip(min_x_ + width_ - zone.origin.x, zone.dims[0]);  // exclusive
  const int y0 = clip(min_y_ - zone.origin.y, zone.dims[1]);
  const int y1 = clip(min_y_ + height_ - zone.origin.y, zone.dims[1]);
  for (int z = 0; z < zone.dims[2]; ++z) {
    const std::int32_t world_z = zone.origin.z + z;
    const std::int32_t up = z_up_ ? world_z : -world_z;
    for (int y = y0; y < y1; ++y) {
      const FusedCell* row = zone.cells + zone.index(x0, y, z);
      std::int32_t* tops = tops_.data() +
                           static_cast<std::size_t>(zone.origin.y + y - min_y_) * width_ +
                           (zone.origin.x + x0 - min_x_);
      for (int x = 0; x < x1 - x0; ++x) {
        tops[x] = row[x] > threshold_ ? std::max(tops[x], up) : tops[x];
      }
    }
  }
  // Columns outside the picture (none while the rectangle covers the flight):
  // counted, once per zone column holding an occupied cell.
  if (x0 == 0 && x1 == zone.dims[0] && y0 == 0 && y1 == zone.dims[1]) return;
  for (int y = 0; y < zone.dims[1]; ++y) {
    for (int x = 0; x < zone.dims[0]; ++x) {
      if (x >= x0 && x < x1 && y >= y0 && y < y1) continue;
      for (int z = 0; z < zone.dims[2]; ++z) {
        if (zone.cells[zone.index(x, y, z)] > threshold_) {
          ++columns_outside_;
          break;
        }
      }
    }
  }
}

bool HeightProfile::top(std::int32_t x, std::int32_t y, std::int32_t* top_cell) const {
  const std::int32_t cx = x - min_x_;
  const std::int32_t cy = y - min_y_;
  if (cx < 0 || cy < 0 || cx >= width_ || cy >= height_) return false;
  const std::int32_t t = tops_[static_cast<std::size_t>(cy) * width_ + cx];
  if (t == kNoTop) return false;
  *top_cell = t;
  return true;
}

bool HeightProfile::write_png(const std::string& path, double cell_size_m,
                              const std::vector<Eigen::Vector3d>& trajectory,
                              const std::vector<Eigen::Vector4d>& outlines,
                              std::string* error) const {
  // Crop to the columns with a height and the flight, plus a margin.
  std::int32_t c0x = width_, c0y = height_, c1x = -1, c1y = -1;
  auto include = [&](std::int32_t cx, std::int32_t cy) {
    c0x = std::min(c0x, cx);
    c0y = std::min(c0y, cy);
    c1x = std::max(c1x, cx);
    c1y = std::max(c1y, cy);
  };
  for (int cy = 0; cy < height_; ++cy)
    for (int cx = 0; cx < width_; ++cx)
      if (tops_[static_cast<std::size_t>(cy) * width_ + cx] != kNoTop) include(cx, cy);
  for (const Eigen::Vector3d& p : trajectory) {
    include(static_cast<std::int32_t>(std::floor(p.x() / cell_size_m)) - min_x_,
            static_cast<std::int32_t>(std::floor(p.y() / cell_size_m)) - min_y_);
  }
  if (c1x < c0x) {
    c0x = c0y = 0;
    c1x = c1y = 0;
  }
  const std::int32_t pad = 5;
  c0x = std::max(0, c0x - pad);
  c0y = std::max(0, c0y - pad);
  c1x = std::min(width_ - 1, c1x + pad);
  c1y = std::min(height_ - 1, c1y + pad);
  const int crop_w = c1x - c0x + 1;
  const int crop_h = c1y - c0y + 1;

  // Map view from above. z-up worlds: +x right, +y up. NED: north (+x) up, east (+y) right.
  const int cols = z_up_ ? crop_w : crop_h;
  const int rows = z_up_ ? crop_h : crop_w;
  const int scale = std::clamp(900 / std::max(cols, rows), 1, 8);
  const int margin = 40;
  const int legend = 120;
  Canvas canvas(cols * scale + 2 * margin + legend, rows * scale + 2 * margin);
  auto to_pixel = [&](double wx, double wy, int* px, int* py) {
    const double cx = wx / cell_size_m - min_x_ - c0x;
    const double cy = wy / cell_size_m - min_y_ - c0y;
    const double right = z_up_ ? cx : cy;
    const double up = z_up_ ? cy : cx;
    *px = margin + static_cast<int>(std::floor(right * scale));
    *py = margin + rows * scale - 1 - static_cast<int>(std::floor(up * scale));
  };

  std::int32_t lo = std::numeric_limits<std::int32_t>::max();
  std::int32_t hi = std::numeric_limits<std::int32_t>::min();
  for (std::int32_t t : tops_) {
    if (t == kNoTop) continue;
    lo = std::min(lo, t);
    hi = std::max(hi, t);
  }
  const bool any = lo <= hi;
  const double span = any ? std::max(1, hi - lo) : 1;
  canvas.fill(margin - 1, margin - 1, cols * scale + 2, rows * scale + 2, {160, 160, 160});
  canvas.fill(margin, margin, cols * scale, rows * scale, {255, 255, 255});
  for (int cy = c0y; cy <= c1y; ++cy) {
    for (int cx = c0x; cx <= c1x; ++cx) {
      const std::int32_t t = tops_[static_cast<std::size_t>(cy) * width_ + cx];
      if (t == kNoTop) continue;
      const int right = z_up_ ? cx - c0x : cy - c0y;
      const int up = z_up_ ? cy - c0y : cx - c0x;
      canvas.fill(margin + right * scale, margin + (rows - 1 - up) * scale, scale, scale,
                  height_colour((t - lo) / span));
    }
  }
  for (const Eigen::Vector4d& box : outlines) {
    int x0, y0, x1, y1;
    to_pixel(box[0], box[1], &x0, &y0);
    to_pixel(box[2], box[3], &x1, &y1);
    canvas.line(x0, y0, x1, y0, {0, 0, 0}, 1);
    canvas.line(x1, y0, x1, y1, {0, 0, 0}, 1);
    canvas.line(x1, y1, x0, y1, {0, 0, 0}, 1);
    canvas.line(x0, y1, x0, y0, {0, 0, 0}, 1);
  }
  for (std::size_t i = 0; i + 1 < trajectory.size(); ++i) {
    int x0, y0, x1, y1;
    to_pixel(trajectory[i].x(), trajectory[i].y(), &x0, &y0);
    to_pixel(trajectory[i + 1].x(), trajectory[i + 1].y(), &x1, &y1);
    canvas.line(x0, y0, x1, y1, {0, 0, 0}, 2);
  }
  if (!trajectory.empty()) {
    int x, y;
    to_pixel(trajectory.front().x(), trajectory.front().y(), &x, &y);
    canvas.fill(x - 4, y - 4, 9, 9, {0, 0, 0});  // start of the flight
  }

  // Colour bar: heights of the top cells (cell centres), metres.
  const int bar_x = margin + cols * scale + 30;
  const int bar_h = std::min(rows * scale, 300);
  for (int i = 0; i < bar_h; ++i) {
    canvas.fill(bar_x, margin + i, 20, 1,
                height_colour(1.0 - static_cast<double>(i) / (bar_h - 1)));
  }
  if (any) {
    canvas.text(bar_x + 24, margin, format_metres((hi + 0.5) * cell_size_m), 1);
    canvas.text(bar_x + 24, margin + bar_h - 7, format_metres((lo + 0.5) * cell_size_m), 1);
  }
  canvas.text(bar_x, margin - 14, "z", 1);
  // Scale bar of a round length near a fifth of the map width.
  const double map_m = cols * cell_size_m;
  double bar_m = 1.0;
  for (double c : {1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 500.0, 1000.0})
    if (c <= map_m / 5) bar_m = c;
  const int bar_px = static_cast<int>(bar_m / cell_size_m * scale);
  const int sy = margin + rows * scale + 20;
  canvas.fill(margin, sy, bar_px, 3, {0, 0, 0});
  canvas.text(margin + bar_px + 6, sy - 2, format_metres(bar_m), 1);
  // Axis names: which world axis points right and which up.
  canvas.text(margin + cols * scale - 6, sy - 2, z_up_ ? "x" : "E", 1);
  canvas.text(margin - 14, margin, z_up_ ? "y" : "N", 1);
  return write_png_rgb8(path, canvas.width, canvas.height, canvas.rgb.data(), error);
}

}  // namespace zonemap::hal
