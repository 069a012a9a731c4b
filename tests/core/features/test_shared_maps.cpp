// Other vehicles' maps in the feature map: kept as the sender's (in every output
// marked prior, never written into the grid, replaced by the sender's next map),
// and the fixed inbox that hands them to the feature map's thread (the message:
// tests/test_shared_map.cpp; no allocation: tests/test_core_allocations.cpp).
#include <gtest/gtest.h>

#include <utility>
#include <vector>

#include "zonemap/features/feature_map.hpp"
#include "zonemap/features/shared_map_inbox.hpp"

namespace zonemap {
namespace {

std::size_t replace(FeatureMap& features, std::uint8_t source,
                    std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> boxes) {
  std::vector<Eigen::Vector3d> lo, hi;
  for (const auto& [a, b] : boxes) {
    lo.push_back(a);
    hi.push_back(b);
  }
  return features.replace_shared(source, lo.data(), hi.data(), lo.size());
}

TEST(SharedMap, ABoxIsTheSendersUntilItsNextMapLacksIt) {
  MapConfig config;  // 1 m cells, zones of 80 x 80 x 10
  FeatureMap features(config, true);
  EXPECT_EQ(replace(features, 1, {{{78.5, 10, 0}, {81.5, 12, 5}}}), 2u);  // across x = 80
  ObstacleBox out[4];
  ASSERT_EQ(features.merged(out, 4, false), 1u);
  EXPECT_TRUE(out[0].prior) << "no view of ours has confirmed it";
  EXPECT_EQ(out[0].min, Eigen::Vector3d(78, 10, 0));
  EXPECT_EQ(out[0].max, Eigen::Vector3d(82, 12, 5));
  const std::uint32_t id = out[0].id;

  // Never written into the grid: the sender's map stays the sender's.
  int boxes = 0;
  features.for_each_reintegration_box(ZoneKey{0, 0, 0}, [&](auto&&, auto&&) { ++boxes; });
  EXPECT_EQ(boxes, 0);

  // The same object moved by half a metre: the same pieces, the same id.
  EXPECT_EQ(replace(features, 1, {{{79.0, 10, 0}, {82.0, 12, 5}}}), 2u);
  ASSERT_EQ(features.merged(out, 4, false), 1u);
  EXPECT_EQ(out[0].id, id);
  EXPECT_EQ(out[0].max.x(), 82.0);
  EXPECT_EQ(features.counters().shared_kept, 2);

  // Another sender's map leaves this one's alone; this one's next map without it removes it.
  EXPECT_EQ(replace(features, 2, {{{10, 10, 0}, {11, 11, 3}}}), 1u);
  EXPECT_EQ(replace(features, 1, {}), 0u);
  ASSERT_EQ(features.merged(out, 4, false), 1u);
  EXPECT_EQ(out[0].min, Eigen::Vector3d(10, 10, 0));
  EXPECT_EQ(features.counters().shared_removed, 2);
  EXPECT_EQ(features.counters().shared_updates, 4);
}

// An extraction of the zone finds nothing of it in the grid, and keeps it: the
// grid never held it. This vehicle's own object there is its own feature; the
// output joins the two, no longer prior.
TEST(SharedMap, AnExtractionKeepsItAndAnOwnViewOfTheSameObjectJoinsIt) {
  MapConfig config;
  config.zone_cells = {20, 20, 10};
  config.features.min_cells = 1;
  config.features.ground_enabled = false;
  FeatureMap features(config, true);
  std::vector<FusedCell> cells(20 * 20 * 10, 0);
  ZoneView zone{ZoneKey{0, 0, 0}, CellIndex{0, 0, 0}, config.zone_cells, cells.data()};
  ASSERT_EQ(replace(features, 1, {{{4, 4, 0}, {6, 6, 4}}}), 1u);
  features.extract(zone);
  ObstacleBox out[4];
  ASSERT_EQ(features.merged(out, 4, false), 1u) << "an empty grid does not remove it";
  EXPECT_TRUE(out[0].prior);

  // The post seen by this vehicle: cells 4..5 x 4..5 x 1..3 occupied.
  for (int z = 1; z <= 3; ++z)
    for (int y = 4; y <= 5; ++y)
      for (int x = 4; x <= 5; ++x) cells[zone.index(x, y, z)] = 4 * kCellScale;
  features.extract(zone);
  EXPECT_EQ(features.count(), 2u);
  ASSERT_EQ(features.merged(out, 4, false), 1u);
  EXPECT_FALSE(out[0].prior) << "seen by this vehicle too";
  EXPECT_EQ(out[0].parts, 2);
}

TEST(SharedMap, WhenTheStoreIsFullTheRelevanceRuleDecidesAndCounts) {
  MapConfig config;
  config.features.capacity = 2;
  FeatureMap features(config, true);
  features.set_context(0.0, Eigen::Vector3d::Zero());
  EXPECT_TRUE(features.add_prior({10, 10, 0}, {11, 11, 5}));
  // Two shared boxes: a near one takes the last slot, a far one of the same size is left out.
  EXPECT_EQ(replace(features, 1, {{{12, 12, 0}, {13, 13, 5}}, {{300, 300, 0}, {301, 301, 5}}}), 1u);
  EXPECT_EQ(features.counters().shared_added, 1);
  EXPECT_EQ(features.counters().shared_dropped, 1);
  EXPECT_EQ(features.count(), 2u);
}

TEST(SharedMap, TheInboxHandsOverInOrderAndCountsAFullOne) {
  SharedMapInbox inbox(8);
  SharedMapUpdate* taken[SharedMapInbox::kSlots];
  for (auto& t : taken) {
    t = inbox.take_free();
    ASSERT_NE(t, nullptr);
    t->count = 1;
    t->min[0] = Eigen::Vector3d(1, 2, 3);
    inbox.post(t);
  }
  EXPECT_EQ(inbox.take_free(), nullptr);
  EXPECT_EQ(inbox.dropped(), 1);
  for (int i = 0; i < static_cast<int>(SharedMapInbox::kSlots); ++i) {
    SharedMapUpdate* u = inbox.next();
    ASSERT_EQ(u, taken[i]) << "in the order posted";
    inbox.release(u);
  }
  EXPECT_EQ(inbox.next(), nullptr);
  EXPECT_NE(inbox.take_free(), nullptr);
}

}  // namespace
}  // namespace zonemap
