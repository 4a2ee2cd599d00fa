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
// and its scale the initial baseline (1), until sfm/georegistration.h maps it onto GPS
// positions.
#pragma once

#include <cstdint>
#include <vector>

#include "geometry/camera_model.h"
#include "sfm/features.h"
#include "sfm/reconstruction.h"

namespace mound::sfm {

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
  // With refine_intrinsics: each global adjustment (the only ones that refine the lens)
  // holds f, k1, k2 about the starting camera's values with these standard deviations
  // (ba::IntrinsicsPrior; relative for f); 0: free.
  double focal_prior_sd = 0, distortion_prior_sd = 0;
  int threads = 1;
  uint64_t seed = 1;
};

// Throws NoResultError when no initial pair has enough matches and parallax.
Reconstruction IncrementalMap(const std::vector<ImageFeatures>& features,
                              const std::vector<VerifiedPair>& pairs,
                              const geometry::CameraModel& camera, const MapperOptions& options);

}  // namespace mound::sfm
