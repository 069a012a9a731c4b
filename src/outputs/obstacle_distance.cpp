#include "zonemap/outputs/obstacle_distance.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "zonemap/zones/zone_map.hpp"

namespace zonemap {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kStep = 2.0 * kPi / kObstacleSectors;

// Distance along the unit ray (0,0)+t*dir to the rectangle [lo, hi], +inf if missed.
double ray_entry(const Eigen::Vector2d& dir, const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) {
  double t_near = 0.0, t_far = kInf;
  for (int a = 0; a < 2; ++a) {
    if (std::abs(dir[a]) < 1e-12) {
      if (lo[a] > 0.0 || hi[a] < 0.0) return kInf;
      continue;
    }
    double t0 = lo[a] / dir[a], t1 = hi[a] / dir[a];
    if (t0 > t1) std::swap(t0, t1);
    t_near = std::max(t_near, t0);
    t_far = std::min(t_far, t1);
  }
  return t_near <= t_far ? t_near : kInf;
}

// Clockwise angle from forward to v in [0, 2 pi), v in (forward, right) terms.
double clockwise_angle(const Eigen::Vector2d& v) {
  double a = std::atan2(v.y(), v.x());
  if (a < 0.0) a += 2.0 * kPi;
  return a;
}

// The wedge holding a bearing (radians, clockwise from forward, any turn), of
// `step` radians each: wedge s covers [s - 1/2, s + 1/2) steps.
int wedge_of(double bearing, double step) {
  return static_cast<int>(std::floor(bearing / step + 0.5));
}
int wrap_wedge(int s, int wedges) {
  return ((s % wedges) + wedges) % wedges;
}

// Heights measured upwards whatever the world's convention.
double up_sign(bool world_z_up) {
  return world_z_up ? 1.0 : -1.0;
}

bool in_band(const ObstacleBox& box, double vehicle_height, bool world_z_up,
             const SectorConfig& config) {
  const double u = up_sign(world_z_up);
  const double h0 = std::min(u * box.min.z(), u * box.max.z());
  const double h1 = std::max(u * box.min.z(), u * box.max.z());
  return h1 >= vehicle_height - config.band_below_m && h0 <= vehicle_height + config.band_above_m;
}

// Calls fn(wedge, point, distance) for each of `wedges` equal wedges about the
// vehicle (wedge 0 centred straight ahead, numbered clockwise) that the world
// rectangle [lo, hi] (relative to the vehicle) reaches into within
// max_distance_m: its nearest point inside the wedge (world x-y, relative) and
// that point's distance. Returns false when the vehicle stands inside it.
template <typename Fn>
bool for_each_wedge(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi,
                    const HorizontalAxes& axes, int wedges, double max_distance_m, Fn&& fn) {
  const Eigen::Vector2d closest = lo.cwiseMax(Eigen::Vector2d::Zero()).cwiseMin(hi);
  const double closest_distance = closest.norm();
  if (closest_distance > max_distance_m) return true;
  if (closest_distance == 0.0) return false;
  const double step = 2.0 * kPi / wedges;
  const auto to_body = [&](const Eigen::Vector2d& w) {
    const Eigen::Vector3d w3(w.x(), w.y(), 0.0);
    return Eigen::Vector2d(w3.dot(axes.forward), w3.dot(axes.right));
  };
  const double closest_angle = clockwise_angle(to_body(closest));
  // The rectangle does not hold the vehicle, so it spans less than 180 degrees
  // about its closest point's bearing.
  double a_min = kInf, a_max = -kInf;
  for (const double x : {lo.x(), hi.x()}) {
    for (const double y : {lo.y(), hi.y()}) {
      double a = clockwise_angle(to_body({x, y})) - closest_angle;
      if (a > kPi) a -= 2.0 * kPi;
      if (a < -kPi) a += 2.0 * kPi;
      a_min = std::min(a_min, a);
      a_max = std::max(a_max, a);
    }
  }
  const int closest_wedge = wrap_wedge(wedge_of(closest_angle, step), wedges);
  const int s_first = wedge_of(closest_angle + a_min, step);
  const int s_last = wedge_of(closest_angle + a_max, step);
  for (int s_unwrapped = s_first; s_unwrapped <= s_last; ++s_unwrapped) {
    const int s = wrap_wedge(s_unwrapped, wedges);
    // Nearest point inside the wedge: the closest point if its bearing is inside,
    // else where one of the wedge's edges enters the rectangle.
    double d = kInf;
    Eigen::Vector2d point = closest;
    if (s == closest_wedge) d = closest_distance;
    for (const double edge : {(s_unwrapped - 0.5) * step, (s_unwrapped + 0.5) * step}) {
      const Eigen::Vector3d dir3 = axes.forward * std::cos(edge) + axes.right * std::sin(edge);
      const Eigen::Vector2d dir(dir3.x(), dir3.y());
      const double t = ray_entry(dir, lo, hi);
      if (t < d) {
        d = t;
        point = dir * t;
      }
    }
    if (d <= max_distance_m) fn(s, point, d);
  }
  return true;
}

// Calls fn(lo, hi) (world x-y) for each footprint rectangle of box b, or the box.
template <typename Fn>
void for_each_rectangle(const ObstacleBox* boxes, std::size_t b, const FootprintView& footprints,
                        Fn&& fn) {
  const std::uint32_t n = footprints.counts != nullptr ? footprints.counts[b] : 0;
  if (n == 0 || footprints.rects == nullptr || footprints.offsets == nullptr) {
    fn(Eigen::Vector2d(boxes[b].min.x(), boxes[b].min.y()),
       Eigen::Vector2d(boxes[b].max.x(), boxes[b].max.y()));
    return;
  }
  for (std::uint32_t r = 0; r < n; ++r) {
    const FootprintRect& rect = footprints.rects[footprints.offsets[b] + r];
    fn(Eigen::Vector2d(rect.x0, rect.y0), Eigen::Vector2d(rect.x1, rect.y1));
  }
}

}  // namespace

