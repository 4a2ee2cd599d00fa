#include "geometry/camera_model.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace mound::geometry {

CameraModel CameraModel::FromParams(const double* p, int width, int height) {
  CameraModel c;
  c.width = width;
  c.height = height;
  c.fx = p[0];
  c.fy = p[1];
  c.cx = p[2];
  c.cy = p[3];
  std::copy(p + 4, p + kNumParams, c.dist.begin());
  return c;
}

Eigen::Matrix3d CameraModel::K() const {
  Eigen::Matrix3d K;
  K << fx, 0, cx, 0, fy, cy, 0, 0, 1;
  return K;
}

bool CameraModel::HasDistortion() const {
  return std::any_of(dist.begin(), dist.end(), [](double d) { return d != 0; });
}

Eigen::Vector2d CameraModel::ImageFromNormalised(const Eigen::Vector2d& xy) const {
  const std::array<double, kNumParams> p = Params();
  Eigen::Vector2d uv;
  geometry::ImageFromNormalised(p.data(), xy.x(), xy.y(), &uv.x(), &uv.y());
  return uv;
}

bool CameraModel::ImageFromCamera(const Eigen::Vector3d& X, Eigen::Vector2d* uv) const {
  const std::array<double, kNumParams> p = Params();
  return geometry::ImageFromCamera(p.data(), X.data(), &uv->x(), &uv->y());
}

Eigen::Vector2d CameraModel::NormalisedFromImage(const Eigen::Vector2d& uv) const {
  const Eigen::Vector2d target((uv.x() - cx) / fx, (uv.y() - cy) / fy);
  Eigen::Vector2d xy = target;
  if (!HasDistortion()) return xy;
  // Newton on D(xy) = target, the Jacobian by central differences (the map is smooth and
  // 2-D, so this is cheap and exact enough: converges to 1e-12 within a few steps).
  for (int it = 0; it < 20; ++it) {
    auto D = [&](const Eigen::Vector2d& q) {
      Eigen::Vector2d d;
      DistortNormalised(dist.data(), q.x(), q.y(), &d.x(), &d.y());
      return d;
    };
    const Eigen::Vector2d r = D(xy) - target;
    if (r.squaredNorm() < 1e-24) break;
    const double h = 1e-7;
    Eigen::Matrix2d J;
    J.col(0) = (D(xy + Eigen::Vector2d(h, 0)) - D(xy - Eigen::Vector2d(h, 0))) / (2 * h);
    J.col(1) = (D(xy + Eigen::Vector2d(0, h)) - D(xy - Eigen::Vector2d(0, h))) / (2 * h);
    xy -= J.partialPivLu().solve(r);
  }
  return xy;
}

}  // namespace mound::geometry
