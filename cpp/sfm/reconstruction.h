// The sparse model of structure from motion: registered images (cam_from_world, OpenCV
// camera axes), their camera, and the triangulated points with their tracks. sfm/tracks.h
// builds the tracks, sfm/incremental_mapper.h the model, sfm/georegistration.h maps it
// onto the GPS positions (until then its frame is the first image's camera and its scale
// the initial baseline).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "geometry/camera_model.h"
#include "geometry/rigid3.h"
#include "sfm/tracks.h"

namespace mound::sfm {

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

}  // namespace mound::sfm
