// validate(MapConfig): the first wrong key, by name, section by section.
#include <gtest/gtest.h>

#include <string>

#include "zonemap/common/config.hpp"

namespace zonemap {
namespace {

TEST(MapConfigValidate, TheDefaultsPassAndEachSectionNamesItsFirstWrongKey) {
  EXPECT_EQ(validate(MapConfig{}), "");
  MapConfig map_wrong;
  map_wrong.cell_size_m = -1.0;
  map_wrong.min_weight = 0.0;  // wrong too, but a later section
  EXPECT_EQ(validate(map_wrong).rfind("map.cell_size_m", 0), 0u) << validate(map_wrong);
  MapConfig sensor_wrong;
  sensor_wrong.depth_filter_radius_px = kMaxDepthFilterRadius + 1;
  EXPECT_EQ(validate(sensor_wrong).rfind("sensor.depth_filter_radius", 0), 0u)
      << validate(sensor_wrong);
  MapConfig fusion_wrong;
  fusion_wrong.min_weight = 0.0;
  EXPECT_EQ(validate(fusion_wrong).rfind("fusion.min_weight", 0), 0u) << validate(fusion_wrong);
  MapConfig features_wrong;
  features_wrong.features.merge_gap_cells = 9;
  EXPECT_EQ(validate(features_wrong).rfind("features.merge_gap_cells", 0), 0u)
      << validate(features_wrong);
}

}  // namespace
}  // namespace zonemap
