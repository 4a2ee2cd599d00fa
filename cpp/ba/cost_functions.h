// Reprojection error of a world point in a camera, for Ceres (autodiff).
//
// Parameter blocks <2 residuals; 3, 3, 3>:
//   cam_from_world_rotation[0..2]  angle-axis (radians), X_cam = R X_world + t
//   cam_from_world_translation[0..2]  t (metres)
//   point[0..2]  the world point (metres)
// The camera model is OpenCV's pinhole with k1 k2 p1 p2 k3 (fixed here); the residual is
// projected minus observed pixel. As in COLMAP, a point behind the camera gives a zero
// residual instead of a meaningless one.
#pragma once

#include <ceres/autodiff_cost_function.h>
#include <ceres/rotation.h>

#include <array>

namespace mound::ba {

struct PinholeRadial {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::array<double, 5> dist{};  // k1 k2 p1 p2 k3
};

class ReprojectionError {
 public:
  ReprojectionError(double u_px, double v_px, const PinholeRadial& camera)
      : u_(u_px), v_(v_px), cam_(camera) {}

  template <typename T>
  bool operator()(const T* rotation, const T* translation, const T* point, T* residual) const {
    T p[3];
    ceres::AngleAxisRotatePoint(rotation, point, p);
    for (int i = 0; i < 3; ++i) p[i] += translation[i];
    if (p[2] <= T(0)) {
      residual[0] = residual[1] = T(0);
      return true;
    }
    const T x = p[0] / p[2], y = p[1] / p[2];
    const T r2 = x * x + y * y;
    const double k1 = cam_.dist[0], k2 = cam_.dist[1], p1 = cam_.dist[2], p2 = cam_.dist[3],
                 k3 = cam_.dist[4];
    const T radial = T(1) + r2 * (T(k1) + r2 * (T(k2) + r2 * T(k3)));
    const T xd = x * radial + T(2 * p1) * x * y + T(p2) * (r2 + T(2) * x * x);
    const T yd = y * radial + T(p1) * (r2 + T(2) * y * y) + T(2 * p2) * x * y;
    residual[0] = T(cam_.fx) * xd + T(cam_.cx) - T(u_);
    residual[1] = T(cam_.fy) * yd + T(cam_.cy) - T(v_);
    return true;
  }

  // Ceres 2.1: the cost function takes ownership of a heap-allocated functor.
  static ceres::CostFunction* Create(double u_px, double v_px, const PinholeRadial& camera) {
    return new ceres::AutoDiffCostFunction<ReprojectionError, 2, 3, 3, 3>(
        new ReprojectionError(u_px, v_px, camera));
  }

 private:
  double u_, v_;
  PinholeRadial cam_;
};

}  // namespace mound::ba
