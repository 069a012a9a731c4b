#include "zonemap/features/feature_map.hpp"

// The feature map's store: matching an extraction's objects to the features it
// holds, relevance when full, re-integration (§IV-B), and the features that come
// from outside (priors, other vehicles' maps).
#include <algorithm>
#include <array>
#include <cmath>

#include "common/simd_u16.hpp"
#include "features/feature_map_detail.hpp"

namespace zonemap {

template <typename Pick>
Feature* FeatureMap::most_overlapping_stale(const ZoneKey& zone, const CellIndex& min,
                                            const CellIndex& max, Pick&& pick) {
  Feature* most = nullptr;
  std::int64_t best = 0;
  for (Feature* f = features_.get(); f != features_.get() + capacity_; ++f) {
    if (!f->in_use || !f->stale || !(f->zone == zone) || !pick(*f)) continue;
    const std::int64_t v = overlap_volume(f->min, f->max, min, max);
    if (v > best) {
      best = v;
      most = f;
    }
  }
  return most;
}

template <typename Fn>
void FeatureMap::for_each_zone_piece(const Eigen::Vector3d& min_m, const Eigen::Vector3d& max_m,
                                     Fn&& fn) const {
  const auto cell = [this](double m, bool upper) {
    const double c = m / cell_size_m_;
    // [min, max) in metres: the cells it covers, at least one.
    return static_cast<std::int32_t>(upper ? std::ceil(c) - 1.0 : std::floor(c));
  };
  const CellIndex lo{cell(min_m.x(), false), cell(min_m.y(), false), cell(min_m.z(), false)};
  CellIndex hi{cell(max_m.x(), true), cell(max_m.y(), true), cell(max_m.z(), true)};
  hi = {std::max(hi.x, lo.x), std::max(hi.y, lo.y), std::max(hi.z, lo.z)};
  const ZoneKey first = ZoneMap::key_of(map_config_, lo);
  const ZoneKey last = ZoneMap::key_of(map_config_, hi);
  // Bounded by the box's extent in zones (the loaders refuse boxes over 1 km).
  for (std::int32_t k = first.k; k <= last.k; ++k)
    for (std::int32_t j = first.j; j <= last.j; ++j)
      for (std::int32_t i = first.i; i <= last.i; ++i) {
        const ZoneKey key{i, j, k};
        const CellIndex o = ZoneMap::origin_of(map_config_, key);
        const CellIndex a{std::max(lo.x, o.x), std::max(lo.y, o.y), std::max(lo.z, o.z)};
        const CellIndex b{std::min(hi.x, o.x + dims_[0] - 1), std::min(hi.y, o.y + dims_[1] - 1),
                          std::min(hi.z, o.z + dims_[2] - 1)};
        fn(key, a, b);
      }
}

bool FeatureMap::add_prior(const Eigen::Vector3d& min_m, const Eigen::Vector3d& max_m) {
  bool all_stored = true;
  for_each_zone_piece(min_m, max_m,
                      [&](const ZoneKey& key, const CellIndex& a, const CellIndex& b) {
                        all_stored &= add_prior_piece(key, a, b);
                      });
  return all_stored;
}

std::size_t FeatureMap::replace_shared(std::uint8_t source, const Eigen::Vector3d* min_m,
                                       const Eigen::Vector3d* max_m, std::size_t count) {
  ++counters_.shared_updates;
  // What this sender sent before stays out of eviction while it is matched.
  for (Feature* f = features_.get(); f != features_.get() + capacity_; ++f) {
    if (f->in_use && f->shared_source == source) f->stale = true;
  }
  for (std::size_t b = 0; b < count; ++b) {
    for_each_zone_piece(min_m[b], max_m[b],
                        [&](const ZoneKey& key, const CellIndex& lo, const CellIndex& hi) {
                          add_or_keep_shared(source, key, lo, hi);
                        });
  }
  std::size_t stored = 0;
  for (Feature* f = features_.get(); f != features_.get() + capacity_; ++f) {
    if (!f->in_use || f->shared_source != source) continue;
    if (f->stale) {
      remove(f);
      ++counters_.shared_removed;
    } else {
      ++stored;
    }
  }
  return stored;
}

void FeatureMap::add_or_keep_shared(std::uint8_t source, const ZoneKey& zone, const CellIndex& min,
                                    const CellIndex& max) {
  Feature* same = most_overlapping_stale(
      zone, min, max, [source](const Feature& f) { return f.shared_source == source; });
  Feature piece;
  piece.min = min;
  piece.max = max;
  piece.cells = (max.x - min.x + 1) * (max.y - min.y + 1) * (max.z - min.z + 1);
  if (same != nullptr) {
    same->min = min;
    same->max = max;
    same->cells = piece.cells;
    same->last_seen_s = time_s_;
    same->stale = false;
    ++counters_.shared_kept;
    return;
  }
  Feature* slot = free_slot(relevance(piece));
  if (slot == nullptr) {
    ++counters_.shared_dropped;
    return;
  }
  piece.id = next_id_++;
  piece.zone = zone;
  piece.shared_source = source;
  piece.first_seen_s = time_s_;
  piece.last_seen_s = time_s_;
  piece.in_use = true;
  piece.prior = true;  // no view of ours has confirmed it (never matched by upsert)
  *slot = piece;
  ++in_use_;
  ++priors_live_;
  ++counters_.shared_added;
}

bool FeatureMap::add_prior_piece(const ZoneKey& zone, const CellIndex& min, const CellIndex& max) {
  Feature piece;
  piece.kind = FeatureKind::kObstacle;
  piece.min = min;
  piece.max = max;
  piece.cells = (max.x - min.x + 1) * (max.y - min.y + 1) * (max.z - min.z + 1);
  Feature* slot = free_slot(relevance(piece));
  if (slot == nullptr) {
    ++counters_.priors_dropped;
    return false;
  }
  piece.id = next_id_++;
  piece.zone = zone;
  piece.first_seen_s = time_s_;
  piece.last_seen_s = time_s_;
  piece.in_use = true;
  piece.prior = true;  // has_shape false: the whole box is the object until a view says more
  *slot = piece;
  ++in_use_;
  ++priors_live_;
  ++counters_.priors_added;
  return true;
}

double FeatureMap::relevance(const Feature& f) const {
  const Eigen::Vector3d centre =
      Eigen::Vector3d(f.min.x + f.max.x + 1, f.min.y + f.max.y + 1, f.min.z + f.max.z + 1) *
      (0.5 * cell_size_m_);
  const double distance = (centre - vehicle_m_).norm();
  const double score = f.cells / (1.0 + (distance / 10.0) * (distance / 10.0));
  // Any obstacle outranks any ground feature (a zone holds < 1e9 cells).
  return f.kind == FeatureKind::kObstacle ? 1e9 + score : score;
}

void FeatureMap::remove(Feature* f) {
  if (f->prior) --priors_live_;
  if (f->has_shape) shapes_.release(&f->shape);
  *f = Feature{};
  --in_use_;
}

Feature* FeatureMap::free_slot(double new_relevance) {
  Feature* least = nullptr;
  for (Feature* f = features_.get(); f != features_.get() + capacity_; ++f) {
    if (!f->in_use) return f;
    // Stale features are being matched in this extraction: keep them out of the choice.
    if (!f->stale && (least == nullptr || relevance(*f) < relevance(*least))) least = f;
  }
  if (least == nullptr || relevance(*least) >= new_relevance) {
    ++counters_.features_dropped;
    return nullptr;
  }
  remove(least);
  ++counters_.features_evicted;
  return least;
}

void FeatureMap::upsert(const ZoneKey& zone, FeatureKind kind, const CellIndex& min,
                        const CellIndex& max, std::int32_t cells, bool measured) {
  // The same object as before: the stale feature of this zone and kind that
  // overlaps the new box most.
  Feature* match =
      most_overlapping_stale(zone, min, max, [kind](const Feature& f) { return f.kind == kind; });
  if (match == nullptr) {
    Feature candidate;
    candidate.kind = kind;
    candidate.min = min;
    candidate.max = max;
    candidate.cells = cells;
    match = free_slot(relevance(candidate));
    if (match == nullptr) return;
    match->id = next_id_++;
    match->first_seen_s = time_s_;
    match->last_seen_s = time_s_;
    match->in_use = true;
    ++in_use_;
    ++counters_.features_added;
  } else {
    if (match->has_shape) shapes_.release(&match->shape);
    ++counters_.features_updated;
  }
  match->kind = kind;
  match->zone = zone;
  match->min = min;
  match->max = max;
  match->cells = cells;
  if (in_view(min, max)) {
    match->last_seen_s = time_s_;
    if (match->prior && measured) {  // seen occupied where it was said to stand
      match->prior = false;
      --priors_live_;
      ++counters_.priors_confirmed;
    }
  }
  match->stale = false;
  match->has_shape = shapes_.build(footprint_.get(), max.x - min.x + 1, max.y - min.y + 1,
                                   &match->shape, &match->shape_side);
  if (!match->has_shape) ++counters_.shapes_truncated;
}

bool FeatureMap::feature_contains(const Feature& f, const CellIndex& c) const {
  if (c.x < f.min.x || c.y < f.min.y || c.z < f.min.z || c.x > f.max.x || c.y > f.max.y ||
      c.z > f.max.z) {
    return false;
  }
  return !f.has_shape || shapes_.contains(f.shape, f.shape_side, c.x - f.min.x, c.y - f.min.y);
}

void FeatureMap::on_zone_allocated(ZoneView& zone) {
  // §IV-B: cells inside a stored object's shape (footprint x z extent) become
  // occupied with a high value; everything else stays unknown.
  for_each_reintegration_box(zone.key, [&](const CellIndex& min, const CellIndex& max) {
    counters_.cells_reintegrated += reintegrate_box(zone, min, max, reintegration_value_);
  });
}

std::int64_t FeatureMap::reintegrate_box(ZoneView& zone, const CellIndex& min, const CellIndex& max,
                                         FusedCell value) {
  const int x0 = std::max(min.x - zone.origin.x, 0);
  const int y0 = std::max(min.y - zone.origin.y, 0);
  const int z0 = std::max(min.z - zone.origin.z, 0);
  const int x1 = std::min(max.x - zone.origin.x, zone.dims[0] - 1);
  const int y1 = std::min(max.y - zone.origin.y, zone.dims[1] - 1);
  const int z1 = std::min(max.z - zone.origin.z, zone.dims[2] - 1);
  std::int64_t cells = 0;
  for (int z = z0; z <= z1; ++z)
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        FusedCell& cell = zone.cells[zone.index(x, y, z)];
        cell = std::max(cell, value);
        ++cells;
      }
  return cells;
}

}  // namespace zonemap
