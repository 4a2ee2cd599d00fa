// The metric frame of a reconstruction: a robust similarity from its camera centres to
// the images' GPS positions (local ENU metres), full or levelled (the vertical from the
// images), and its application to the whole model.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <vector>

#include "geometry/sim3.h"
#include "sfm/reconstruction.h"

namespace mound::sfm {

struct GeoFit {
  geometry::Sim3d world_from_model;
  std::vector<bool> inlier;  // per pair given
  double rmse_m = 0;         // over the inliers
  double rmse_horizontal_m = 0, rmse_vertical_m = 0;
  int inliers = 0;
};

// Robust similarity from camera centres (model) to GPS positions (world): least median of
// squares over minimal three-point Umeyama fits, inliers within 2.5 robust sigmas (at least
// `min_threshold_m`), refitted on them. Nothing when fewer than 3 usable pairs.
// `weights` (optional, one per pair, e.g. 1 / variance of each GPS position): the refit on
// the inliers is weighted.
std::optional<GeoFit> FitSim3Robust(const std::vector<Eigen::Vector3d>& model,
                                    const std::vector<Eigen::Vector3d>& world, uint64_t seed,
                                    double min_threshold_m = 0.5,
                                    const std::vector<double>* weights = nullptr);

// The same with the vertical taken from the images instead of the GPS heights (whose
// altitude drifts on consumer receivers): the model is first rotated so that
// `down_in_model` (the cameras' mean viewing direction: straight down for a nadir raster,
// down on average for an orbit) points along -z; then scale, heading and translation are
// fitted robustly to the horizontal GPS positions (least median of squares over two-point
// fits), and the height offset is the median of the height differences. The residuals
// are reported as for FitSim3Robust.
std::optional<GeoFit> FitLevelledSim3Robust(const std::vector<Eigen::Vector3d>& model,
                                            const std::vector<Eigen::Vector3d>& world,
                                            const Eigen::Vector3d& down_in_model, uint64_t seed,
                                            double min_threshold_m = 0.5);

// Applies world_from_model to the whole reconstruction (poses stay rigid, in metres).
void Transform(const geometry::Sim3d& world_from_model, Reconstruction* r);

}  // namespace mound::sfm
