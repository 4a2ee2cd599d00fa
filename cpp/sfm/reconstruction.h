// Incremental structure from motion (after COLMAP's incremental mapper, Schoenberger &
// Frahm, CVPR 2016), on the project's two-view initialisation and bundle adjuster:
//   tracks from the verified matches (union-find); an initial pair with many inliers and
//   parallax (pairs a homography explains are passed over), initialised by the 8-point
//   algorithm with the stacked-epipolar depths, eqs. (9)-(11), and two-view BA; then the
//   next image with the most triangulated tracks registered by PnP + RANSAC, its new tracks
//   triangulated (two-view DLT of the widest pair of rays, minimum angle, reprojection check
//   in every registered view), a local bundle adjustment around each new image, one of the
//   whole model as it grows by 60 %, outlier observations filtered; at the end a last triangulation
//   pass and adjustment.
// Frames: OpenCV camera axes, cam_from_world; the model's frame is the first image's camera
// and its scale the initial baseline (1), until Georegister maps it onto GPS positions.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "geometry/camera_model.h"
#include "geometry/rigid3.h"
#include "geometry/sim3.h"
#include "sfm/features.h"

namespace mound::sfm {

struct TrackElement {
  int image = 0, keypoint = 0;
};

struct Point3D {
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  std::array<uint8_t, 3> color{};
  std::vector<TrackElement> track;  // registered observations
  double error_px = 0;              // mean reprojection error
};

struct Reconstruction {
  geometry::CameraModel camera;
  std::vector<bool> registered;
  std::vector<geometry::Rigid3d> cam_from_world;
  std::vector<double> image_error_px;  // mean reprojection error per registered image
  std::vector<int> image_points;       // observations per image
  std::vector<Point3D> points;
  double rmse_px = 0;
  int init_image1 = -1, init_image2 = -1;
  int ba_runs = 0, local_ba_runs = 0;
  // Seconds per mapping stage: initialisation, PnP registration, triangulation, local and
  // global bundle adjustment (with their outlier filtering).
  struct Timings {
    double initialise_s = 0, register_s = 0, triangulate_s = 0, local_ba_s = 0, global_ba_s = 0;
  } timings;
  int NumRegistered() const;
};

struct MapperOptions {
  int min_inliers = 30;       // a pair below this is not used
  double max_error_px = 4.0;  // PnP RANSAC and triangulation/filtering threshold
  double min_tri_angle_deg = 1.5;
  int min_pnp_inliers = 15;
  // After each registration: the new image and the `local_ba_images` images that share
  // the most points with it are adjusted with those points, the rest of the model held
  // (COLMAP's local BA, 6 images); the whole model is adjusted when it has grown by
  // `global_ba_growth` since the last global adjustment.
  int local_ba_images = 6;
  int local_ba_iterations = 25;
  double global_ba_growth = 1.6;
  bool refine_intrinsics = false;  // f, k1, k2 in bundle adjustment (EXIF intrinsics)
  int threads = 1;
  uint64_t seed = 1;
};

// Union-find over (image, keypoint) of the verified matches; tracks that would see one
// image twice are dropped.
std::vector<std::vector<TrackElement>> BuildTracks(const std::vector<VerifiedPair>& pairs,
                                                   const std::vector<int>& keypoints_per_image);

// Throws NoResultError when no initial pair has enough matches and parallax.
Reconstruction IncrementalMap(const std::vector<ImageFeatures>& features,
                              const std::vector<VerifiedPair>& pairs,
                              const geometry::CameraModel& camera, const MapperOptions& options);

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
std::optional<GeoFit> FitSim3Robust(const std::vector<Eigen::Vector3d>& model,
                                    const std::vector<Eigen::Vector3d>& world, uint64_t seed,
                                    double min_threshold_m = 0.5);

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
