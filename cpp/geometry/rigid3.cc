#include "geometry/rigid3.h"

#include <Eigen/Dense>
#include <cmath>

namespace mound::geometry {

Rigid3d Rigid3d::Inverse() const {
  const Eigen::Quaterniond inv = rotation.conjugate();
  return {inv, -(inv * translation)};
}

double RotationAngle(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return a.angularDistance(b);
}

Rigid3d LookAt(const Eigen::Vector3d& c, const Eigen::Vector3d& target) {
  const Eigen::Vector3d z = (target - c).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d(0, 1, 0)).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d R;
  R.row(0) = x;
  R.row(1) = y;
  R.row(2) = z;
  return {R, -R * c};
}

}  // namespace mound::geometry
