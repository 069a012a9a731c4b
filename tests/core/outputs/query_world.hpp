// A world for the planner queries' tests: a far zone known only through
// features (random blobs) and live zones with random occupied cells, with every
// occupied cell listed for brute force.
#pragma once

#include <utility>
#include <vector>

#include "tools/sim/scene.hpp"
#include "zonemap/features/feature_map.hpp"
#include "zonemap/zones/zone_map.hpp"

namespace zonemap::testing {

struct World {
  MapConfig config;
  ZoneMap zones;
  FeatureMap features;
  std::vector<CellIndex> occupied;  // every occupied cell, for brute force
  std::vector<std::pair<CellIndex, std::uint32_t>> obstacle_cells;

  static MapConfig make_config() {
    MapConfig c;
    c.cell_size_m = 0.5;
    c.zone_cells = {16, 16, 8};
    c.features.min_cells = 1;
    c.features.ground_enabled = false;
    c.features.capacity = 256;
    c.features.quadtree_groups = 4096;
    return c;
  }

  World() : config(make_config()), zones(config), features(config, true) {
    sim::Rng rng(11);
    const FusedCell high = 4 * kCellScale;
    // A far zone (key 3,0,0) known only through features: random blobs, extracted
    // from a scratch grid.
    std::vector<FusedCell> scratch(16 * 16 * 8, 0);
    ZoneView far{{3, 0, 0}, {48, 0, 0}, config.zone_cells, scratch.data()};
    for (int blob = 0; blob < 6; ++blob) {
      const int x0 = static_cast<int>(rng.uniform() * 12),
                y0 = static_cast<int>(rng.uniform() * 12);
      const int z0 = static_cast<int>(rng.uniform() * 5);
      for (int k = 0; k < 10; ++k) {
        const int x = x0 + static_cast<int>(rng.uniform() * 4),
                  y = y0 + static_cast<int>(rng.uniform() * 4);
        const int z = z0 + static_cast<int>(rng.uniform() * 3);
        scratch[far.index(x, y, z)] = high;
      }
    }
    features.extract(far);
    // Brute-force list of feature-shape cells: box x footprint.
    for (const Feature* f = features.begin(); f != features.end(); ++f) {
      if (!f->in_use) continue;
      for (int z = f->min.z; z <= f->max.z; ++z)
        for (int y = f->min.y; y <= f->max.y; ++y)
          for (int x = f->min.x; x <= f->max.x; ++x)
            if (features.feature_contains(*f, {x, y, z})) {
              occupied.push_back({x, y, z});
              obstacle_cells.push_back({{x, y, z}, f->id});
            }
    }
    // Live zones around the origin with random occupied cells in the grid.
    zones.move_environment(zones.environment_origin({8, 8, 4}));
    zones.for_each_live_zone([&](ZoneView& z) {
      for (int i = 0; i < 40; ++i) {
        const int x = static_cast<int>(rng.uniform() * 16),
                  y = static_cast<int>(rng.uniform() * 16);
        const int zz = static_cast<int>(rng.uniform() * 8);
        z.cells[z.index(x, y, zz)] = high;
        occupied.push_back({z.origin.x + x, z.origin.y + y, z.origin.z + zz});
      }
    });
  }
};

}  // namespace zonemap::testing
