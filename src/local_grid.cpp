#include "zonemap/local_grid.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace zonemap {
namespace {

constexpr int kMaxBlurRadius = 2;

LocalCell quantize(float units) {
  return static_cast<LocalCell>(std::clamp(to_fixed(units), -kCellScale, kCellScale));
}

// Divides by 2^shift, rounding half away from zero, so that blur(-x) == -blur(x).
int symmetric_shift(int value, int shift) {
  const int half = 1 << (shift - 1);
  return value >= 0 ? (value + half) >> shift : -((-value + half) >> shift);
}

}  // namespace

LocalGrid::LocalGrid(const std::array<int, 3>& dims)
    : dims_(dims),
      cell_count_(static_cast<std::size_t>(dims[0]) * static_cast<std::size_t>(dims[1]) *
                  static_cast<std::size_t>(dims[2])),
      cells_(new LocalCell[cell_count_]),
      line_(new std::int16_t[static_cast<std::size_t>(std::max({dims[0], dims[1], dims[2]}) +
                                                      2 * kMaxBlurRadius)]) {
  reset(CellIndex{});
}

std::size_t LocalGrid::reserved_bytes() const {
  return cell_count_ * sizeof(LocalCell) +
         static_cast<std::size_t>(std::max({dims_[0], dims_[1], dims_[2]}) + 2 * kMaxBlurRadius) *
             sizeof(std::int16_t);
}

void LocalGrid::reset(const CellIndex& origin) {
  origin_ = origin;
  std::fill_n(cells_.get(), cell_count_, kUntouched);
}

int LocalGrid::draw_ray(const Eigen::Vector3f& start, const Eigen::Vector3f& direction,
                        const RayProfile& ray) {
  // Clip [delta_begin, delta_end] to the grid box (slab method).
  float t0 = ray.delta_begin;
  float t1 = ray.delta_end;
  for (int a = 0; a < 3; ++a) {
    const float extent = static_cast<float>(dims_[a]);
    if (std::fabs(direction[a]) < 1e-12f) {
      if (start[a] < 0.0f || start[a] >= extent) return 0;
      continue;
    }
    float ta = (0.0f - start[a]) / direction[a];
    float tb = (extent - start[a]) / direction[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  if (!(t0 < t1)) return 0;

  // Amanatides & Woo traversal: visit every cell the segment crosses, in order,
  // with the δ interval [t, t_exit] the ray spends inside it.
  int cell[3];
  int step[3];
  float t_next[3];
  float t_delta[3];
  const float inf = std::numeric_limits<float>::infinity();
  for (int a = 0; a < 3; ++a) {
    const float p = start[a] + t0 * direction[a];
    cell[a] = std::clamp(static_cast<int>(std::floor(p)), 0, dims_[a] - 1);
    if (direction[a] > 0.0f) {
      step[a] = 1;
      t_delta[a] = 1.0f / direction[a];
      t_next[a] = (static_cast<float>(cell[a] + 1) - start[a]) / direction[a];
    } else if (direction[a] < 0.0f) {
      step[a] = -1;
      t_delta[a] = -1.0f / direction[a];
      t_next[a] = (static_cast<float>(cell[a]) - start[a]) / direction[a];
    } else {
      step[a] = 0;
      t_delta[a] = inf;
      t_next[a] = inf;
    }
  }

  const int max_steps = dims_[0] + dims_[1] + dims_[2] + 3;
  float t = t0;
  int visited = 0;
  while (visited < max_steps) {
    int axis = 0;
    if (t_next[1] < t_next[axis]) axis = 1;
    if (t_next[2] < t_next[axis]) axis = 2;
    const float t_exit = std::min(std::max(t_next[axis], t), t1);
    write_max(cell[0], cell[1], cell[2], quantize(max_value_in_interval(ray, t, t_exit)));
    ++visited;
    if (t_exit >= t1) break;
    t = t_exit;
    cell[axis] += step[axis];
    if (cell[axis] < 0 || cell[axis] >= dims_[axis]) break;
    t_next[axis] += t_delta[axis];
  }
  return visited;
}

void LocalGrid::finish(int blur_radius) {
  LocalCell* cells = cells_.get();
  for (std::size_t i = 0; i < cell_count_; ++i) {
    if (cells[i] == kUntouched) cells[i] = 0;
  }
  if (blur_radius <= 0) return;
  const int radius = std::min(blur_radius, kMaxBlurRadius);
  for (int axis = 0; axis < 3; ++axis) blur_axis(axis, radius);
}

void LocalGrid::blur_axis(int axis, int radius) {
  const int n = dims_[axis];
  const std::size_t stride =
      axis == 0   ? 1
      : axis == 1 ? static_cast<std::size_t>(dims_[0])
                  : static_cast<std::size_t>(dims_[0]) * static_cast<std::size_t>(dims_[1]);
  // The two axes other than `axis` enumerate the lines.
  const int other_a = axis == 0 ? 1 : 0;
  const int other_b = axis == 2 ? 1 : 2;
  std::int16_t* line = line_.get();
  LocalCell* cells = cells_.get();
  for (int b = 0; b < dims_[other_b]; ++b) {
    for (int a = 0; a < dims_[other_a]; ++a) {
      int coord[3] = {0, 0, 0};
      coord[other_a] = a;
      coord[other_b] = b;
      LocalCell* first = cells + index(coord[0], coord[1], coord[2]);
      for (int i = 0; i < radius; ++i) {
        line[i] = 0;
        line[radius + n + i] = 0;
      }
      for (int i = 0; i < n; ++i) line[radius + i] = first[static_cast<std::size_t>(i) * stride];
      for (int i = 0; i < n; ++i) {
        const std::int16_t* w = line + i;  // window [i, i + 2 * radius]
        const int sum =
            radius == 1 ? w[0] + 2 * w[1] + w[2] : w[0] + 4 * w[1] + 6 * w[2] + 4 * w[3] + w[4];
        first[static_cast<std::size_t>(i) * stride] =
            static_cast<LocalCell>(symmetric_shift(sum, 2 * radius));
      }
    }
  }
}

}  // namespace zonemap
