#include "hal/output/height_png.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>

#include "hal/codec/png_io.hpp"

namespace zonemap::hal {
namespace {

constexpr std::int32_t kNoTop = HeightProfile::kNoTop;
constexpr std::array<std::uint8_t, 3> kBlack = {0, 0, 0};

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

// The part of the profile drawn (rectangle-relative columns, inclusive) and how
// it maps to pixels: a view from above. z-up worlds: +x right, +y up. NED: north
// (+x) up, east (+y) right.
struct MapView {
  std::int32_t c0x = 0, c0y = 0, c1x = 0, c1y = 0;
  std::int32_t min_x = 0, min_y = 0;
  bool z_up = true;
  double cell_size_m = 1.0;
  int cols = 1, rows = 1, scale = 1;
  static constexpr int kMargin = 40;
  static constexpr int kLegend = 120;

  void to_pixel(double wx, double wy, int* px, int* py) const {
    const double cx = wx / cell_size_m - min_x - c0x;
    const double cy = wy / cell_size_m - min_y - c0y;
    const double right = z_up ? cx : cy;
    const double up = z_up ? cy : cx;
    *px = kMargin + static_cast<int>(std::floor(right * scale));
    *py = kMargin + rows * scale - 1 - static_cast<int>(std::floor(up * scale));
  }
};

// Crops to the columns with a height and the flight, plus a margin.
MapView crop_to_content(const HeightProfile& profile, double cell_size_m,
                        const std::vector<Eigen::Vector3d>& trajectory) {
  const std::int32_t width = profile.width(), height = profile.height();
  MapView v;
  v.c0x = width;
  v.c0y = height;
  v.c1x = -1;
  v.c1y = -1;
  auto include = [&](std::int32_t cx, std::int32_t cy) {
    v.c0x = std::min(v.c0x, cx);
    v.c0y = std::min(v.c0y, cy);
    v.c1x = std::max(v.c1x, cx);
    v.c1y = std::max(v.c1y, cy);
  };
  for (int cy = 0; cy < height; ++cy)
    for (int cx = 0; cx < width; ++cx)
      if (profile.top_in_rectangle(cx, cy) != kNoTop) include(cx, cy);
  for (const Eigen::Vector3d& p : trajectory) {
    include(static_cast<std::int32_t>(std::floor(p.x() / cell_size_m)) - profile.min_x(),
            static_cast<std::int32_t>(std::floor(p.y() / cell_size_m)) - profile.min_y());
  }
  if (v.c1x < v.c0x) {
    v.c0x = v.c0y = 0;
    v.c1x = v.c1y = 0;
  }
  const std::int32_t pad = 5;
  v.c0x = std::max(0, v.c0x - pad);
  v.c0y = std::max(0, v.c0y - pad);
  v.c1x = std::min(width - 1, v.c1x + pad);
  v.c1y = std::min(height - 1, v.c1y + pad);
  const int crop_w = v.c1x - v.c0x + 1;
  const int crop_h = v.c1y - v.c0y + 1;
  v.min_x = profile.min_x();
  v.min_y = profile.min_y();
  v.z_up = profile.world_z_up();
  v.cell_size_m = cell_size_m;
  v.cols = v.z_up ? crop_w : crop_h;
  v.rows = v.z_up ? crop_h : crop_w;
  v.scale = std::clamp(900 / std::max(v.cols, v.rows), 1, 8);
  return v;
}

// Every column with a top, coloured by its height between lo and lo + span.
void draw_columns(Canvas& canvas, const MapView& v, const HeightProfile& profile, std::int32_t lo,
                  double span) {
  const int m = MapView::kMargin;
  canvas.fill(m - 1, m - 1, v.cols * v.scale + 2, v.rows * v.scale + 2, {160, 160, 160});
  canvas.fill(m, m, v.cols * v.scale, v.rows * v.scale, {255, 255, 255});
  for (int cy = v.c0y; cy <= v.c1y; ++cy) {
    for (int cx = v.c0x; cx <= v.c1x; ++cx) {
      const std::int32_t t = profile.top_in_rectangle(cx, cy);
      if (t == kNoTop) continue;
      const int right = v.z_up ? cx - v.c0x : cy - v.c0y;
      const int up = v.z_up ? cy - v.c0y : cx - v.c0x;
      canvas.fill(m + right * v.scale, m + (v.rows - 1 - up) * v.scale, v.scale, v.scale,
                  height_colour((t - lo) / span));
    }
  }
}

void draw_outlines(Canvas& canvas, const MapView& v, const std::vector<Eigen::Vector4d>& outlines) {
  for (const Eigen::Vector4d& box : outlines) {
    int x0, y0, x1, y1;
    v.to_pixel(box[0], box[1], &x0, &y0);
    v.to_pixel(box[2], box[3], &x1, &y1);
    canvas.line(x0, y0, x1, y0, kBlack, 1);
    canvas.line(x1, y0, x1, y1, kBlack, 1);
    canvas.line(x1, y1, x0, y1, kBlack, 1);
    canvas.line(x0, y1, x0, y0, kBlack, 1);
  }
}

void draw_trajectory(Canvas& canvas, const MapView& v,
                     const std::vector<Eigen::Vector3d>& trajectory) {
  for (std::size_t i = 0; i + 1 < trajectory.size(); ++i) {
    int x0, y0, x1, y1;
    v.to_pixel(trajectory[i].x(), trajectory[i].y(), &x0, &y0);
    v.to_pixel(trajectory[i + 1].x(), trajectory[i + 1].y(), &x1, &y1);
    canvas.line(x0, y0, x1, y1, kBlack, 2);
  }
  if (!trajectory.empty()) {
    int x, y;
    v.to_pixel(trajectory.front().x(), trajectory.front().y(), &x, &y);
    canvas.fill(x - 4, y - 4, 9, 9, kBlack);  // start of the flight
  }
}

// The colour bar (heights of the top cells' centres, metres; none without a top),
// a scale bar of a round length near a fifth of the map width, the axis names.
void draw_legend(Canvas& canvas, const MapView& v, bool any, std::int32_t lo, std::int32_t hi) {
  const int m = MapView::kMargin;
  const double cell = v.cell_size_m;
  const int bar_x = m + v.cols * v.scale + 30;
  const int bar_h = std::min(v.rows * v.scale, 300);
  for (int i = 0; i < bar_h; ++i) {
    canvas.fill(bar_x, m + i, 20, 1, height_colour(1.0 - static_cast<double>(i) / (bar_h - 1)));
  }
  if (any) {
    canvas.text(bar_x + 24, m, format_metres((hi + 0.5) * cell), 1);
    canvas.text(bar_x + 24, m + bar_h - 7, format_metres((lo + 0.5) * cell), 1);
  }
  canvas.text(bar_x, m - 14, "z", 1);
  const double map_m = v.cols * cell;
  double bar_m = 1.0;
  for (double c : {1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 500.0, 1000.0})
    if (c <= map_m / 5) bar_m = c;
  const int bar_px = static_cast<int>(bar_m / cell * v.scale);
  const int sy = m + v.rows * v.scale + 20;
  canvas.fill(m, sy, bar_px, 3, kBlack);
  canvas.text(m + bar_px + 6, sy - 2, format_metres(bar_m), 1);
  canvas.text(m + v.cols * v.scale - 6, sy - 2, v.z_up ? "x" : "E", 1);
  canvas.text(m - 14, m, v.z_up ? "y" : "N", 1);
}

}  // namespace

bool write_height_png(const std::string& path, const HeightProfile& profile, double cell_size_m,
                      const std::vector<Eigen::Vector3d>& trajectory,
                      const std::vector<Eigen::Vector4d>& outlines, std::string* error) {
  const MapView view = crop_to_content(profile, cell_size_m, trajectory);
  Canvas canvas(view.cols * view.scale + 2 * MapView::kMargin + MapView::kLegend,
                view.rows * view.scale + 2 * MapView::kMargin);
  std::int32_t lo = std::numeric_limits<std::int32_t>::max();
  std::int32_t hi = std::numeric_limits<std::int32_t>::min();
  for (std::int32_t t : profile.tops()) {
    if (t == kNoTop) continue;
    lo = std::min(lo, t);
    hi = std::max(hi, t);
  }
  const bool any = lo <= hi;
  draw_columns(canvas, view, profile, lo, any ? std::max(1, hi - lo) : 1);
  draw_outlines(canvas, view, outlines);
  draw_trajectory(canvas, view, trajectory);
  draw_legend(canvas, view, any, lo, hi);
  return write_png_rgb8(path, canvas.width, canvas.height, canvas.rgb.data(), error);
}

}  // namespace zonemap::hal