HorizontalAxes horizontal_axes(const Eigen::Isometry3d& world_T_body, bool world_z_up) {
  HorizontalAxes axes;
  axes.down = world_z_up ? Eigen::Vector3d(0, 0, -1) : Eigen::Vector3d(0, 0, 1);
  Eigen::Vector3d forward = world_T_body.linear().col(0);
  forward.z() = 0.0;
  if (forward.norm() < 1e-6) forward = -world_T_body.linear().col(2);  // nose straight down
  forward.z() = 0.0;
  axes.forward = forward.normalized();
  axes.right = axes.down.cross(axes.forward);
  return axes;
}

ObstacleDistances obstacle_distances(const ObstacleBox* boxes, std::size_t count,
                                     const FootprintView& footprints,
                                     const Eigen::Isometry3d& world_T_body, bool world_z_up,
                                     const SectorConfig& config, const SectorMask& observed) {
  ObstacleDistances out;
  out.min_distance_cm = static_cast<std::uint16_t>(std::lround(config.min_distance_m * 100.0));
  out.max_distance_cm = static_cast<std::uint16_t>(
      std::clamp(std::lround(config.max_distance_m * 100.0), 1L, 65533L));
  double nearest[kObstacleSectors];
  std::fill(std::begin(nearest), std::end(nearest), kInf);
  const HorizontalAxes axes = horizontal_axes(world_T_body, world_z_up);
  const Eigen::Vector3d position = world_T_body.translation();
  const double vehicle_height = up_sign(world_z_up) * position.z();
  bool inside = false;
  for (std::size_t b = 0; b < count && !inside; ++b) {
    if (boxes[b].kind != FeatureKind::kObstacle) continue;
    if (!in_band(boxes[b], vehicle_height, world_z_up, config)) continue;
    for_each_rectangle(
        boxes, b, footprints, [&](const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) {
          const Eigen::Vector2d p = position.head<2>();
          if (inside) return;
          inside = !for_each_wedge(lo - p, hi - p, axes, kObstacleSectors, config.max_distance_m,
                                   [&](int s, const Eigen::Vector2d&, double d) {
                                     nearest[s] = std::min(nearest[s], d);
                                   });
        });
  }
  if (inside) std::fill(std::begin(nearest), std::end(nearest), 0.0);  // everything is blocked
  for (int s = 0; s < kObstacleSectors; ++s) {
    if (nearest[s] <= config.max_distance_m) {
      const double cm = std::max(nearest[s], config.min_distance_m) * 100.0;
      out.distances_cm[s] = static_cast<std::uint16_t>(std::min(std::floor(cm), 65533.0));
      ++out.sectors_with_obstacle;
    } else if (observed[static_cast<std::size_t>(s)]) {
      out.distances_cm[s] = static_cast<std::uint16_t>(out.max_distance_cm + 1);
    } else {
      out.distances_cm[s] = kSectorUnknown;
      ++out.sectors_unknown;
    }
  }
  return out;
}

