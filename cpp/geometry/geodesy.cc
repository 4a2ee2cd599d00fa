#include "geometry/geodesy.h"

#include <Eigen/Dense>
#include <cmath>

namespace mound::geometry {
namespace {

constexpr double kA = 6378137.0;            // WGS84 semi-major axis, m
constexpr double kF = 1.0 / 298.257223563;  // flattening
constexpr double kE2 = kF * (2 - kF);       // first eccentricity squared
constexpr double kB = kA * (1 - kF);
constexpr double kDeg = M_PI / 180;

Eigen::Matrix3d EnuFromEcefRotation(const Geodetic& o) {
  const double sl = std::sin(o.lat_deg * kDeg), cl = std::cos(o.lat_deg * kDeg);
  const double so = std::sin(o.lon_deg * kDeg), co = std::cos(o.lon_deg * kDeg);
  Eigen::Matrix3d R;
  R << -so, co, 0, -sl * co, -sl * so, cl, cl * co, cl * so, sl;
  return R;
}

}  // namespace

Eigen::Vector3d EcefFromGeodetic(const Geodetic& g) {
  const double lat = g.lat_deg * kDeg, lon = g.lon_deg * kDeg;
  const double N = kA / std::sqrt(1 - kE2 * std::sin(lat) * std::sin(lat));
  return {(N + g.alt_m) * std::cos(lat) * std::cos(lon),
          (N + g.alt_m) * std::cos(lat) * std::sin(lon), (N * (1 - kE2) + g.alt_m) * std::sin(lat)};
}

Geodetic GeodeticFromEcef(const Eigen::Vector3d& e) {
  const double p = std::hypot(e.x(), e.y());
  const double ep2 = (kA * kA - kB * kB) / (kB * kB);
  double lat = std::atan2(e.z(), p * (1 - kE2));
  for (int it = 0; it < 5; ++it) {  // Bowring: converges to < 1e-12 rad in 2-3 steps
    const double beta = std::atan2((1 - kF) * std::sin(lat), std::cos(lat));
    lat = std::atan2(e.z() + ep2 * kB * std::pow(std::sin(beta), 3),
                     p - kE2 * kA * std::pow(std::cos(beta), 3));
  }
  const double sl = std::sin(lat), cl = std::cos(lat);
  const double N = kA / std::sqrt(1 - kE2 * sl * sl);
  // Height stable at every latitude: the projection on the normal.
  const double h = p * cl + e.z() * sl - kA * kA / N;
  return {lat / kDeg, std::atan2(e.y(), e.x()) / kDeg, h};
}

Eigen::Vector3d EnuFromGeodetic(const Geodetic& origin, const Geodetic& g) {
  return EnuFromEcefRotation(origin) * (EcefFromGeodetic(g) - EcefFromGeodetic(origin));
}

Geodetic GeodeticFromEnu(const Geodetic& origin, const Eigen::Vector3d& enu) {
  return GeodeticFromEcef(EcefFromGeodetic(origin) + EnuFromEcefRotation(origin).transpose() * enu);
}

}  // namespace mound::geometry
