#include "zonemap/features/feature_map.hpp"

// The feature map's output: features of one object cut by zone faces merged
// into boxes, with their footprints.
#include <algorithm>
#include <array>
#include <cmath>

#include "common/simd_u16.hpp"
#include "features/feature_map_detail.hpp"

namespace zonemap {

std::size_t FeatureMap::merged(ObstacleBox* out, std::size_t capacity, bool include_ground,
                               FootprintOutput* footprints) {
  if (footprints != nullptr) {
    footprints->used = 0;
    footprints->boxes_without_footprint = 0;
  }
  group_touching_features();
  std::size_t n = 0;
  // Roots first write their group; obstacles before ground.
  for (const FeatureKind kind : {FeatureKind::kObstacle, FeatureKind::kGround}) {
    if (kind == FeatureKind::kGround && !include_ground) break;
    for (std::size_t i = 0; i < capacity_ && n < capacity; ++i) {
      const Feature& root = features_[i];
      if (!root.in_use || root.kind != kind ||
          find_root(parent_.get(), static_cast<std::uint32_t>(i)) != i) {
        continue;
      }
      out[n] = box_of_group(i, footprints, n);
      ++n;
    }
  }
  return n;
}

// parent_: features of one object cut by zone faces touch across the face. In
// one zone, obstacles whose x-y boxes mostly overlap are the faces of one object
// seen from opposite sides (a hut flown out and back), apart once the halo
// between them is trimmed.
void FeatureMap::group_touching_features() {
  const int gap = config_.merge_gap_cells;
  for (std::size_t i = 0; i < capacity_; ++i) parent_[i] = static_cast<std::uint32_t>(i);
  for (std::size_t i = 0; i < capacity_; ++i) {
    const Feature& a = features_[i];
    if (!a.in_use) continue;
    for (std::size_t j = i + 1; j < capacity_; ++j) {
      const Feature& b = features_[j];
      if (!b.in_use || b.kind != a.kind) continue;
      const bool one_object = a.kind == FeatureKind::kObstacle && mostly_overlap_xy(a, b);
      if (b.zone == a.zone && !one_object) continue;
      // Parts of one object one above the other (the halo trim can take a weaker
      // middle for the halo of a stronger end: a post in two boxes) join across
      // the trim's reach in z as well.
      const int gap_z = b.zone == a.zone ? gap + kTrimReachZ : gap;
      if (a.min.x > b.max.x + gap || b.min.x > a.max.x + gap || a.min.y > b.max.y + gap ||
          b.min.y > a.max.y + gap || a.min.z > b.max.z + gap_z || b.min.z > a.max.z + gap_z) {
        continue;
      }
      const std::uint32_t ra = find_root(parent_.get(), static_cast<std::uint32_t>(i));
      const std::uint32_t rb = find_root(parent_.get(), static_cast<std::uint32_t>(j));
      if (ra != rb) parent_[std::max(ra, rb)] = std::min(ra, rb);
    }
  }
}

// The box of the group whose root is feature `root_index`, the n-th box out,
// with its footprint appended when there is room.
ObstacleBox FeatureMap::box_of_group(std::size_t root_index, FootprintOutput* footprints,
                                     std::size_t n) {
  const Feature& root = features_[root_index];
  ObstacleBox box;
  box.kind = root.kind;
  box.id = root.id;
  box.first_seen_s = root.first_seen_s;
  box.last_seen_s = root.last_seen_s;
  box.prior = true;
  CellIndex lo = root.min;
  CellIndex hi = root.max;
  const std::size_t first_rect = footprints != nullptr ? footprints->used : 0;
  bool footprint_fits = true;
  for (std::size_t j = root_index; j < capacity_; ++j) {
    const Feature& f = features_[j];
    if (!f.in_use || find_root(parent_.get(), static_cast<std::uint32_t>(j)) != root_index) {
      continue;
    }
    if (footprints != nullptr && footprint_fits) footprint_fits = append_footprint(f, footprints);
    lo = {std::min(lo.x, f.min.x), std::min(lo.y, f.min.y), std::min(lo.z, f.min.z)};
    hi = {std::max(hi.x, f.max.x), std::max(hi.y, f.max.y), std::max(hi.z, f.max.z)};
    box.id = std::min(box.id, f.id);
    box.first_seen_s = std::min(box.first_seen_s, f.first_seen_s);
    box.last_seen_s = std::max(box.last_seen_s, f.last_seen_s);
    box.cells += f.cells;
    box.prior &= f.prior;
    ++box.parts;
  }
  box.min = Eigen::Vector3d(lo.x, lo.y, lo.z) * cell_size_m_;
  box.max = Eigen::Vector3d(hi.x + 1, hi.y + 1, hi.z + 1) * cell_size_m_;
  if (footprints != nullptr) {
    footprints->offsets[n] = static_cast<std::uint32_t>(first_rect);
    footprints->counts[n] =
        footprint_fits ? static_cast<std::uint32_t>(footprints->used - first_rect) : 0;
    if (!footprint_fits) {
      footprints->used = first_rect;  // the space goes to the next box
      ++footprints->boxes_without_footprint;
    }
  }
  return box;
}

bool FeatureMap::append_footprint(const Feature& f, FootprintOutput* out) const {
  const auto rect = [&](int x0, int y0, int x1, int y1) {  // cells [x0, x1) x [y0, y1)
    out->rects[out->used++] = {
        static_cast<float>(x0 * cell_size_m_), static_cast<float>(y0 * cell_size_m_),
        static_cast<float>(x1 * cell_size_m_), static_cast<float>(y1 * cell_size_m_)};
  };
  if (!f.has_shape) {
    if (out->used >= out->capacity) return false;
    rect(f.min.x, f.min.y, f.max.x + 1, f.max.y + 1);
    return true;
  }
  bool fits = true;
  shapes_.for_each_full_square(f.shape, f.shape_side, [&](int sx, int sy, int size) {
    if (out->used >= out->capacity) return fits = false;
    // The tree covers a power-of-two square: clip to the feature's box.
    const int x0 = f.min.x + sx, y0 = f.min.y + sy;
    rect(x0, y0, std::min(x0 + size, f.max.x + 1), std::min(y0 + size, f.max.y + 1));
    return true;
  });
  if (!fits) return false;
  return true;
}

}  // namespace zonemap
