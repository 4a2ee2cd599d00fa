// The EXIF facts a reconstruction needs from a JPEG: the focal length and the sensor's
// pixel pitch (or the 35 mm equivalent focal length) for the intrinsics, and the GPS
// position. A small reader of the TIFF structure inside the APP1 "Exif" segment (EXIF 2.3,
// CIPA DC-008); anything malformed or absent is simply not reported.
#pragma once

#include <optional>
#include <string>

namespace mound::recon {

struct Exif {
  std::optional<double> focal_mm;
  std::optional<double> focal_35mm;             // FocalLengthIn35mmFilm
  std::optional<double> focal_plane_x_res;      // pixels per unit
  std::optional<double> focal_plane_unit_mm;    // the unit, in mm (inch 25.4, cm 10, mm 1)
  std::optional<int> width_px;                  // PixelXDimension
  std::optional<double> lat_deg, lon_deg, alt_m;
  std::string make, model;
};

// Reads the EXIF of a JPEG file; an empty Exif when the file has none (not an error).
Exif ReadExif(const std::string& path);

// Focal length in pixels for an image `width_px` wide: from the focal length and the focal
// plane resolution, else from the 35 mm equivalent (36 mm wide); nothing when neither.
std::optional<double> FocalPx(const Exif& e, int width_px);

}  // namespace mound::recon
