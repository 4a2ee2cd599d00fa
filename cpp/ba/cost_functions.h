// Private to mound_ba (the only place that includes Ceres): the reprojection error of a
// world point in a camera, for Ceres' autodiff.
//
// Parameter blocks <2 residuals; 3, 3, 3>:
//   cam_from_world_rotation[0..2]  angle-axis (radians), X_cam = R X_world + t
//   cam_from_world_translation[0..2]  t (metres)
//   point[0..2]  the world point (metres)
// The camera is the project's model (geometry/camera_model.h), fixed here; the residual is
// projected minus observed pixel. As in COLMAP, a point behind the camera gives a zero
// residual instead of a meaningless one.
#pragma once

#include <ceres/autodiff_cost_function.h>
#include <ceres/rotation.h>

#include <array>

#include "geometry/camera_model.h"

namespace mound::ba {

// Projected minus observed pixel of `point` in the camera (rotation, translation) with the
// model parameters `params` (fixed doubles or refined jets); zero behind the camera.
// Shared by both cost functions.
template <typename P, typename T>
bool ProjectionResidual(const T* rotation, const T* translation, const T* point, const P* params,
                        double u_px, double v_px, T* residual) {
  T p[3];
  ceres::AngleAxisRotatePoint(rotation, point, p);
  for (int i = 0; i < 3; ++i) p[i] += translation[i];
  T u, v;
  if (!geometry::ImageFromCamera(params, p, &u, &v)) {
    residual[0] = residual[1] = T(0);
    return true;
  }
  residual[0] = u - T(u_px);
  residual[1] = v - T(v_px);
  return true;
}

class ReprojectionError {
 public:
  ReprojectionError(double u_px, double v_px, const geometry::CameraModel& camera)
      : u_(u_px), v_(v_px), params_(camera.Params()) {}

  template <typename T>
  bool operator()(const T* rotation, const T* translation, const T* point, T* residual) const {
    return ProjectionResidual(rotation, translation, point, params_.data(), u_, v_, residual);
  }

  // Ceres 2.1: the cost function takes ownership of a heap-allocated functor.
  static ceres::CostFunction* Create(double u_px, double v_px,
                                     const geometry::CameraModel& camera) {
    return new ceres::AutoDiffCostFunction<ReprojectionError, 2, 3, 3, 3>(
        new ReprojectionError(u_px, v_px, camera));
  }

 private:
  double u_, v_;
  std::array<double, geometry::CameraModel::kNumParams> params_;
};

// The same with the shared intrinsics refined (self-calibration, as COLMAP's
// SIMPLE_RADIAL): a fourth block [f, k1, k2]; fx = f, fy = f * aspect, and cx, cy, p1, p2,
// k3 held at the camera's values.
class ReprojectionErrorWithIntrinsics {
 public:
  ReprojectionErrorWithIntrinsics(double u_px, double v_px, const geometry::CameraModel& camera)
      : u_(u_px), v_(v_px), aspect_(camera.fy / camera.fx), fixed_(camera.Params()) {}

  template <typename T>
  bool operator()(const T* rotation, const T* translation, const T* point, const T* intrinsics,
                  T* residual) const {
    const T params[geometry::CameraModel::kNumParams] = {intrinsics[0], intrinsics[0] * T(aspect_),
                                                         T(fixed_[2]),  T(fixed_[3]),
                                                         intrinsics[1], intrinsics[2],
                                                         T(fixed_[6]),  T(fixed_[7]),
                                                         T(fixed_[8])};
    return ProjectionResidual(rotation, translation, point, params, u_, v_, residual);
  }

  static ceres::CostFunction* Create(double u_px, double v_px,
                                     const geometry::CameraModel& camera) {
    return new ceres::AutoDiffCostFunction<ReprojectionErrorWithIntrinsics, 2, 3, 3, 3, 3>(
        new ReprojectionErrorWithIntrinsics(u_px, v_px, camera));
  }

 private:
  double u_, v_, aspect_;
  std::array<double, geometry::CameraModel::kNumParams> fixed_;
};

// The prior on the refined intrinsics block [f, k1, k2] (bundle_adjuster.h's
// IntrinsicsPrior): three residuals, each the parameter's departure in prior sigmas.
class IntrinsicsPriorError {
 public:
  IntrinsicsPriorError(double f_px, double k1, double k2, double f_sd, double k_sd)
      : mean_{f_px, k1, k2}, sd_{f_sd * f_px, k_sd, k_sd} {}

  template <typename T>
  bool operator()(const T* intrinsics, T* residual) const {
    for (int i = 0; i < 3; ++i) residual[i] = (intrinsics[i] - T(mean_[i])) / T(sd_[i]);
    return true;
  }

  static ceres::CostFunction* Create(double f_px, double k1, double k2, double f_sd, double k_sd) {
    return new ceres::AutoDiffCostFunction<IntrinsicsPriorError, 3, 3>(
        new IntrinsicsPriorError(f_px, k1, k2, f_sd, k_sd));
  }

 private:
  std::array<double, 3> mean_, sd_;
};

}  // namespace mound::ba
