// Hand-made grids for the feature map's tests: a zone buffer of its own and a
// small feature configuration.
#pragma once

#include <array>
#include <vector>

#include "zonemap/common/config.hpp"
#include "zonemap/zones/zone_map.hpp"

namespace zonemap::testing {

// A zone buffer of its own, for hand-made grids.
struct TestZone {
  std::vector<FusedCell> cells;
  ZoneView view;
  TestZone(const std::array<int, 3>& dims, const ZoneKey& key)
      : cells(static_cast<std::size_t>(dims[0]) * dims[1] * dims[2], 0) {
    view = ZoneView{key, CellIndex{key.i * dims[0], key.j * dims[1], key.k * dims[2]}, dims,
                    cells.data()};
  }
  void set(int x, int y, int z, FusedCell v = 4 * kCellScale) { cells[view.index(x, y, z)] = v; }
  FusedCell at(int x, int y, int z) const { return cells[view.index(x, y, z)]; }
};

inline MapConfig feature_config(std::array<int, 3> dims, bool ground) {
  MapConfig config;
  config.cell_size_m = 1.0;
  config.zone_cells = dims;
  config.features.min_cells = 1;
  config.features.ground_enabled = ground;
  config.features.ground_thickness_m = 1.0;
  config.features.ground_window_m = 4.0;
  config.features.capacity = 64;
  config.features.quadtree_groups = 1024;
  return config;
}

}  // namespace zonemap::testing
