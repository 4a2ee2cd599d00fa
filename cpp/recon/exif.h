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
  // The camera's factory calibration, where DJI writes it (CalibratedFocalLength and
  // CalibratedOpticalCenterX/Y: pixels of the full-size image, PixelXDimension wide).
  std::optional<double> calibrated_focal_px, calibrated_cx_px, calibrated_cy_px;
};

// The drone-dji fields of an XMP packet (text); nothing for a packet without any.
std::optional<DjiXmp> ParseDjiXmp(const std::string& packet);

struct Exif {
  std::optional<double> focal_mm;
  std::optional<double> focal_35mm;           // FocalLengthIn35mmFilm
  std::optional<double> focal_plane_x_res;    // pixels per unit
  std::optional<double> focal_plane_unit_mm;  // the unit, in mm (inch 25.4, cm 10, mm 1)
  std::optional<int> width_px;                // PixelXDimension
  std::optional<int> height_px;               // PixelYDimension
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

// A camera of the sensor table: its EXIF model, its sensor's width in mm and where that
// figure comes from (the maker's published specification).
struct SensorSpec {
  const char* model;
  double width_mm;
  const char* source;
};

// The sensor table's entry for an EXIF model (case and spaces do not matter); nothing for
// a camera the table does not know.
std::optional<SensorSpec> SensorOf(const std::string& model);
// Its width in mm.
std::optional<double> SensorWidthMm(const std::string& model);

// A focal length in pixels with where it came from and how far it may be off: the
// relative standard deviation bundle adjustment's prior holds it with.
struct FocalPrior {
  double px = 0;
  std::string source;  // "dji_calibration", "focal_plane", "sensor_table", "35mm"
  double rel_sd = 0;
  std::string detail;  // what it was computed from, in words
};

// The focal length for an image `width_px` wide (the photo as stored, or scaled), best
// source first:
//   1. DJI's XMP calibration (CalibratedFocalLength), rel. sd 0.5 %;
//   2. the focal length and EXIF's focal plane resolution (the maker's pixel pitch), 1 %;
//   3. the focal length and the sensor table's width, 1 %;
//   4. the 35 mm equivalent, last, 5 %: it is defined on the diagonal (43.27 mm) of the
//      sensor's native frame, so an image cropped to another aspect (16:9 from a 4:3
//      sensor, the Phantom 3's 4000 x 2250) is taken as the full width of a 4:3 frame
//      (3:2 when the image itself is 3:2): DJI's FC300S, 20 mm equivalent, gives 2,311 px
//      instead of the 2,222 px of the 36 mm width (its sensor table value: 2,340 px).
// Nothing when EXIF says none of these.
std::optional<FocalPrior> FocalFromExif(const Exif& e, int width_px);

// FocalFromExif's focal length; `source`, when given, says which source.
std::optional<double> FocalPx(const Exif& e, int width_px, std::string* source = nullptr);

}  // namespace mound::recon
