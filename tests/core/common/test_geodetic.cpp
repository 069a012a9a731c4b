// Geodetic (WGS-84) -> local NED: known points and the round trip.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "zonemap/common/geodetic.hpp"

using namespace zonemap;

TEST(Geodetic, KnownPointsAndRoundTrip) {
  const Eigen::Vector3d equator = geodetic_to_ecef({0.0, 0.0, 0.0});
  EXPECT_NEAR(equator.x(), 6378137.0, 1e-6);
  EXPECT_NEAR(geodetic_to_ecef({90.0, 0.0, 0.0}).z(), 6356752.314245, 1e-5);  // semi-minor axis
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> lat(-89.0, 89.0), lon(-180.0, 180.0), h(-100.0, 10000.0);
  for (int i = 0; i < 1000; ++i) {
    const Geodetic g{lat(rng), lon(rng), h(rng)};
    const Geodetic back = ecef_to_geodetic(geodetic_to_ecef(g));
    EXPECT_NEAR(back.latitude_deg, g.latitude_deg, 1e-10);
    EXPECT_NEAR(back.longitude_deg, g.longitude_deg, 1e-10);
    EXPECT_NEAR(back.height_m, g.height_m, 1e-5);
  }
  const LocalTangentPlane plane({48.0, 11.0, 500.0});
  const Eigen::Vector3d up = plane.to_ned({48.0, 11.0, 600.0});
  EXPECT_NEAR(up.z(), -100.0, 1e-6);
  EXPECT_NEAR(up.head<2>().norm(), 0.0, 1e-6);
  const Eigen::Vector3d ned(1234.5, -678.9, -42.0);
  EXPECT_LT((plane.to_ned(plane.to_geodetic(ned)) - ned).norm(), 1e-5);
}