namespace {

// Where the update's sectors leave an obstacle possible, or the unknown: the
// edge of what they say is free (within max_distance of the update's position).
struct BoundarySegment {
  enum class Beyond : std::uint8_t { kObstacle, kUnknown, kOutOfRange };  // what may lie past it
  Eigen::Vector2d a, b;                                                   // world x-y
  Beyond beyond = Beyond::kObstacle;
};
constexpr int kMaxBoundarySegments = 3 * kObstacleSectors;  // an arc, two edge stretches
constexpr double kEdgeMargin = 1e-7;                        // radians

double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}

// The horizontal world direction (x-y) at `angle` clockwise from forward.
Eigen::Vector2d direction_at(const HorizontalAxes& axes, double angle) {
  const Eigen::Vector3d d = axes.forward * std::cos(angle) + axes.right * std::sin(angle);
  return {d.x(), d.y()};
}

// How far each sector is known free: its obstacle's distance, max_distance
// when seen free, 0 when unknown.
double free_reach(const ObstacleDistances& d, int s) {
  const std::uint16_t cm = d.distances_cm[s];
  if (cm == kSectorUnknown) return 0.0;
  if (cm > d.max_distance_cm) return d.max_distance_cm / 100.0;
  return cm / 100.0;
}

// The arcs (as chords) of sectors with an obstacle or seen free to
// max_distance, the stretches of wedge edges between two sectors' reaches,
// which belong to the nearer one's side, and past an obstacle's reach the
// stretch of its edge with an unknown wedge, out to max_distance.
int boundary_segments(const ObstacleDistances& d, const HorizontalAxes& axes,
                      const Eigen::Vector2d& origin, BoundarySegment* out) {
  using Beyond = BoundarySegment::Beyond;
  const auto beyond = [&](int s) {
    if (d.distances_cm[s] == kSectorUnknown) return Beyond::kUnknown;
    return d.distances_cm[s] > d.max_distance_cm ? Beyond::kOutOfRange : Beyond::kObstacle;
  };
  int n = 0;
  for (int s = 0; s < kObstacleSectors; ++s) {
    const double reach = free_reach(d, s);
    if (beyond(s) != Beyond::kUnknown) {
      out[n++] = {origin + reach * direction_at(axes, (s - 0.5) * kStep),
                  origin + reach * direction_at(axes, (s + 0.5) * kStep), beyond(s)};
    }
    const int next = (s + 1) % kObstacleSectors;
    const double next_reach = free_reach(d, next);
    if (next_reach == reach) continue;
    const Eigen::Vector2d edge = direction_at(axes, (s + 0.5) * kStep);
    const Beyond near_side = beyond(next_reach < reach ? next : s);
    out[n++] = {origin + std::min(reach, next_reach) * edge,
                origin + std::max(reach, next_reach) * edge, near_side};
    // Past an obstacle's arc beside an unknown wedge: from the unknown side the
    // edge leads into where the obstacle may be.
    if (near_side == Beyond::kUnknown &&
        beyond(next_reach < reach ? s : next) == Beyond::kObstacle) {
      out[n++] = {origin + std::max(reach, next_reach) * edge,
                  origin + d.max_distance_cm / 100.0 * edge, Beyond::kObstacle};
    }
  }
  return n;
}

