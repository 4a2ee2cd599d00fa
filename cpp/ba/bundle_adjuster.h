// Bundle adjustment: all camera poses and points refined together by Levenberg-Marquardt
// (Ceres, sparse Schur complement, points eliminated first) on the Huber-robustified
// reprojection error.
//
// Gauge: the first view (`fixed_view`) is held fixed, which removes rotation and
// translation; the scale is fixed by keeping the length of `scale_view`'s translation
// (a sphere manifold on it), so with the fixed view at the origin the baseline keeps
// its length. Intrinsics are fixed (calibrated camera).
#pragma once

#include <array>
#include <string>
#include <vector>

#include "ba/cost_functions.h"

namespace mound::ba {

struct View {
  std::array<double, 3> rotation{};     // angle-axis of cam_from_world
  std::array<double, 3> translation{};  // t of cam_from_world
};

struct Observation {
  int view = 0;
  int point = 0;
  double u_px = 0, v_px = 0;  // observed (distorted) pixel
};

struct Problem {
  PinholeRadial camera;
  std::vector<View> views;
  std::vector<std::array<double, 3>> points;
  std::vector<Observation> observations;
};

struct Options {
  double huber_px = 1.0;
  int max_iterations = 100;
  int fixed_view = 0;
  int scale_view = 1;  // -1: no scale constraint (e.g. a view with known position fixed)
  int threads = 1;
};

struct Summary {
  double initial_rmse_px = 0, final_rmse_px = 0;
  int iterations = 0;
  bool converged = false;
  std::string brief;  // Ceres' one-line report
};

// Refines `problem` in place. Throws InputError for indices out of range.
Summary Adjust(Problem* problem, const Options& options);

// Root-mean-square reprojection error of all observations (pixels).
double RmseReprojection(const Problem& problem);

}  // namespace mound::ba
