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

// What a DJI photo's XMP packet says (namespace drone-dji, the attributes or elements of
// its rdf:Description), each only when present and in range: AbsoluteAltitude (DJI's
// "absolute" height: above mean sea level, EGM96, without RTK; with an RTK fix, RtkFlag 50,
// above the WGS84 ellipsoid, as field reports say and DJI documents no further),
// RelativeAltitude (above the take-off point, barometric), the gimbal's and the aircraft's
// attitude in degrees (yaw clockwise from north, pitch -90 straight down), the RTK fix and
// the RTK position's standard deviations in metres.
struct DjiXmp {
  std::optional<double> abs_alt_m, rel_alt_m;
  std::optional<double> gimbal_pitch_deg, gimbal_yaw_deg, gimbal_roll_deg;
  std::optional<double> flight_pitch_deg, flight_yaw_deg, flight_roll_deg;
  std::optional<double> lat_deg, lon_deg;  // GpsLatitude / GpsLongitude, where written
  std::optional<int> rtk_flag;
  std::optional<double> rtk_std_lon_m, rtk_std_lat_m, rtk_std_hgt_m;
};

// The drone-dji fields of an XMP packet (text); nothing for a packet without any.
std::optional<DjiXmp> ParseDjiXmp(const std::string& packet);

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
  std::optional<DjiXmp> dji;  // a DJI photo's XMP (JPEG APP1 "http://ns.adobe.com/xap/1.0/")
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
