#include "zonemap/common/geodetic.hpp"

#include <cmath>

namespace zonemap {
namespace {

constexpr double kSemiMajorM = 6378137.0;            // WGS84 a
constexpr double kFlattening = 1.0 / 298.257223563;  // WGS84 f
constexpr double kE2 = kFlattening * (2.0 - kFlattening);
constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

}  // namespace

Eigen::Vector3d geodetic_to_ecef(const Geodetic& point) {
  const double lat = point.latitude_deg * kDegToRad;
  const double lon = point.longitude_deg * kDegToRad;
  const double sin_lat = std::sin(lat);
  const double n = kSemiMajorM / std::sqrt(1.0 - kE2 * sin_lat * sin_lat);
  const double r = (n + point.height_m) * std::cos(lat);
  return {r * std::cos(lon), r * std::sin(lon), (n * (1.0 - kE2) + point.height_m) * sin_lat};
}

Geodetic ecef_to_geodetic(const Eigen::Vector3d& ecef) {
  // Fixed-point iteration on latitude: converges to < 1e-9 m in a few steps at
  // any flight height (bounded: 8 steps).
  const double p = std::hypot(ecef.x(), ecef.y());
  double lat = std::atan2(ecef.z(), p * (1.0 - kE2));
  double height = 0.0;
  for (int i = 0; i < 8; ++i) {
    const double sin_lat = std::sin(lat);
    const double n = kSemiMajorM / std::sqrt(1.0 - kE2 * sin_lat * sin_lat);
    height = p / std::cos(lat) - n;
    lat = std::atan2(ecef.z(), p * (1.0 - kE2 * n / (n + height)));
  }
  return {lat / kDegToRad, std::atan2(ecef.y(), ecef.x()) / kDegToRad, height};
}

LocalTangentPlane::LocalTangentPlane(const Geodetic& origin)
    : has_origin_(true), origin_(origin), origin_ecef_(geodetic_to_ecef(origin)) {
  const double lat = origin.latitude_deg * kDegToRad;
  const double lon = origin.longitude_deg * kDegToRad;
  const double sl = std::sin(lat), cl = std::cos(lat), so = std::sin(lon), co = std::cos(lon);
  ned_R_ecef_ << -sl * co, -sl * so, cl,  //
      -so, co, 0.0,                       //
      -cl * co, -cl * so, -sl;
}

Eigen::Vector3d LocalTangentPlane::to_ned(const Geodetic& point) const {
  return ned_R_ecef_ * (geodetic_to_ecef(point) - origin_ecef_);
}

Geodetic LocalTangentPlane::to_geodetic(const Eigen::Vector3d& ned) const {
  return ecef_to_geodetic(origin_ecef_ + ned_R_ecef_.transpose() * ned);
}

}  // namespace zonemap
