// Aligning a reconstructed cloud to a reference cloud: iterative closest point with scale
// (Besl & McKay 1992), point-to-plane (Chen & Medioni 1992) with a scale parameter and a
// weak point-to-point term, Gauss-Newton on 7 parameters; or PCL's point-to-point ICP with
// its SVD-with-scale estimator (Umeyama 1991); robust to clutter and partial overlap, and the
// distances of the aligned cloud to the reference surface (the paper's comparison, done
// there in CloudCompare). Eigen in, Eigen out: PCL is private to this library.
//
// Robustness: correspondences farther than `median_factor` x their median distance are
// rejected in every iteration (PCL's median-distance rejector), so clutter and the parts
// one cloud has and the other lacks do not drag the fit. Speed: at most
// `max_source_points` of the cloud (a seeded random sample, as CloudCompare's "random
// sampling limit") take part in the iterations; the distances are computed for every point.
// Convergence: the iteration's step is smaller than `translation_epsilon` (as a fraction of
// the reference's extent; the scale step likewise) and `rotation_epsilon_rad`; otherwise it
// stops after `max_iterations` unconverged (PCL's variant also stops on a relative change of
// the mean squared error below `relative_mse_epsilon`).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "common/enum_names.h"
#include "geometry/sim3.h"

namespace mound::icp {

// kPointToPlane (default): written here, on PCL's k-d tree; kPclPointToPoint: PCL's
// IterativeClosestPoint with its SVD-with-scale estimator (slow on smooth terrain, where
// point-to-point ICP crawls along the surface; kept for comparison).
enum class Method { kPointToPlane, kPclPointToPoint };
// kNone: the clouds share a frame (both georeferenced); kPca: principal axes with their
// ambiguities (24 starts) tried by a coarse ICP each; kAuto: none when the cloud's
// centroid lies within the reference's extent (RMS radius) and its own extent is 0.1-2x
// the reference's (a flight covers part of a reference site), else pca.
enum class Init { kAuto, kNone, kPca };

// Their names in flags and files (NameOf, FromName of common/enum_names.h).
inline constexpr EnumName<Method> kMethodNames[] = {
    {Method::kPointToPlane, "point_to_plane"}, {Method::kPclPointToPoint, "pcl_point_to_point"}};
inline constexpr EnumName<Init> kInitNames[] = {
    {Init::kAuto, "auto"}, {Init::kNone, "none"}, {Init::kPca, "pca"}};

struct Options {
  bool estimate_scale = true;
  Method method = Method::kPointToPlane;
  Init init = Init::kAuto;
  int max_iterations = 100;
  double median_factor = 3.0;
  // Steps below these move the cloud by less than 1e-4 of its extent: below the sampling's
  // nearest-neighbour jitter.
  double translation_epsilon = 1e-4;  // of the reference's extent (the scale step likewise)
  double rotation_epsilon_rad = 1e-4;
  double relative_mse_epsilon = 1e-9;
  int max_source_points = 20000;
  // With init none (a shared, georeferenced frame): a fitted scale further than this from
  // 1 is not believed, and the fit is redone rigid (Result::scale_fixed).
  double max_scale_change = 0.1;
  // ...and a fit that moves the cloud's centre by more than this fraction of its extent
  // (RMS radius), or turns it by more than max_rotation_rad, is rejected: the georeferenced
  // frame is kept as it is (Result::frame_kept).
  double max_shift_fraction = 0.1;
  double max_rotation_rad = 0.17;  // 10 degrees
  uint64_t seed = 1;

  // InputError naming the field ("icp.max_iterations: ...") when a value is out of range.
  void Check() const;
};

struct Result {
  geometry::Sim3d reference_from_cloud;
  Init init_used = Init::kNone;  // kNone or kPca
  int iterations = 0;            // of the final ICP on the full sample
  int coarse_iterations = 0;     // of the 2,000-point ICPs before it (all starts)
  bool scale_fixed = false;      // the fit with scale left max_scale_change: redone rigid
  bool frame_kept = false;       // the fit moved too far: the input frame kept, no alignment
  bool converged = false;
  double rmse_m = 0;           // point-to-point, over the inliers of the last iteration
  double inlier_fraction = 0;  // of the sampled cloud points
};

// Throws InputError for clouds with fewer than 10 points or options that fail Check(),
// NoResultError when the clouds do
// not overlap (no correspondences survive) or the fit degenerates.
Result Align(const std::vector<Eigen::Vector3d>& cloud,
             const std::vector<Eigen::Vector3d>& reference, const Options& options);

// Unsigned distance of each point to the reference surface: to the least-squares plane of
// its 6 nearest reference points (CloudCompare's local-model distance), but never less than
// the distance to the nearest reference point minus that neighbourhood's radius (points
// beyond the reference's edge).
std::vector<double> SurfaceDistances(const std::vector<Eigen::Vector3d>& points,
                                     const std::vector<Eigen::Vector3d>& reference);

}  // namespace mound::icp
