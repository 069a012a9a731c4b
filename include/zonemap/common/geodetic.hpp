// WGS84 geodetic coordinates and a local tangent plane (north, east, down) about
// an origin: how an INS's latitude/longitude/height become the map's metres.
#pragma once

#include <Eigen/Core>

namespace zonemap {

struct Geodetic {
  double latitude_deg = 0.0;
  double longitude_deg = 0.0;
  double height_m = 0.0;  // above the WGS84 ellipsoid
};

Eigen::Vector3d geodetic_to_ecef(const Geodetic& point);
Geodetic ecef_to_geodetic(const Eigen::Vector3d& ecef);

// North-east-down metres about a fixed origin (exact ECEF rotation, no flat-earth
// approximation: valid for the whole flight, not only near the origin).
class LocalTangentPlane {
 public:
  LocalTangentPlane() = default;
  explicit LocalTangentPlane(const Geodetic& origin);

  bool has_origin() const { return has_origin_; }
  const Geodetic& origin() const { return origin_; }
  Eigen::Vector3d to_ned(const Geodetic& point) const;
  Geodetic to_geodetic(const Eigen::Vector3d& ned) const;

 private:
  bool has_origin_ = false;
  Geodetic origin_;
  Eigen::Vector3d origin_ecef_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d ned_R_ecef_ = Eigen::Matrix3d::Identity();
};

}  // namespace zonemap