// Whether `moved` (world x-y, from the update's position) lies in a wedge with
// an obstacle, at or past its distance: where the obstacle may stand.
bool past_an_obstacles_reach(const ObstacleDistances& d, const HorizontalAxes& axes,
                             const Eigen::Vector2d& moved) {
  const Eigen::Vector3d moved3(moved.x(), moved.y(), 0.0);
  const Eigen::Vector2d body(moved3.dot(axes.forward), moved3.dot(axes.right));
  const int s = wrap_wedge(wedge_of(clockwise_angle(body), kStep), kObstacleSectors);
  const std::uint16_t cm = d.distances_cm[s];
  return cm != kSectorUnknown && cm <= d.max_distance_cm && moved.norm() >= cm / 100.0;
}

// Distance from p to the nearest point of segment a-b inside the wedge between
// directions e1 and e2 (less than 180 degrees apart); +inf when none is.
double nearest_in_wedge(const Eigen::Vector2d& p, const Eigen::Vector2d& e1,
                        const Eigen::Vector2d& e2, const BoundarySegment& segment) {
  const Eigen::Vector2d u = segment.a - p, w = segment.b - segment.a;
  const double sense = cross2(e1, e2) >= 0.0 ? 1.0 : -1.0;
  double t0 = 0.0, t1 = 1.0;
  // Inside: sense * (c0 + t c1) >= 0 for both edges.
  const double c0[2] = {cross2(e1, u), cross2(u, e2)};
  const double c1[2] = {cross2(e1, w), cross2(w, e2)};
  for (int k = 0; k < 2; ++k) {
    const double a0 = sense * c0[k], a1 = sense * c1[k];
    if (std::abs(a1) < 1e-12) {
      if (a0 < 0.0) return kInf;
    } else if (a1 > 0.0) {
      t0 = std::max(t0, -a0 / a1);
    } else {
      t1 = std::min(t1, -a0 / a1);
    }
  }
  if (t0 > t1) return kInf;
  const double length_squared = w.squaredNorm();
  const double t = length_squared > 0.0 ? std::clamp(-u.dot(w) / length_squared, t0, t1) : t0;
  return (u + t * w).norm();
}

}  // namespace

ObstacleDistances moved_obstacle_distances(const ObstacleDistances& then_distances,
                                           const Eigen::Isometry3d& world_T_body_then,
                                           const Eigen::Isometry3d& world_T_body_now,
                                           bool world_z_up) {
  const HorizontalAxes then_axes = horizontal_axes(world_T_body_then, world_z_up);
  const HorizontalAxes now_axes = horizontal_axes(world_T_body_now, world_z_up);
  const Eigen::Vector2d origin = world_T_body_then.translation().head<2>();
  const Eigen::Vector2d position = world_T_body_now.translation().head<2>();
  if ((position - origin).norm() < 1e-3 && now_axes.forward.dot(then_axes.forward) > 1.0 - 1e-12) {
    return then_distances;
  }
  BoundarySegment segments[kMaxBoundarySegments];
  const int count = boundary_segments(then_distances, then_axes, origin, segments);
  ObstacleDistances out = then_distances;
  out.sectors_with_obstacle = 0;
  out.sectors_unknown = 0;
  const double min_m = then_distances.min_distance_cm / 100.0;
  const double max_m = then_distances.max_distance_cm / 100.0;
  if (past_an_obstacles_reach(then_distances, then_axes, position - origin)) {
    // Moved to where the update's obstacle may stand: blocked all round.
    std::fill(std::begin(out.distances_cm), std::end(out.distances_cm), out.min_distance_cm);
    out.sectors_with_obstacle = kObstacleSectors;
    return out;
  }
  for (int s = 0; s < kObstacleSectors; ++s) {
    // A hair inside the wedge's edges: an edge lying on one (a pure turn by whole
    // sectors) belongs to neither side rather than to the side rounding picks.
    const Eigen::Vector2d e1 = direction_at(now_axes, (s - 0.5) * kStep + kEdgeMargin);
    const Eigen::Vector2d e2 = direction_at(now_axes, (s + 0.5) * kStep - kEdgeMargin);
    double nearest[3] = {kInf, kInf, kInf};  // by what lies beyond
    for (int i = 0; i < count; ++i) {
      double& to = nearest[static_cast<int>(segments[i].beyond)];
      to = std::min(to, nearest_in_wedge(position, e1, e2, segments[i]));
    }
    const double obstacle = nearest[0], unknown = nearest[1], out_of_range = nearest[2];
    if (obstacle <= max_m) {
      out.distances_cm[s] = static_cast<std::uint16_t>(
          std::min(std::floor(std::max(obstacle, min_m) * 100.0), 65533.0));
      ++out.sectors_with_obstacle;
    } else if (unknown <= max_m || (unknown == kInf && out_of_range == kInf)) {
      // Part of the wedge was never seen, or all of it (the vehicle stands in it).
      out.distances_cm[s] = kSectorUnknown;
      ++out.sectors_unknown;
    } else {
      out.distances_cm[s] = static_cast<std::uint16_t>(then_distances.max_distance_cm + 1);
    }
  }
  return out;
}

