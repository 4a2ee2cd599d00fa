// Files of the 3-D stage: the camera and GPS inputs (recon/inputs.h), and the reconstruction's
// outputs (recon.json, points.ply, COLMAP's text model). Contract: ../shared/INTERFACES.md.
#pragma once

#include <Eigen/Core>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "geometry/camera_model.h"
#include "geometry/geodesy.h"
#include "geometry/ply.h"
#include "recon/inputs.h"
#include "sfm/reconstruction.h"

namespace mound::recon {

// Writes points.ply: binary little-endian, float x y z, uchar red green blue, int
// track_length.
void WritePly(const std::string& path, const sfm::Reconstruction& r);

// COLMAP's text model (cameras.txt, images.txt, points3D.txt) in `dir`.
void WriteColmapText(const std::string& dir, const sfm::Reconstruction& r,
                     const std::vector<std::string>& files,
                     const std::vector<sfm::ImageFeatures>& features);

nlohmann::json CameraJson(const geometry::CameraModel& c);

// A point cloud of at least 10 points; `what` names it in the error ("--reference").
geometry::PlyCloud ReadCloud(const std::string& path, const std::string& what);

// recon.json, its schema checked (mound.recon v1).
nlohmann::json LoadRecon(const std::string& path);

}  // namespace mound::recon
