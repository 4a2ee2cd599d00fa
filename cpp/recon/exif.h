// The EXIF facts a reconstruction and the photo sorter need: the focal length and the
// sensor's pixel pitch (or the 35 mm equivalent focal length) for the intrinsics, the GPS
// position and the capture time. A small reader of the TIFF structure inside a JPEG's APP1
// "Exif" segment, or of a TIFF file itself (EXIF 2.3, CIPA DC-008); anything malformed or
// absent is simply not reported. In the light inputs library: fuzzed (target `exif`).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace mound::recon {

struct Exif {
  std::optional<double> focal_mm;
  std::optional<double> focal_35mm;           // FocalLengthIn35mmFilm
  std::optional<double> focal_plane_x_res;    // pixels per unit
  std::optional<double> focal_plane_unit_mm;  // the unit, in mm (inch 25.4, cm 10, mm 1)
  std::optional<int> width_px;                // PixelXDimension
  std::optional<double> lat_deg, lon_deg, alt_m;
  std::string make, model;
  // DateTimeOriginal (else DateTime) as written, "YYYY:MM:DD HH:MM:SS" (camera local time,
  // no zone), empty when absent or not of that form.
  std::string datetime;
};

// Reads the EXIF of a JPEG or TIFF file; an empty Exif when the file has none (not an
// error).
Exif ReadExif(const std::string& path);
// The same from a file's first bytes (a JPEG's header segments, or a whole TIFF).
Exif ParseExif(const std::vector<uint8_t>& file_bytes);

// The sensor's width in mm of a common UAV camera, by its EXIF model (DJI's FC codes and
// a few others; case-insensitive); nothing for a camera the table does not know.
std::optional<double> SensorWidthMm(const std::string& model);

// Focal length in pixels for an image `width_px` wide: from the focal length and the focal
// plane resolution, else from the 35 mm equivalent (36 mm wide), else from the focal
// length and the sensor width of a known camera (SensorWidthMm); nothing when none.
// `source`, when given, says which: "focal_plane", "35mm", "sensor_table".
std::optional<double> FocalPx(const Exif& e, int width_px, std::string* source = nullptr);

}  // namespace mound::recon
