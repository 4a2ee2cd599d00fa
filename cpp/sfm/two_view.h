// Two-view initialisation of the reconstruction: feature matches between two images, the
// relative pose from the 8-point algorithm, and the depths of the matched points from the
// stacked epipolar system, solved by its singular value decomposition.
//
// Frames: OpenCV camera frames (x right, y down, z forward); the pose is cam2_from_cam1,
// X2 = R X1 + t, with |t| = 1 (two views fix the scene only up to scale). The camera is the
// project's model (geometry/camera_model.h), calibrated.
//
// Depths, the paper's eqs. (9)-(11) (Ma, Soatto, Kosecka & Sastry, "An Invitation to 3-D Vision",
// 2004, sec. 5.2): for each point j with normalised image coordinates x1_j, x2_j (homogeneous),
//   lambda2_j x2_j = lambda1_j R x1_j + gamma t,
// and multiplying by the skew matrix of x2_j removes lambda2_j:
//   [x2_j]x R x1_j lambda1_j + [x2_j]x t gamma = 0.
// Stacking all points gives M v = 0 with v = (lambda1_1 .. lambda1_n, gamma), M of size
// 3n x (n+1); the least-squares solution is the right singular vector of M for its
// smallest singular value, i.e. the eigenvector of M^T M for its smallest eigenvalue.
// M^T M is an arrowhead matrix (diagonal plus a last row and column), so that eigenvector
// is found exactly from the secular equation in O(n) per iteration instead of an O(n^3)
// dense SVD; the tests check it against Eigen's dense SVD of M.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "geometry/camera_model.h"
#include "geometry/rigid3.h"

namespace mound::sfm {

// An 8-bit grey image, row-major.
struct GreyImage {
  int width = 0, height = 0;
  std::vector<uint8_t> pixels;
};

GreyImage LoadGrey(const std::string& path);  // InputError if unreadable

struct Matches {
  std::vector<Eigen::Vector2d> px1, px2;  // pixel coordinates (distorted, as observed)
};

// SIFT features (up to max_features per image; features.h, its bias corrected), matched
// as MatchDescriptors does (ratio test 0.8, mutual).
Matches MatchFeatures(const GreyImage& a, const GreyImage& b, int max_features = 4000);

// Eq. (11): depths lambda1 (and gamma) of the stacked epipolar system for a given pose; `x1`, `x2`
// normalised homogeneous coordinates. Returns v = (lambda1_1..n, gamma) with unit norm
// and gamma >= 0; points with x2 parallel to R x1 (no parallax) get depth 0.
Eigen::VectorXd StackedEpipolarDepths(const std::vector<Eigen::Vector3d>& x1,
                                      const std::vector<Eigen::Vector3d>& x2,
                                      const Eigen::Matrix3d& R, const Eigen::Vector3d& t);

struct TwoViewResult {
  geometry::Rigid3d cam2_from_cam1;  // translation of unit length
  std::vector<int> inliers;          // indices into the matches
  std::vector<double> depth1;        // per inlier: depth in camera 1, in units of |t|
  std::vector<double> depth2;        // per inlier: depth in camera 2
  int matches = 0;
  int positive_depth = 0;  // inliers in front of both cameras
};

// Paper: the 8-point initialisation. RANSAC (fundamental matrix, 1 px) selects the
// inliers, the 8-point algorithm on all of
// them gives F, E = K^T F K projected onto the essential matrices; of its four
// decompositions the one that puts the most points in front of both cameras wins; the
// depths come from the stacked epipolar system. Fewer than 8 matches or inliers, or no
// pose with points in front of both cameras, is a degenerate scene (NoResultError); px1 and
// px2 of different lengths a caller's bug (InternalError).
TwoViewResult InitialiseTwoView(const Matches& m, const geometry::CameraModel& camera,
                                double ransac_px = 1.0, uint64_t seed = 1);

// Two-view bundle adjustment of an initialisation (cpp/ba: camera 1 fixed, |t| kept):
// refines R, t and the inlier depths in place; returns the RMS reprojection error
// before and after (pixels).
std::pair<double, double> RefineTwoView(const Matches& m, const geometry::CameraModel& camera,
                                        TwoViewResult* r);

// Normalised homogeneous coordinates of pixels (undistorted, K removed).
std::vector<Eigen::Vector3d> Normalise(const std::vector<Eigen::Vector2d>& px,
                                       const geometry::CameraModel& camera);

}  // namespace mound::sfm
