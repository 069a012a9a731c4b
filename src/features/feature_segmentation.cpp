#include "zonemap/features/feature_map.hpp"

// The feature map's segmentation: 6-connected components, and their split into
// objects at the fused value's valleys (a watershed over column peaks).
#include <algorithm>
#include <array>
#include <cmath>

#include "common/simd_u16.hpp"
#include "features/feature_map_detail.hpp"

namespace zonemap {

std::size_t FeatureMap::fill_component(const ZoneSnapshot& zone, std::size_t start, bool ground) {
  // Breadth-first fill of the 6-connected cells of the same class. Each cell is
  // queued once (marked when queued), so the queue never exceeds the zone.
  std::size_t head = 0;
  std::size_t tail = 0;
  component_[tail++] = static_cast<std::uint32_t>(start);
  mark(start);
  while (head < tail) {
    const std::size_t i = component_[head++];
    for_each_neighbour(i, [&](std::size_t j, int x, int y, int z) {
      if (visited(j) || !zone.occupied(j) || is_ground_cell(x, y, z) != ground) return;
      mark(j);
      component_[tail++] = static_cast<std::uint32_t>(j);
    });
  }
  return tail;
}

std::size_t FeatureMap::grow_regions(const ZoneSnapshot& zone, std::uint32_t* queue,
                                     std::size_t tail, int level) {
  // Breadth-first from every labelled cell at once: each cell at or above `level`
  // goes to the region that reaches it first.
  for (std::size_t head = 0; head < tail; ++head) {
    const std::uint32_t label = unpack_label(queue[head]);
    for_each_neighbour(unpack_cell(queue[head]), [&](std::size_t j, int x, int y, int z) {
      if (visited(j) || !zone.occupied(j) || zone.level(j) < level || is_ground_cell(x, y, z)) {
        return;
      }
      mark(j);
      queue[tail++] = pack(j, label);
    });
  }
  return tail;
}

std::size_t FeatureMap::add_cores(const ZoneSnapshot& zone, std::size_t count, std::uint32_t* queue,
                                  std::size_t tail, int level, std::uint32_t* cores) {
  // Parts at or above `level` that no region reached are new cores, unless they
  // are specks (fewer than core_min_cells: left for the growth).
  for (std::size_t k = 0; k < count && *cores < kMaxCores; ++k) {
    const std::size_t seed = component_[k];
    if (visited(seed) || zone.level(seed) < level) continue;
    const std::size_t first = tail;
    queue[tail++] = pack(seed, *cores);
    mark(seed);
    for (std::size_t head = first; head < tail; ++head) {
      for_each_neighbour(unpack_cell(queue[head]), [&](std::size_t j, int x, int y, int z) {
        if (visited(j) || !zone.occupied(j) || zone.level(j) < level || is_ground_cell(x, y, z)) {
          return;
        }
        mark(j);
        queue[tail++] = pack(j, *cores);
      });
    }
    if (tail - first < static_cast<std::size_t>(core_min_cells_)) {
      for (std::size_t q = first; q < tail; ++q) unmark(unpack_cell(queue[q]));
      tail = first;
      continue;
    }
    core_first_[*cores] = first;
    core_end_[*cores] = tail;
    ++*cores;
  }
  return tail;
}

std::size_t FeatureMap::split_at_valleys(const ZoneSnapshot& zone, std::size_t count) {
  // Objects that stand close (trees in a line, bushes of a hedge) touch through
  // cells that fewer or farther views saw occupied: the fused value dips between
  // them. A watershed by flooding, in levels from the object's peak down:
  // at each level the regions found so far grow into the cells now above it, and
  // parts that none of them reaches are new regions (cores). What is left below
  // the last level goes to the nearest region. A part whose value never rises
  // apart from its neighbour's (no dip) stays one region.
  const std::size_t total = zone.cell_count();
  if (!(core_min_cells_ > 0) || count < 2 * static_cast<std::size_t>(core_min_cells_) ||
      2 * count > total || !zone.levels_complete()) {
    return 1;  // nothing to split, no room for the growth queue, or no levels
  }
  int peak = 0;
  for (std::size_t k = 0; k < count; ++k) peak = std::max<int>(peak, zone.level(component_[k]));
  for (std::size_t k = 0; k < count; ++k) unmark(component_[k]);
  // The queue lives behind the component's cells: entries are a cell index (22
  // bits: kMaxZoneCells) and its region's label above it.
  std::uint32_t* queue = component_.get() + count;
  std::size_t tail = 0;
  std::uint32_t cores = 0;
  // Levels 0.9^k of the peak down to the occupied threshold: a dip of a tenth
  // shows, and a weak object next to a strong one still rises apart from it.
  const int floor_level = threshold_ / zone.level_step() + 1;
  for (int level = peak * 9 / 10; level >= floor_level; level = level * 9 / 10) {
    tail = grow_regions(zone, queue, tail, level);
    tail = add_cores(zone, count, queue, tail, level, &cores);
    if (level < 10) break;  // 9 * 9 / 10 rounds to itself
  }
  for (std::size_t k = 0; k < count; ++k) mark(component_[k]);
  if (cores <= 1) return 1;
  // Each cell then goes with its column: columns, not cells, so that a region's
  // growth along the low band that joins neighbours cannot reach far under them;
  // flooded down the columns' peaks, so that neighbours part where they dip.
  label_columns_by_flooding(zone, count, queue, cores);
  sort_by_column_label(count, cores);
  // Two faces of one solid thing (a hut seen from both sides, its inside never
  // seen) are cores too; their regions' x-y boxes overlap mostly, those of
  // neighbours standing apart hardly: such regions are one object again.
  if (merge_overlapping_regions(cores)) sort_by_column_label(count, cores);
  return cores;
}

bool FeatureMap::merge_overlapping_regions(std::uint32_t cores) {
  RegionBox* box = region_box_.get();
  for (std::uint32_t r = 0; r < cores; ++r) {
    box[r] = {INT32_MAX, INT32_MAX, INT32_MIN, INT32_MIN};
    for (std::size_t k = region_start_[r]; k < region_start_[r + 1]; ++k) {
      const int x = cell_x(component_[k]), y = cell_y(component_[k]);
      box[r] = {std::min(box[r].x0, x), std::min(box[r].y0, y), std::max(box[r].x1, x),
                std::max(box[r].y1, y)};
    }
    region_root_[r] = static_cast<std::uint16_t>(r);
  }
  const auto root = [&](std::uint32_t r) {
    while (region_root_[r] != r) r = region_root_[r];
    return r;
  };
  const auto area = [](const RegionBox& b) {
    return static_cast<std::int64_t>(b.x1 - b.x0 + 1) * (b.y1 - b.y0 + 1);
  };
  bool merged_any = false;
  for (std::uint32_t a = 0; a < cores; ++a) {
    if (region_start_[a] == region_start_[a + 1]) continue;
    for (std::uint32_t b = a + 1; b < cores; ++b) {
      if (region_start_[b] == region_start_[b + 1]) continue;
      const std::int64_t w = std::min(box[a].x1, box[b].x1) - std::max(box[a].x0, box[b].x0) + 1;
      const std::int64_t h = std::min(box[a].y1, box[b].y1) - std::max(box[a].y0, box[b].y0) + 1;
      if (w <= 0 || h <= 0 || 2 * w * h <= std::min(area(box[a]), area(box[b]))) continue;
      const std::uint32_t ra = root(a), rb = root(b);
      if (ra != rb) region_root_[std::max(ra, rb)] = static_cast<std::uint16_t>(std::min(ra, rb));
      merged_any = true;
    }
  }
  if (!merged_any) return false;
  // The columns take their region's root as label (sort_by_column_label reads them).
  std::int16_t* label = column_tmp_.get();
  const std::size_t nx = static_cast<std::size_t>(dims_[0]);
  for (std::uint32_t r = 0; r < cores; ++r) {
    for (std::size_t k = region_start_[r]; k < region_start_[r + 1]; ++k) {
      const std::uint32_t c = component_[k];
      label[static_cast<std::size_t>(cell_y(c)) * nx + cell_x(c)] =
          static_cast<std::int16_t>(root(r));
    }
  }
  return true;
}

void FeatureMap::label_columns_by_flooding(const ZoneSnapshot& zone, std::size_t count,
                                           const std::uint32_t* queue, std::uint32_t cores) {
  const int nx = dims_[0];
  CellIndex lo{cell_x(component_[0]), cell_y(component_[0]), 0};
  CellIndex hi = lo;
  for (std::size_t k = 0; k < count; ++k) {
    lo = {std::min(lo.x, cell_x(component_[k])), std::min(lo.y, cell_y(component_[k])), 0};
    hi = {std::max(hi.x, cell_x(component_[k])), std::max(hi.y, cell_y(component_[k])), 0};
  }
  std::int16_t* label = column_tmp_.get();
  // Each column's peak: the largest level of the component's cells in it (lowest_
  // is free once the terrain is known); -1 for the box's other columns.
  std::int16_t* peak = lowest_.get();
  for (int y = lo.y; y <= hi.y; ++y) {
    const std::size_t row = static_cast<std::size_t>(y) * nx + lo.x;
    std::fill_n(label + row, hi.x - lo.x + 1, std::int16_t{-1});
    std::fill_n(peak + row, hi.x - lo.x + 1, std::int16_t{-1});
  }
  for (std::size_t k = 0; k < count; ++k) {
    const std::uint32_t c = component_[k];
    std::int16_t& p = peak[static_cast<std::size_t>(cell_y(c)) * nx + cell_x(c)];
    p = std::max<std::int16_t>(p, zone.level(c));
  }
  // A bucket queue of columns by level (FIFO within a level; links through
  // column_queue_): from the cores' seed columns, the highest columns are
  // taken first and give their label to their unlabelled 4-neighbours, queued
  // at their own peak (never above the level being flooded). Neighbours thus
  // meet where the column peaks dip between them, not halfway between cores.
  constexpr std::uint32_t kEnd = UINT32_MAX;
  constexpr int kLevels = 256;
  std::array<std::uint32_t, kLevels> head;
  std::array<std::uint32_t, kLevels> tail;
  head.fill(kEnd);
  tail.fill(kEnd);
  std::uint32_t* next = column_queue_.get();
  const auto push = [&](std::uint32_t column, int level) {
    const int b = std::clamp(level, 0, kLevels - 1);
    next[column] = kEnd;
    if (tail[b] == kEnd) {
      head[b] = column;
    } else {
      next[tail[b]] = column;
    }
    tail[b] = column;
  };
  for (std::uint32_t c = 0; c < cores; ++c) {
    for (std::size_t q = core_first_[c]; q < core_end_[c]; ++q) {
      const std::size_t cell = unpack_cell(queue[q]);
      const std::size_t column = static_cast<std::size_t>(cell_y(cell)) * nx + cell_x(cell);
      if (label[column] >= 0) continue;
      label[column] = static_cast<std::int16_t>(c);
      push(static_cast<std::uint32_t>(column), peak[column]);
    }
  }
  for (int level = kLevels - 1; level >= 0; --level) {
    while (head[level] != kEnd) {
      const std::uint32_t column = head[level];
      head[level] = next[column];
      if (head[level] == kEnd) tail[level] = kEnd;
      const int x = static_cast<int>(column % static_cast<std::uint32_t>(nx));
      const int y = static_cast<int>(column / static_cast<std::uint32_t>(nx));
      const auto visit = [&](int vx, int vy) {
        if (vx < lo.x || vx > hi.x || vy < lo.y || vy > hi.y) return;
        const std::size_t v = static_cast<std::size_t>(vy) * nx + vx;
        if (label[v] >= 0) return;
        label[v] = label[column];
        push(static_cast<std::uint32_t>(v), std::min<int>(peak[v], level));
      };
      visit(x - 1, y);
      visit(x + 1, y);
      visit(x, y - 1);
      visit(x, y + 1);
    }
  }
}

void FeatureMap::sort_by_column_label(std::size_t count, std::uint32_t cores) {
  // Counting sort by the column's label into component_[0, count) (through the
  // queue area behind it): region r is [region_start_[r], region_start_[r + 1]).
  const int nx = dims_[0];
  const std::int16_t* label = column_tmp_.get();
  const auto label_of = [&](std::uint32_t cell) {
    return static_cast<std::size_t>(
        label[static_cast<std::size_t>(cell_y(cell)) * nx + cell_x(cell)]);
  };
  std::fill_n(region_start_.get(), cores + 1, std::size_t{0});
  for (std::size_t k = 0; k < count; ++k) ++region_start_[label_of(component_[k]) + 1];
  for (std::uint32_t r = 0; r < cores; ++r) region_start_[r + 1] += region_start_[r];
  std::uint32_t* sorted = component_.get() + count;
  for (std::size_t k = 0; k < count; ++k)
    sorted[region_start_[label_of(component_[k])]++] = component_[k];
  std::copy_n(sorted, count, component_.get());
  // region_start_[r] now ends region r: shifted back to where each begins.
  for (std::uint32_t r = cores; r > 0; --r) region_start_[r] = region_start_[r - 1];
  region_start_[0] = 0;
}

}  // namespace zonemap
