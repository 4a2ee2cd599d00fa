// The project's one camera model: a pinhole with OpenCV's distortion (k1 k2 p1 p2 k3),
// OpenCV camera axes (x right, y down, z forward) and pixel (0, 0) at the centre of the
// top-left pixel. Used by the renderer (cpp/sim), bundle adjustment (cpp/ba, through the
// templated projection below, which Ceres' autodiff evaluates with Jets) and the
// reconstruction (cpp/sfm); mound.geometry.camera is its Python twin.
//
// Parameters, in this order wherever they travel as an array (kNumParams):
//   fx fy cx cy (pixels), k1 k2 p1 p2 k3 (OpenCV's distortion of normalised coordinates).
#pragma once

#include <Eigen/Core>
#include <array>

namespace mound::geometry {

// Distorts normalised image coordinates (x, y) = (X/Z, Y/Z) with `dist` = k1 k2 p1 p2 k3:
//   r^2 = x^2 + y^2, radial = 1 + k1 r^2 + k2 r^4 + k3 r^6,
//   xd = x radial + 2 p1 x y + p2 (r^2 + 2 x^2),  yd = y radial + p1 (r^2 + 2 y^2) + 2 p2 x y.
// T is double or a Ceres Jet; P the parameters' type (double for fixed intrinsics, T when
// they are refined).
template <typename P, typename T>
void DistortNormalised(const P* dist, const T& x, const T& y, T* xd, T* yd) {
  const P &k1 = dist[0], &k2 = dist[1], &p1 = dist[2], &p2 = dist[3], &k3 = dist[4];
  const T r2 = x * x + y * y;
  const T radial = T(1) + r2 * (k1 + r2 * (k2 + r2 * k3));
  *xd = x * radial + P(2) * p1 * x * y + p2 * (r2 + T(2) * x * x);
  *yd = y * radial + p1 * (r2 + T(2) * y * y) + P(2) * p2 * x * y;
}

// Pixel of the normalised coordinates (x, y) for `params` = fx fy cx cy k1 k2 p1 p2 k3.
template <typename P, typename T>
void ImageFromNormalised(const P* params, const T& x, const T& y, T* u, T* v) {
  T xd, yd;
  DistortNormalised(params + 4, x, y, &xd, &yd);
  *u = params[0] * xd + params[2];
  *v = params[1] * yd + params[3];
}

// Pixel of a point in the camera frame; false (and no pixel) when it is not in front.
template <typename P, typename T>
bool ImageFromCamera(const P* params, const T* point_in_cam, T* u, T* v) {
  if (!(point_in_cam[2] > T(0))) return false;
  ImageFromNormalised(params, point_in_cam[0] / point_in_cam[2], point_in_cam[1] / point_in_cam[2],
                      u, v);
  return true;
}

struct CameraModel {
  static constexpr int kNumParams = 9;

  int width = 0, height = 0;  // pixels
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::array<double, 5> dist{};  // k1 k2 p1 p2 k3

  std::array<double, kNumParams> Params() const {
    return {fx, fy, cx, cy, dist[0], dist[1], dist[2], dist[3], dist[4]};
  }
  static CameraModel FromParams(const double* params, int width, int height);
  Eigen::Matrix3d K() const;
  bool HasDistortion() const;

  // Normalised coordinates -> pixel (with distortion).
  Eigen::Vector2d ImageFromNormalised(const Eigen::Vector2d& xy) const;
  // Pixel -> normalised coordinates (distortion removed by Newton iterations).
  Eigen::Vector2d NormalisedFromImage(const Eigen::Vector2d& uv) const;
  // Point in the camera frame -> pixel; false when it is not in front of the camera.
  bool ImageFromCamera(const Eigen::Vector3d& point_in_cam, Eigen::Vector2d* uv) const;
};

}  // namespace mound::geometry
