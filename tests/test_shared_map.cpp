// Maps shared between vehicles, the message: another vehicle's obstacle_map_t taken
// into this map's frame through both world origins (every check on each box, the
// whole message refused when it cannot be placed). The feature map's side and the
// inbox: tests/core/features/test_shared_maps.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "hal/lcm/lcm_codec.hpp"
#include "hal/lcm/lcm_shared_maps.hpp"
#include "zonemap/common/geodetic.hpp"
#include "zonemap/features/feature_map.hpp"
#include "zonemap/features/shared_map_inbox.hpp"

namespace zonemap {
namespace {

using lcm_link::SharedMapDecoder;
using lcm_link::SharedMapsConfig;

// --- the message -------------------------------------------------------------------

struct Sent {
  const char* vehicle = "heli-2";
  bool world_z_up = true;
  const Geodetic* origin = nullptr;
  std::vector<ObstacleBox> boxes;
};

std::vector<std::uint8_t> encode(const Sent& s) {
  lcm_link::ObstacleMapMessage map(64, 4);
  map.set_sender(s.vehicle, s.origin);
  map.fill(1, Eigen::Vector3d::Zero(), s.world_z_up, s.boxes.data(), s.boxes.size(), nullptr,
           nullptr, nullptr);
  const std::uint8_t* bytes = nullptr;
  const std::size_t size = map.encode(&bytes);
  return {bytes, bytes + size};
}

ObstacleBox box(Eigen::Vector3d min, Eigen::Vector3d max, bool prior = false,
                FeatureKind kind = FeatureKind::kObstacle) {
  ObstacleBox b;
  b.id = 7;
  b.min = min;
  b.max = max;
  b.prior = prior;
  b.kind = kind;
  return b;
}

const Geodetic kOwnOrigin{48.1, 11.5, 520.0};

SharedMapsConfig own_config(bool world_z_up) {
  SharedMapsConfig c;
  c.vehicle = "heli-1";
  c.world_origin = kOwnOrigin;
  c.world_z_up = world_z_up;
  c.max_boxes = 3;
  return c;
}

// This vehicle's receiving side: the decoder and one inbox slot to decode into.
struct Receiving {
  SharedMapDecoder decoder;
  SharedMapInbox inbox{3};
  SharedMapUpdate* slot = inbox.take_free();
  explicit Receiving(bool world_z_up) : decoder(own_config(world_z_up)) {}
  bool take(const std::vector<std::uint8_t>& bytes, std::size_t size) {
    return decoder.decode(bytes.data(), size, slot, 0.0);
  }
  bool take(const std::vector<std::uint8_t>& bytes) { return take(bytes, bytes.size()); }
};

// The sender's origin 40 m north, 20 m east and 2 m above ours: its post at
// (10, 5) north-west-up is at (50, -15) in ours, 2 m higher; in NED the same.
TEST(SharedMapMessage, ABoxMovesFromTheSendersFrameToOursThroughTheOrigins) {
  const Geodetic sender = LocalTangentPlane(kOwnOrigin).to_geodetic({40.0, 20.0, -2.0});
  for (const bool own_z_up : {true, false}) {
    for (const bool sender_z_up : {true, false}) {
      Sent s;
      s.origin = &sender;
      s.world_z_up = sender_z_up;
      // North 10..11, west 5..6 (east -6..-5), up 0..8.
      s.boxes = {sender_z_up ? box({10, 5, 0}, {11, 6, 8}) : box({10, -6, -8}, {11, -5, 0})};
      Receiving here(own_z_up);
      const SharedMapUpdate* u = here.slot;
      ASSERT_TRUE(here.take(encode(s)));
      ASSERT_EQ(u->count, 1u);
      const Eigen::Vector3d lo =
          own_z_up ? Eigen::Vector3d(50, -15, 2) : Eigen::Vector3d(50, 14, -10);
      const Eigen::Vector3d hi =
          own_z_up ? Eigen::Vector3d(51, -14, 10) : Eigen::Vector3d(51, 15, -2);
      EXPECT_LT((u->min[0] - lo).cwiseAbs().maxCoeff(), 0.01) << u->min[0].transpose();
      EXPECT_LT((u->max[0] - hi).cwiseAbs().maxCoeff(), 0.01) << u->max[0].transpose();
    }
  }
}

TEST(SharedMapMessage, OnlyWhatTheSenderMeasuredIsTakenAndABadBoxCostsOnlyItself) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  Sent s;
  s.origin = &kOwnOrigin;
  s.boxes = {box({0, 0, 0}, {1, 1, 2}),
             box({5, 5, 0}, {6, 6, 2}, true),                             // its prior: not measured
             box({0, 0, 0}, {30, 30, 0.5}, false, FeatureKind::kGround),  // ground
             box({0, 0, 0}, {nan, 1, 2}),                                 // not a number
             box({0, 0, 0}, {1500, 1, 2}),                                // over 1 km wide
             box({0, 0, -1200}, {1, 1, -1100}),                           // below -1 km
             box({3, 1, 0}, {2, 2, 2}),                                   // inside out
             box({2, 2, 0}, {3, 3, 2}),
             box({4, 4, 0}, {5, 5, 2}),
             box({6, 6, 0}, {7, 7, 2})};  // the fourth measured: over max_boxes 3
  Receiving here(true);
  const SharedMapUpdate* u = here.slot;
  ASSERT_TRUE(here.take(encode(s)));
  EXPECT_EQ(u->count, 3u);
  const lcm_link::SharedMapCounters& c = here.decoder.counters();
  EXPECT_EQ(c.boxes_taken, 3);
  EXPECT_EQ(c.boxes_not_measured, 2);
  EXPECT_EQ(c.boxes_rejected, 4);
  EXPECT_EQ(c.boxes_over_capacity, 1);
  for (std::size_t i = 0; i < u->count; ++i) {
    EXPECT_TRUE(u->min[i].allFinite() && u->max[i].allFinite());
  }
}

TEST(SharedMapMessage, AMapThatCannotBePlacedIsRefusedWhole) {
  Receiving here(true);
  const SharedMapDecoder& decoder = here.decoder;
  const SharedMapUpdate* u = here.slot;
  Sent no_origin;
  no_origin.boxes = {box({0, 0, 0}, {1, 1, 2})};
  auto bytes = encode(no_origin);
  EXPECT_FALSE(here.take(bytes));
  EXPECT_EQ(decoder.counters().refused_no_origin, 1);

  Sent own = no_origin;
  own.origin = &kOwnOrigin;
  own.vehicle = "heli-1";
  bytes = encode(own);
  EXPECT_FALSE(here.take(bytes));
  EXPECT_EQ(decoder.counters().refused_own, 1);

  Sent good = no_origin;
  good.origin = &kOwnOrigin;
  bytes = encode(good);
  for (const std::size_t cut : {std::size_t{0}, std::size_t{9}, bytes.size() - 1}) {
    EXPECT_FALSE(here.take(bytes, cut)) << "truncated to " << cut;
  }
  std::vector<std::uint8_t> wrong = bytes;
  wrong[0] ^= 0xFF;  // another type's fingerprint
  EXPECT_FALSE(here.take(wrong));
  // Counts that lcm-gen's decoder would size its vectors by before checking them:
  // the box count (after 49 bytes) negative or past the message, the name's
  // length (the last 29 bytes: length, "heli-2", flag, origin) zero.
  for (const std::uint8_t first : {std::uint8_t{0xFF}, std::uint8_t{0x7F}}) {
    wrong = bytes;
    wrong[49] = first;
    EXPECT_FALSE(here.take(wrong)) << int(first);
  }
  wrong = bytes;
  const std::size_t name = bytes.size() - 1 - 24 - 7 - 4;
  wrong[name + 3] = 0;
  EXPECT_FALSE(here.take(wrong));
  EXPECT_EQ(decoder.counters().malformed, 7);
  EXPECT_EQ(u->count, 0u);
  EXPECT_TRUE(here.take(bytes));
  EXPECT_EQ(u->count, 1u);
}

}  // namespace
}  // namespace zonemap
