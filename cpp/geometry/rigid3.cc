#include "geometry/rigid3.h"

#include <Eigen/Dense>
#include <cmath>

#include "common/error.h"

namespace mound::geometry {

Rigid3d Rigid3d::Inverse() const {
  const Eigen::Quaterniond inv = rotation.conjugate();
  return {inv, -(inv * translation)};
}

double RotationAngle(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return a.angularDistance(b);
}

Rigid3d LookAt(const Eigen::Vector3d& c, const Eigen::Vector3d& target) {
  if ((target - c).norm() == 0) throw InputError("pose: target equals the camera centre");
  const Eigen::Vector3d z = (target - c).normalized();
  Eigen::Vector3d x = z.cross(Eigen::Vector3d(0, 1, 0));
  if (x.norm() < 1e-9) {
    // Looking along north: image x is east, made orthogonal to the axis (as the Python
    // twin, mound.geometry.camera.Pose.look_at).
    const Eigen::Vector3d east =
        std::abs(z.x()) < 0.9 ? Eigen::Vector3d(1, 0, 0) : Eigen::Vector3d(0, 1, 0);
    x = east - z * z.dot(east);
  }
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d R;
  R.row(0) = x;
  R.row(1) = y;
  R.row(2) = z;
  return {R, -R * c};
}

}  // namespace mound::geometry
