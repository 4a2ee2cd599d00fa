// The 3-D stage's input files: the camera (mound.camera v1 or Strecha's K.txt) and the GPS
// positions of the images (mound.poses v1). Eigen and JSON only, so that the readers can be
// fuzzed and tested without the reconstruction's heavy dependencies.
#pragma once

#include <Eigen/Core>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "geometry/camera_model.h"
#include "geometry/geodesy.h"

namespace mound::recon {

// A mound.camera v1 file (the simulator's) or a text file holding the 3 x 3 K (Strecha's
// K.txt; no distortion). Width and height must equal the images' (InputError otherwise).
geometry::CameraModel ReadCamera(const std::string& path, int width, int height);
// The same from the file's text; `path` names it in error messages.
geometry::CameraModel ParseCamera(const std::string& text, const std::string& path, int width,
                                  int height);

struct GpsPositions {
  std::map<std::string, Eigen::Vector3d> enu_m;  // by image file name
  std::optional<geometry::Geodetic> origin;
  std::string source;  // "poses" or "exif"
  // What the origin's height (and so every absolute height of the model) is above:
  // "ellipsoid" (WGS84; a poses file's origin unless it says `alt_datum`, or photos whose
  // every DJI RTK fix is 50) or "egm96" (EXIF GPSAltitude: above sea level, EGM96 for DJI's
  // GNSS-only heights). recon.json's `origin.alt_datum`.
  std::string alt_datum = "ellipsoid";
};

// `images[].file` + `gps_enu_m` of a mound.poses v1 file, by the file's base name. A
// position for an image not in `files` is an InputError naming it.
GpsPositions ReadGpsPoses(const std::string& path, const std::vector<std::string>& files);
GpsPositions ParseGpsPoses(const std::string& text, const std::string& path,
                           const std::vector<std::string>& files);

}  // namespace mound::recon