SectorMask turned_sector_mask(const SectorMask& observed,
                              const Eigen::Isometry3d& world_T_body_then,
                              const Eigen::Isometry3d& world_T_body_now, bool world_z_up) {
  const HorizontalAxes then_axes = horizontal_axes(world_T_body_then, world_z_up);
  const HorizontalAxes now_axes = horizontal_axes(world_T_body_now, world_z_up);
  // Clockwise turn from then to now, in sectors.
  const double turned =
      std::atan2(now_axes.forward.dot(then_axes.right), now_axes.forward.dot(then_axes.forward)) /
      kStep;
  SectorMask out;
  for (int s = 0; s < kObstacleSectors; ++s) {
    // Sector s now covers [s - 1/2, s + 1/2) + turned of then's sectors.
    const int first = static_cast<int>(std::floor(s + turned + 1e-9));
    const int last = static_cast<int>(std::floor(s + turned + 1.0 - 1e-9));
    bool seen = true;
    for (int k = first; k <= last; ++k) seen = seen && observed[wrap_wedge(k, kObstacleSectors)];
    out[static_cast<std::size_t>(s)] = seen;
  }
  return out;
}

namespace {

// Heights sampled at each step, from the vehicle's down to the band's bottom.
constexpr int kSeenHeights = 5;
constexpr double kUnseenTailShare = 0.2;

// One line of a sector's wedge, from min_distance out to max_distance a cell a
// step: seen (true) when at least four steps lie inside the zones holding a grid,
// at least half of those have a seen cell (fused value != 0) at one of `heights`
// above the vehicle, and no run of unseen steps longer than max_unseen_gap_m lies
// between seen ones.
bool line_seen(const ZoneMap& zones, double cell_size_m, const Eigen::Vector3d& position,
               const Eigen::Vector3d& dir, const Eigen::Vector3d& up,
               const double (&heights)[kSeenHeights], const SectorConfig& config) {
  const int steps =
      static_cast<int>(std::ceil((config.max_distance_m - config.min_distance_m) / cell_size_m));
  const int longest_gap = static_cast<int>(std::floor(config.max_unseen_gap_m / cell_size_m));
  const auto cell_of = [cell_size_m](const Eigen::Vector3d& p) {
    return CellIndex{static_cast<std::int32_t>(std::floor(p.x() / cell_size_m)),
                     static_cast<std::int32_t>(std::floor(p.y() / cell_size_m)),
                     static_cast<std::int32_t>(std::floor(p.z() / cell_size_m))};
  };
  int inside = 0, seen = 0, gap = 0;
  bool hole = false;
  for (int k = 0; k <= steps && !hole; ++k) {
    const Eigen::Vector3d along = position + dir * (config.min_distance_m + k * cell_size_m);
    bool any_inside = false, any_seen = false;
    for (const double h : heights) {
      FusedCell v = 0;
      if (zones.value_at(cell_of(along + up * h), &v)) {
        any_inside = true;
        any_seen = any_seen || v != 0;
      }
    }
    inside += any_inside ? 1 : 0;
    seen += any_seen ? 1 : 0;
    // An unseen stretch between seen cells is what a surface no view matched
    // leaves (a white wall and its shadow): not known free across it.
    hole = any_seen && gap > longest_gap;
    if (any_inside) gap = any_seen ? 0 : (seen > 0 ? gap + 1 : 0);
  }
  // The stretch past the last seen step counts too, but for the last
  // kUnseenTailShare of max_distance (far ground that fused to zero, the zone's
  // edge): a sector reading free has been seen out to 80% of max_distance.
  const int longest_tail = std::max(
      longest_gap,
      static_cast<int>(std::floor(kUnseenTailShare * config.max_distance_m / cell_size_m)));
  if (hole || gap > longest_tail) return false;
  return inside >= 4 && 2 * seen >= inside;
}

}  // namespace

