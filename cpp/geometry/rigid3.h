// Rigid transforms named by their frames, as COLMAP names them: `cam_from_world` maps a
// world point into the camera frame, X_cam = R X_world + t (OpenCV camera axes). Composition
// reads right to left: cam2_from_world = cam2_from_cam1 * cam1_from_world.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace mound::geometry {

struct Rigid3d {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Rigid3d() = default;
  Rigid3d(const Eigen::Quaterniond& q, const Eigen::Vector3d& t)
      : rotation(q.normalized()), translation(t) {}
  Rigid3d(const Eigen::Matrix3d& R, const Eigen::Vector3d& t)
      : rotation(Eigen::Quaterniond(R).normalized()), translation(t) {}

  Eigen::Matrix3d RotationMatrix() const { return rotation.toRotationMatrix(); }
  // The origin of the source frame's target: for cam_from_world, the camera centre in the
  // world, -R^T t.
  Eigen::Vector3d Centre() const { return -(rotation.conjugate() * translation); }
  Rigid3d Inverse() const;

  Eigen::Vector3d operator*(const Eigen::Vector3d& x) const { return rotation * x + translation; }
  Rigid3d operator*(const Rigid3d& b) const {
    return {rotation * b.rotation, rotation * b.translation + translation};
  }
};

// [v]x: the matrix of the cross product, [v]x w = v x w.
inline Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

// Angle of the rotation between a and b, radians.
double RotationAngle(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b);

// cam_from_world of a camera at `centre` looking at `target`, the image's up as close to
// north (+y) as possible (as mound.geometry.camera.Pose.look_at); looking straight along
// +-y, image x is east. InputError when the target is the centre.
Rigid3d LookAt(const Eigen::Vector3d& centre, const Eigen::Vector3d& target);

}  // namespace mound::geometry
