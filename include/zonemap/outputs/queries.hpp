// Queries for a planner against the map: the feature map everywhere, and the
// fused grid where a zone holds one (their union: the conservative answer).
// Bounded in time (segment length and feature capacity), allocation-free.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>

#include <Eigen/Core>

#include "zonemap/features/feature_map.hpp"
#include "zonemap/zones/zone_map.hpp"

namespace zonemap {

struct RayHit {
  bool hit = false;
  double distance_m = 0.0;  // along the ray to where it enters the first occupied cell
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  CellIndex cell;
  std::uint32_t feature_id = 0;  // 0 when the grid answered
  bool from_grid = false;
};

class MapQueries {
 public:
  // max_cells bounds the cells one query may walk (longer queries answer "blocked").
  MapQueries(const FeatureMap& features, const ZoneMap& zones, double cell_size_m,
             FusedCell occupied_threshold, int max_cells = 100000);

  // True when no occupied cell (grid or feature shape, obstacle or ground) meets
  // the segment from a to b.
  bool is_free(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const;

  // The first occupied cell along origin + t * direction (direction need not be
  // unit; t in metres of |direction|), 0 <= t <= max_range_m.
  RayHit first_hit(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                   double max_range_m) const;

  // Ids of obstacle features whose shape has a cell inside the box [lo, hi]
  // (metres). Writes at most `capacity`; returns how many there are in all.
  std::size_t obstacles_in(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, std::uint32_t* ids,
                           std::size_t capacity) const;

 private:
  RayHit walk(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double length) const;
  std::size_t gather_candidates(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                                double length) const;

  const FeatureMap& features_;
  const ZoneMap& zones_;
  double cell_size_m_;
  FusedCell threshold_;
  int max_cells_;
  std::unique_ptr<const Feature*[]> candidates_;  // features whose box meets the query
};

}  // namespace zonemap