SectorMask observed_sectors(const ZoneMap& zones, double cell_size_m,
                            const Eigen::Isometry3d& world_T_body, bool world_z_up,
                            const SectorConfig& config) {
  SectorMask observed{};
  const HorizontalAxes axes = horizontal_axes(world_T_body, world_z_up);
  const Eigen::Vector3d position = world_T_body.translation();
  const Eigen::Vector3d up = -axes.down;
  // From the vehicle's height down to the band's bottom: a cell seen there shows
  // whether something standing on the ground reaches into the band (rays to the
  // ground cross the cells just above it). The band's top does not: it is seen
  // free over a wall nothing has measured.
  double heights[kSeenHeights];
  for (int i = 0; i < kSeenHeights; ++i) {
    heights[i] = -config.band_below_m * i / (kSeenHeights - 1);
  }
  // The wedge's centre line and two lines near its edges: a wall's corner inside
  // the wedge but off its centre keeps the sector from reading free.
  constexpr double kLines[3] = {-0.4, 0.0, 0.4};
  for (int s = 0; s < kObstacleSectors; ++s) {
    bool seen = true;
    for (const double offset : kLines) {
      const double bearing = (s + offset) * kStep;
      const Eigen::Vector3d dir = axes.forward * std::cos(bearing) + axes.right * std::sin(bearing);
      seen = seen && line_seen(zones, cell_size_m, position, dir, up, heights, config);
    }
    observed[static_cast<std::size_t>(s)] = seen;
  }
  return observed;
}

