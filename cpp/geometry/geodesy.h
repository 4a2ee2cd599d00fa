// WGS84 geodesy: geodetic (latitude, longitude in degrees, height in metres above the
// ellipsoid) <-> ECEF <-> local ENU (east, north, up metres at an origin), as
// python/mound/geometry/geodesy.py (checked there against PROJ).
#pragma once

#include <Eigen/Core>

namespace mound::geometry {

struct Geodetic {
  double lat_deg = 0, lon_deg = 0, alt_m = 0;
};

Eigen::Vector3d EcefFromGeodetic(const Geodetic& g);
Geodetic GeodeticFromEcef(const Eigen::Vector3d& ecef);  // Bowring iterations
// enu_from_ecef at `origin`, applied to a geodetic point.
Eigen::Vector3d EnuFromGeodetic(const Geodetic& origin, const Geodetic& g);
Geodetic GeodeticFromEnu(const Geodetic& origin, const Eigen::Vector3d& enu);

}  // namespace mound::geometry
