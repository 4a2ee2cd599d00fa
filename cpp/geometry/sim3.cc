#include "geometry/sim3.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace mound::geometry {

Sim3d Sim3d::Inverse() const {
  const Eigen::Quaterniond inv = rotation.conjugate();
  return {1 / scale, inv, -(inv * translation) / scale};
}

std::optional<Sim3d> EstimateSim3d(const std::vector<Eigen::Vector3d>& src,
                                   const std::vector<Eigen::Vector3d>& dst) {
  const size_t n = std::min(src.size(), dst.size());
  if (n < 3) return std::nullopt;
  Eigen::Matrix3Xd a(3, n), b(3, n);
  for (size_t i = 0; i < n; ++i) {
    a.col(static_cast<Eigen::Index>(i)) = src[i];
    b.col(static_cast<Eigen::Index>(i)) = dst[i];
  }
  const Eigen::Vector3d ma = a.rowwise().mean();
  const Eigen::Matrix3Xd ac = a.colwise() - ma;
  // Collinear (or coincident) sources leave a rotation about their line undetermined.
  Eigen::JacobiSVD<Eigen::Matrix3d> spread(ac * ac.transpose());
  const Eigen::Vector3d sv = spread.singularValues();
  if (!(sv[0] > 0) || sv[1] < 1e-12 * sv[0]) return std::nullopt;
  const Eigen::Matrix4d T = Eigen::umeyama(a, b, true);
  if (!T.allFinite()) return std::nullopt;
  Sim3d s;
  const Eigen::Matrix3d sR = T.topLeftCorner<3, 3>();
  s.scale = std::cbrt(sR.determinant());
  if (!(s.scale > 0)) return std::nullopt;
  s.rotation = Eigen::Quaterniond(sR / s.scale).normalized();
  s.translation = T.topRightCorner<3, 1>();
  return s;
}

std::optional<Sim3d> EstimateSim3d(const std::vector<Eigen::Vector3d>& src,
                                   const std::vector<Eigen::Vector3d>& dst,
                                   const std::vector<double>& weights) {
  const size_t n = std::min(src.size(), dst.size());
  if (n < 3 || weights.size() != n) return std::nullopt;
  double total = 0;
  Eigen::Vector3d ma = Eigen::Vector3d::Zero(), mb = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < n; ++i) {
    if (!(weights[i] > 0) || !std::isfinite(weights[i])) return std::nullopt;
    total += weights[i];
    ma += weights[i] * src[i];
    mb += weights[i] * dst[i];
  }
  ma /= total;
  mb /= total;
  Eigen::Matrix3d spread = Eigen::Matrix3d::Zero(), cross = Eigen::Matrix3d::Zero();
  double var_a = 0;
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d a = src[i] - ma, b = dst[i] - mb;
    spread += weights[i] * a * a.transpose();
    cross += weights[i] * b * a.transpose();
    var_a += weights[i] * a.squaredNorm();
  }
  const Eigen::Vector3d sv = Eigen::JacobiSVD<Eigen::Matrix3d>(spread).singularValues();
  if (!(sv[0] > 0) || sv[1] < 1e-12 * sv[0]) return std::nullopt;  // collinear sources
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(cross / total, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) S(2, 2) = -1;
  const Eigen::Matrix3d R = svd.matrixU() * S * svd.matrixV().transpose();
  Sim3d s;
  s.scale = (svd.singularValues().asDiagonal() * S).trace() / (var_a / total);
  if (!(s.scale > 0) || !std::isfinite(s.scale)) return std::nullopt;
  s.rotation = Eigen::Quaterniond(R).normalized();
  s.translation = mb - s.scale * (R * ma);
  return s;
}

}  // namespace mound::geometry
