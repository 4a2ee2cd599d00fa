// Files of the 3-D stage: the camera and GPS inputs, and the reconstruction's outputs
// (recon.json, points.ply, COLMAP's text model). Contract: ../shared/INTERFACES.md.
#pragma once

#include <Eigen/Core>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "geometry/camera_model.h"
#include "geometry/geodesy.h"
#include "sfm/reconstruction.h"

namespace mound::recon {

// A mound.camera v1 file (the simulator's) or a text file holding the 3 x 3 K (Strecha's
// K.txt; no distortion). Width and height must equal the images' (InputError otherwise).
geometry::CameraModel ReadCamera(const std::string& path, int width, int height);

struct GpsPositions {
  std::map<std::string, Eigen::Vector3d> enu_m;  // by image file name
  std::optional<geometry::Geodetic> origin;
  std::string source;  // "poses" or "exif"
};

// `images[].file` + `gps_enu_m` of a mound.poses v1 file, by the file's base name. A
// position for an image not in `files` is an InputError naming it.
GpsPositions ReadGpsPoses(const std::string& path, const std::vector<std::string>& files);

// Writes points.ply: binary little-endian, float x y z, uchar red green blue, int
// track_length.
void WritePly(const std::string& path, const sfm::Reconstruction& r);

// COLMAP's text model (cameras.txt, images.txt, points3D.txt) in `dir`.
void WriteColmapText(const std::string& dir, const sfm::Reconstruction& r,
                     const std::vector<std::string>& files,
                     const std::vector<sfm::ImageFeatures>& features);

nlohmann::json CameraJson(const geometry::CameraModel& c);

}  // namespace mound::recon
