#include "zonemap/outputs/queries.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace zonemap {
namespace {

// Slab test of the segment origin + t * direction, t in [0, length], against a box.
bool segment_meets_box(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double length,
                       const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  double t0 = 0.0;
  double t1 = length;
  for (int a = 0; a < 3; ++a) {
    if (std::fabs(d[a]) < 1e-15) {
      if (o[a] < lo[a] || o[a] > hi[a]) return false;
      continue;
    }
    double ta = (lo[a] - o[a]) / d[a];
    double tb = (hi[a] - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
}

}  // namespace

MapQueries::MapQueries(const FeatureMap& features, const ZoneMap& zones, double cell_size_m,
                       FusedCell occupied_threshold, int max_cells)
    : features_(features),
      zones_(zones),
      cell_size_m_(cell_size_m),
      threshold_(occupied_threshold),
      max_cells_(max_cells),
      candidates_(new const Feature*[features.capacity()]) {}

std::size_t MapQueries::gather_candidates(const Eigen::Vector3d& origin,
                                          const Eigen::Vector3d& direction, double length) const {
  std::size_t n = 0;
  for (const Feature* f = features_.begin(); f != features_.end(); ++f) {
    if (!f->in_use) continue;
    const Eigen::Vector3d lo = Eigen::Vector3d(f->min.x, f->min.y, f->min.z) * cell_size_m_;
    const Eigen::Vector3d hi =
        Eigen::Vector3d(f->max.x + 1, f->max.y + 1, f->max.z + 1) * cell_size_m_;
    if (segment_meets_box(origin, direction, length, lo, hi)) candidates_[n++] = f;
  }
  return n;
}

RayHit MapQueries::walk(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                        double length) const {
  RayHit result;
  const std::size_t candidates = gather_candidates(origin, direction, length);
  // Exact voxel traversal in world cells (grid units), t in the ray's parameter.
  const Eigen::Vector3d o = origin / cell_size_m_;
  const Eigen::Vector3d d = direction / cell_size_m_;
  CellIndex cell{static_cast<std::int32_t>(std::floor(o.x())),
                 static_cast<std::int32_t>(std::floor(o.y())),
                 static_cast<std::int32_t>(std::floor(o.z()))};
  std::int32_t* c[3] = {&cell.x, &cell.y, &cell.z};
  int step[3];
  double t_next[3];
  double t_delta[3];
  const double inf = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (d[a] > 0.0) {
      step[a] = 1;
      t_delta[a] = 1.0 / d[a];
      t_next[a] = (*c[a] + 1 - o[a]) / d[a];
    } else if (d[a] < 0.0) {
      step[a] = -1;
      t_delta[a] = -1.0 / d[a];
      t_next[a] = (*c[a] - o[a]) / d[a];
    } else {
      step[a] = 0;
      t_delta[a] = inf;
      t_next[a] = inf;
    }
  }
  double t = 0.0;
  for (int visited = 0; visited < max_cells_; ++visited) {
    FusedCell v = 0;
    bool occupied = false;
    if (zones_.value_at(cell, &v) && v > threshold_) {
      occupied = true;
      result.from_grid = true;
    }
    for (std::size_t i = 0; i < candidates && !occupied; ++i) {
      if (features_.feature_contains(*candidates_[i], cell)) {
        occupied = true;
        result.feature_id = candidates_[i]->id;
      }
    }
    if (occupied) {
      result.hit = true;
      result.distance_m = t * direction.norm();
      result.point = origin + t * direction;
      result.cell = cell;
      return result;
    }
    int axis = 0;
    if (t_next[1] < t_next[axis]) axis = 1;
    if (t_next[2] < t_next[axis]) axis = 2;
    if (t_next[axis] > length) return result;  // the segment ends in this cell
    t = t_next[axis];
    *c[axis] += step[axis];
    t_next[axis] += t_delta[axis];
  }
  // Too long to walk within the bound: say blocked rather than free.
  result.hit = true;
  result.distance_m = t * direction.norm();
  result.point = origin + t * direction;
  return result;
}

bool MapQueries::is_free(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const {
  return !walk(a, b - a, 1.0).hit;
}

RayHit MapQueries::first_hit(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                             double max_range_m) const {
  const double norm = direction.norm();
  if (!(norm > 0.0) || !std::isfinite(norm) || !(max_range_m >= 0.0)) return RayHit{};
  return walk(origin, direction / norm, max_range_m);
}

std::size_t MapQueries::obstacles_in(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                                     std::uint32_t* ids, std::size_t capacity) const {
  const CellIndex qlo{static_cast<std::int32_t>(std::floor(lo.x() / cell_size_m_)),
                      static_cast<std::int32_t>(std::floor(lo.y() / cell_size_m_)),
                      static_cast<std::int32_t>(std::floor(lo.z() / cell_size_m_))};
  const CellIndex qhi{static_cast<std::int32_t>(std::ceil(hi.x() / cell_size_m_)) - 1,
                      static_cast<std::int32_t>(std::ceil(hi.y() / cell_size_m_)) - 1,
                      static_cast<std::int32_t>(std::ceil(hi.z() / cell_size_m_)) - 1};
  std::size_t n = 0;
  for (const Feature* f = features_.begin(); f != features_.end(); ++f) {
    if (!f->in_use || f->kind != FeatureKind::kObstacle) continue;
    const int x0 = std::max(f->min.x, qlo.x), x1 = std::min(f->max.x, qhi.x);
    const int y0 = std::max(f->min.y, qlo.y), y1 = std::min(f->max.y, qhi.y);
    const int z0 = std::max(f->min.z, qlo.z), z1 = std::min(f->max.z, qhi.z);
    if (x0 > x1 || y0 > y1 || z0 > z1) continue;
    // The shape is a prism: one z suffices; scan the footprint inside the query.
    bool inside = false;
    for (int y = y0; y <= y1 && !inside; ++y)
      for (int x = x0; x <= x1 && !inside; ++x) inside = features_.feature_contains(*f, {x, y, z0});
    if (!inside) continue;
    if (n < capacity) ids[n] = f->id;
    ++n;
  }
  return n;
}

}  // namespace zonemap
