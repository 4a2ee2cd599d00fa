// Bundle adjustment: all camera poses and points refined together by Levenberg-Marquardt
// (Ceres, sparse Schur complement, points eliminated first) on the Huber-robustified
// reprojection error. Eigen in, Eigen out: Ceres is private to this library
// (cost_functions.h is its private header).
//
// Gauge: the first view (`fixed_view`) is held fixed, which removes rotation and
// translation; the scale is fixed by keeping the length of `scale_view`'s translation
// (a sphere manifold on it), so with the fixed view at the origin the baseline keeps
// its length. Intrinsics are fixed (calibrated camera) unless `refine_intrinsics`, which
// refines the shared focal length and k1, k2 (self-calibration from EXIF's starting values),
// optionally held by a Gaussian prior about the camera's values (`IntrinsicsPrior`).
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "geometry/camera_model.h"
#include "geometry/rigid3.h"

namespace mound::ba {

struct Observation {
  int view = 0;
  int point = 0;
  Eigen::Vector2d px = Eigen::Vector2d::Zero();  // observed (distorted) pixel
};

struct Problem {
  geometry::CameraModel camera;
  std::vector<geometry::Rigid3d> cam_from_world;  // one per view
  std::vector<Eigen::Vector3d> points;            // in the world frame
  std::vector<Observation> observations;
};

// A prior on the refined intrinsics, as OpenSfM's bundle adjustment has (its focal and
// radial-distortion standard deviations): three residuals (f - f0) / (f_sd f0),
// (k1 - k1_0) / k_sd, (k2 - k2_0) / k_sd beside the reprojection errors (pixels, so one
// prior sigma weighs as a one-pixel error). Directions the images determine are decided by
// thousands of observations; one they barely see stays at the prior. Over flat ground seen
// only from above, k1 and f trade against a bend of the whole model (the "doming" of nadir
// blocks): without a prior, noise decides the bend.
struct IntrinsicsPrior {
  double f_px = 0, k1 = 0, k2 = 0;  // the prior's mean (EXIF's focal length, no distortion)
  double f_sd = 0.01;               // relative standard deviation of the focal length
  double k_sd = 0.01;               // standard deviation of k1 and of k2
};

struct Options {
  double huber_px = 1.0;
  int max_iterations = 100;
  int fixed_view = 0;  // -1: none (the gauge comes from `constant_views`)
  int scale_view = 1;  // -1: no scale constraint (e.g. a view with known position fixed)
  // Views held constant besides `fixed_view`: a local adjustment around a new image keeps
  // the rest of the model where it is (two or more of them fix the gauge).
  std::vector<int> constant_views;
  int threads = 1;
  bool refine_intrinsics = false;  // f (fy / fx kept), k1, k2 of the shared camera
  // With refine_intrinsics: held about these values (none: free, as COLMAP's self-calibration).
  std::optional<IntrinsicsPrior> intrinsics_prior;
  double max_time_s = 1e9;
  // Stops when the cost changes by less than this fraction in an iteration (Ceres'
  // function_tolerance); the mapper's adjustments on the way use 1e-6.
  double function_tolerance = 1e-10;
};

struct Summary {
  double initial_rmse_px = 0, final_rmse_px = 0;
  int iterations = 0;
  bool converged = false;
  std::string brief;  // Ceres' one-line report
};

// Paper: bundle adjustment. Refines `problem` in place. An observation or gauge index out of range
// is a caller's bug (InternalError).
Summary Adjust(Problem* problem, const Options& options);

// Root-mean-square reprojection error of all observations (pixels); a point behind its
// camera contributes nothing (as in the adjustment).
double RmseReprojection(const Problem& problem);

}  // namespace mound::ba
