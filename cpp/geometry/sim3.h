// Similarity transforms (scale, rotation, translation): y = s R x + t, named like rigid
// ones (`enu_from_model`). Estimated from point pairs by Umeyama's closed form (Umeyama,
// "Least-squares estimation of transformation parameters between two point patterns",
// IEEE PAMI 1991), the metric frame of a reconstruction from its camera centres and GPS.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <vector>

namespace mound::geometry {

struct Sim3d {
  double scale = 1;
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Eigen::Vector3d operator*(const Eigen::Vector3d& x) const {
    return scale * (rotation * x) + translation;
  }
  // Composition reads right to left, as Rigid3d's: (a * b) * x = a * (b * x).
  Sim3d operator*(const Sim3d& b) const {
    Sim3d c;
    c.scale = scale * b.scale;
    c.rotation = rotation * b.rotation;
    c.translation = scale * (rotation * b.translation) + translation;
    return c;
  }
  Sim3d Inverse() const;
};

// The least-squares similarity dst ~ s R src + t over the pairs; nothing when fewer than
// three pairs or the source points are (nearly) collinear.
std::optional<Sim3d> EstimateSim3d(const std::vector<Eigen::Vector3d>& src,
                                   const std::vector<Eigen::Vector3d>& dst);
// The same minimising sum_i w_i |s R src_i + t - dst_i|^2 (Umeyama's closed form with
// weighted means and cross-covariance); weights > 0, finite, one per pair, else nothing.
std::optional<Sim3d> EstimateSim3d(const std::vector<Eigen::Vector3d>& src,
                                   const std::vector<Eigen::Vector3d>& dst,
                                   const std::vector<double>& weights);

}  // namespace mound::geometry