namespace {

// Keeps `o` in out[0 .. *n) (nearest first, at most capacity): the farthest
// entry that is not protected gives way. False when o was not kept.
bool keep_nearest(const NearestObstacle& o, NearestObstacle* out, std::size_t* n,
                  std::size_t capacity) {
  if (*n < capacity) {
    out[(*n)++] = o;
  } else if (*n > 0 && o.distance_m < out[*n - 1].distance_m) {
    out[*n - 1] = o;
  } else {
    return false;
  }
  for (std::size_t i = *n - 1; i > 0 && out[i - 1].distance_m > out[i].distance_m; --i) {
    std::swap(out[i - 1], out[i]);
  }
  return true;
}

// One box's nearest point in each wedge (horizontal distance, point relative
// to the vehicle; kInf where it reaches no wedge). When the vehicle stands over
// or under it (or in it): straight up or down, else blocked all round at the
// nearest distance an autopilot takes; *inside says so.
struct WedgeNearest {
  double horizontal[kMaxObstacleWedges];
  Eigen::Vector2d point[kMaxObstacleWedges];
  bool inside = false;
};
WedgeNearest box_in_wedges(const ObstacleBox* boxes, std::size_t b, const FootprintView& footprints,
                           const HorizontalAxes& axes, const Eigen::Vector3d& position, double z,
                           const SectorConfig& config, int wedges) {
  WedgeNearest near;
  std::fill_n(near.horizontal, wedges, kInf);
  for_each_rectangle(
      boxes, b, footprints, [&](const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) {
        const Eigen::Vector2d p = position.head<2>();
        near.inside = !for_each_wedge(lo - p, hi - p, axes, wedges, config.max_distance_m,
                                      [&](int w, const Eigen::Vector2d& q, double d) {
                                        if (d < near.horizontal[w]) {
                                          near.horizontal[w] = d;
                                          near.point[w] = q;
                                        }
                                      }) ||
                      near.inside;
      });
  if (!near.inside) return near;
  std::fill_n(near.horizontal, wedges, kInf);
  const double dz = std::abs(z - position.z());
  if (dz >= config.min_distance_m) {
    near.horizontal[0] = 0.0;
    near.point[0] = Eigen::Vector2d::Zero();
    return near;
  }
  for (int w = 0; w < wedges; ++w) {
    const double bearing = w * 2.0 * kPi / wedges;
    const Eigen::Vector3d dir = axes.forward * std::cos(bearing) + axes.right * std::sin(bearing);
    near.horizontal[w] = config.min_distance_m;
    near.point[w] = Eigen::Vector2d(dir.x(), dir.y()) * config.min_distance_m;
  }
  return near;
}

// A wedge whose nearest point gave way to nearer ones elsewhere takes the
// place of the farthest point that is not a wedge's nearest.
void keep_each_wedges_nearest(const NearestObstacle* wedge_nearest, int wedges,
                              NearestObstacle* out, std::size_t n) {
  for (int w = 0; w < wedges; ++w) {
    const NearestObstacle& o = wedge_nearest[w];
    if (o.wedge < 0) continue;
    const auto same = [&](const NearestObstacle& x) { return x.id == o.id && x.wedge == o.wedge; };
    if (std::any_of(out, out + n, same)) continue;
    for (std::size_t i = n; i-- > 0;) {
      const NearestObstacle& x = out[i];
      if (wedge_nearest[x.wedge].id == x.id && wedge_nearest[x.wedge].wedge == x.wedge) continue;
      out[i] = o;
      std::sort(out, out + n, [](const NearestObstacle& l, const NearestObstacle& r) {
        return l.distance_m < r.distance_m;
      });
      break;
    }
  }
}

}  // namespace

std::size_t nearest_obstacles(const ObstacleBox* boxes, std::size_t count,
                              const FootprintView& footprints,
                              const Eigen::Isometry3d& world_T_body, bool world_z_up,
                              const SectorConfig& config, NearestObstacle* out,
                              std::size_t capacity, int wedges) {
  wedges = std::clamp(wedges, 1, kMaxObstacleWedges);
  const HorizontalAxes axes = horizontal_axes(world_T_body, world_z_up);
  const Eigen::Isometry3d body_T_world = world_T_body.inverse();
  const Eigen::Vector3d position = world_T_body.translation();
  const double vehicle_height = up_sign(world_z_up) * position.z();
  // Each wedge's nearest point overall: kept whatever the capacity (up to one a
  // wedge), so that no direction with an obstacle reads empty.
  NearestObstacle wedge_nearest[kMaxObstacleWedges];
  std::size_t n = 0;
  for (std::size_t b = 0; b < count && capacity > 0; ++b) {
    const ObstacleBox& box = boxes[b];
    if (box.kind != FeatureKind::kObstacle || !in_band(box, vehicle_height, world_z_up, config)) {
      continue;
    }
    // Heights: the box's nearest to the vehicle's.
    const double z = std::clamp(position.z(), box.min.z(), box.max.z());
    const WedgeNearest near =
        box_in_wedges(boxes, b, footprints, axes, position, z, config, wedges);
    for (int w = 0; w < wedges; ++w) {
      if (near.horizontal[w] == kInf) continue;
      const Eigen::Vector3d q(position.x() + near.point[w].x(), position.y() + near.point[w].y(),
                              near.inside && near.horizontal[w] > 0.0 ? position.z() : z);
      const double d = (q - position).norm();
      if (d > config.max_distance_m) continue;
      NearestObstacle o;
      o.id = box.id;
      o.wedge = w;
      o.distance_m = d;
      o.body_frd = body_T_world * q;
      if (wedge_nearest[w].wedge < 0 || d < wedge_nearest[w].distance_m) wedge_nearest[w] = o;
      keep_nearest(o, out, &n, capacity);
    }
  }
  keep_each_wedges_nearest(wedge_nearest, wedges, out, n);
  return n;
}

}  // namespace zonemap
