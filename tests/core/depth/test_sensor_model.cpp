// Paper eq. (1), (4), (5) checked against values worked out by hand.
#include <gtest/gtest.h>

#include "zonemap/common/camera.hpp"
#include "zonemap/depth/sensor_model.hpp"

namespace zonemap {
namespace {

TEST(SensorModel, RangeResolutionIsEquationOne) {
  CameraModel camera;
  camera.fx = 669.0;
  camera.baseline_m = 0.30;
  camera.match_sigma_px = 0.25;
  // Δd = d² σ / (b f) = 400 * 0.25 / (0.3 * 669) = 0.498256...
  EXPECT_NEAR(range_resolution(camera, 20.0), 0.4982561, 1e-6);
  // Quadratic in d: four times the error at twice the distance.
  EXPECT_NEAR(range_resolution(camera, 40.0), 4.0 * range_resolution(camera, 20.0), 1e-9);
  // The paper's camera at its d_max of 50 m: about 3.1 m.
  EXPECT_NEAR(range_resolution(camera, 50.0), 3.1141, 1e-3);
}

TEST(SensorModel, FreeBeforeTheObstacleIsEquationFour) {
  const float d = 20.0f;
  const float dd = 0.5f;
  EXPECT_EQ(sensor_model_value(8.0f, d, dd), -1.0f);
  EXPECT_EQ(sensor_model_value(18.99f, d, dd), -1.0f);  // just before d - 2Δd = 19
}

TEST(SensorModel, TransitionIsEquationFive) {
  const float d = 20.0f;
  const float dd = 0.5f;
  EXPECT_FLOAT_EQ(sensor_model_value(19.0f, d, dd), -1.0f);   // 1 - 1.0/0.5
  EXPECT_FLOAT_EQ(sensor_model_value(19.25f, d, dd), -0.5f);  // 1 - 0.75/0.5
  EXPECT_FLOAT_EQ(sensor_model_value(19.5f, d, dd), 0.0f);    // 1 - 0.5/0.5
  EXPECT_FLOAT_EQ(sensor_model_value(19.75f, d, dd), 0.5f);
  EXPECT_FLOAT_EQ(sensor_model_value(20.0f, d, dd), 1.0f);  // the peak at d
  EXPECT_FLOAT_EQ(sensor_model_value(20.25f, d, dd), 0.5f);
  EXPECT_NEAR(sensor_model_value(20.4f, d, dd), 0.2f, 1e-5f);
}

TEST(SensorModel, NoInfluenceBehindTheObstacle) {
  EXPECT_EQ(sensor_model_value(20.5f, 20.0f, 0.5f), 0.0f);  // δ = d + Δd
  EXPECT_EQ(sensor_model_value(30.0f, 20.0f, 0.5f), 0.0f);
}

TEST(SensorModel, CellValueIsTheLargestAlongTheRaySegment) {
  RayProfile ray;
  ray.depth = 20.0f;
  ray.range_resolution = 0.5f;
  // The segment holds the peak: 1.
  EXPECT_FLOAT_EQ(max_value_in_interval(ray, 19.8f, 20.3f), 1.0f);
  // Before the peak the largest value is at the far end.
  EXPECT_FLOAT_EQ(max_value_in_interval(ray, 19.0f, 19.75f), 0.5f);
  // After it, at the near end.
  EXPECT_FLOAT_EQ(max_value_in_interval(ray, 20.25f, 20.5f), 0.5f);
  // Entirely in the free part.
  EXPECT_FLOAT_EQ(max_value_in_interval(ray, 10.0f, 11.0f), -1.0f);
  ray.free_only = true;
  EXPECT_FLOAT_EQ(max_value_in_interval(ray, 19.8f, 20.3f), -1.0f);
}

}  // namespace
}  // namespace zonemap
