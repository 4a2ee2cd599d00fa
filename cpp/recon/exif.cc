#include "recon/exif.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <utility>
#include <vector>

namespace mound::recon {
namespace {

class Tiff {
 public:
  explicit Tiff(std::vector<uint8_t> d) : d_(std::move(d)) {}
  bool Init() {
    if (d_.size() < 8) return false;
    if (d_[0] == 'I' && d_[1] == 'I')
      le_ = true;
    else if (d_[0] == 'M' && d_[1] == 'M')
      le_ = false;
    else
      return false;
    return U16(2) == 42;
  }
  uint32_t FirstIfd() const { return U32(4); }
  bool Ok(size_t off, size_t n) const { return off <= d_.size() && n <= d_.size() - off; }
  uint16_t U16(size_t o) const {
    if (!Ok(o, 2)) return 0;
    return le_ ? static_cast<uint16_t>(d_[o] | d_[o + 1] << 8)
               : static_cast<uint16_t>(d_[o] << 8 | d_[o + 1]);
  }
  uint32_t U32(size_t o) const {
    if (!Ok(o, 4)) return 0;
    return le_ ? (uint32_t(d_[o]) | uint32_t(d_[o + 1]) << 8 | uint32_t(d_[o + 2]) << 16 |
                  uint32_t(d_[o + 3]) << 24)
               : (uint32_t(d_[o]) << 24 | uint32_t(d_[o + 1]) << 16 | uint32_t(d_[o + 2]) << 8 |
                  uint32_t(d_[o + 3]));
  }
  struct Entry {
    uint16_t tag = 0, type = 0;
    uint32_t count = 0;
    size_t value_offset = 0;  // where the value (or its first element) lies
  };
  std::vector<Entry> Ifd(uint32_t off) const {
    std::vector<Entry> out;
    const uint16_t n = U16(off);
    if (!Ok(off + 2, size_t(n) * 12)) return out;
    static const int kSize[] = {0, 1, 1, 2, 4, 8, 1, 1, 2, 4, 8, 4, 8, 4};
    for (int i = 0; i < n; ++i) {
      const size_t e = off + 2 + size_t(i) * 12;
      Entry en{U16(e), U16(e + 2), U32(e + 4), e + 8};
      if (en.type == 0 || en.type > 13) continue;
      const uint64_t bytes = uint64_t(kSize[en.type]) * en.count;
      if (bytes > 4) en.value_offset = U32(e + 8);
      if (!Ok(en.value_offset, bytes)) continue;
      out.push_back(en);
    }
    return out;
  }
  // Numeric value k of an entry (SHORT, LONG, RATIONAL, SRATIONAL); nothing otherwise.
  std::optional<double> Number(const Entry& e, uint32_t k = 0) const {
    if (k >= e.count) return std::nullopt;
    switch (e.type) {
      case 3:
        return U16(e.value_offset + 2 * k);
      case 4:
        return U32(e.value_offset + 4 * k);
      case 5: {
        const uint32_t num = U32(e.value_offset + 8 * k), den = U32(e.value_offset + 8 * k + 4);
        if (den == 0) return std::nullopt;
        return double(num) / den;
      }
      case 10: {
        const int32_t num = static_cast<int32_t>(U32(e.value_offset + 8 * k));
        const int32_t den = static_cast<int32_t>(U32(e.value_offset + 8 * k + 4));
        if (den == 0) return std::nullopt;
        return double(num) / den;
      }
      default:
        return std::nullopt;
    }
  }
  // An integer entry (SHORT, LONG or IFD): IFD offsets and pixel counts are never rationals,
  // and a rational there (or a negative SRATIONAL) must not reach an integer cast.
  std::optional<uint32_t> Integer(const Entry& e) const {
    if (e.count == 0) return std::nullopt;
    if (e.type == 3) return U16(e.value_offset);
    if (e.type == 4 || e.type == 13) return U32(e.value_offset);
    return std::nullopt;
  }
  std::string Text(const Entry& e) const {
    if (e.type != 2) return "";
    std::string s(d_.begin() + e.value_offset, d_.begin() + e.value_offset + e.count);
    while (!s.empty() && (s.back() == '\0' || s.back() == ' ')) s.pop_back();
    return s;
  }
  char Char(const Entry& e) const {
    return e.type == 2 && e.count > 0 ? static_cast<char>(d_[e.value_offset]) : 0;
  }
  // The first byte of a BYTE or UNDEFINED entry (writers use either for GPSAltitudeRef).
  std::optional<uint8_t> Byte(const Entry& e) const {
    if ((e.type != 1 && e.type != 7) || e.count == 0) return std::nullopt;
    return d_[e.value_offset];
  }

 private:
  std::vector<uint8_t> d_;
  bool le_ = true;
};

// The payload of a JPEG's first APP1 segment whose name is `name` (with its NUL; markers
// walked up to the image data); empty when there is none.
std::vector<uint8_t> App1Payload(const std::vector<uint8_t>& f, const std::string& name) {
  if (f.size() < 2 || f[0] != 0xFF || f[1] != 0xD8) return {};
  size_t at = 2;
  for (int segments = 0; segments < 64; ++segments) {
    if (at + 4 > f.size() || f[at] != 0xFF) return {};
    const uint8_t marker = f[at + 1];
    const size_t len = size_t(f[at + 2]) << 8 | f[at + 3];
    if (len < 2) return {};
    if (marker == 0xDA || marker == 0xD9) return {};  // image data: no metadata after it
    if (at + 2 + len > f.size()) return {};
    const auto seg = f.begin() + static_cast<std::ptrdiff_t>(at + 4);
    const size_t n = len - 2;
    if (marker == 0xE1 && n > name.size() && std::equal(name.begin(), name.end(), seg)) {
      return std::vector<uint8_t>(seg + static_cast<std::ptrdiff_t>(name.size()),
                                  seg + static_cast<std::ptrdiff_t>(n));
    }
    at += 2 + len;
  }
  return {};
}

// The TIFF structure inside a JPEG's APP1 "Exif" segment, or the file itself when it is a
// TIFF; empty when there is none.
std::vector<uint8_t> ExifBlock(const std::vector<uint8_t>& f) {
  if (f.size() >= 4 && ((f[0] == 'I' && f[1] == 'I' && f[2] == 42 && f[3] == 0) ||
                        (f[0] == 'M' && f[1] == 'M' && f[2] == 0 && f[3] == 42))) {
    return f;
  }
  return App1Payload(f, std::string("Exif\0\0", 6));
}

// The XMP packet of a JPEG (its APP1 segment named "http://ns.adobe.com/xap/1.0/"), at most
// one segment (64 KiB); empty when there is none.
std::string XmpPacket(const std::vector<uint8_t>& f) {
  const std::vector<uint8_t> p = App1Payload(f, std::string("http://ns.adobe.com/xap/1.0/\0", 29));
  return std::string(p.begin(), p.end());
}

// The text of drone-dji:NAME in an XMP packet: an attribute (NAME="v") or an element
// (<drone-dji:NAME>v</drone-dji:NAME>); nothing when absent or not closed.
std::optional<std::string> XmpValue(const std::string& xmp, const std::string& name) {
  const std::string key = "drone-dji:" + name;
  for (size_t at = xmp.find(key); at != std::string::npos; at = xmp.find(key, at + 1)) {
    size_t p = at + key.size();
    while (p < xmp.size() && (xmp[p] == ' ' || xmp[p] == '\t' || xmp[p] == '\n' || xmp[p] == '\r'))
      ++p;
    if (p >= xmp.size()) return std::nullopt;
    if (xmp[p] == '=') {
      ++p;
      while (p < xmp.size() && xmp[p] == ' ') ++p;
      if (p >= xmp.size() || (xmp[p] != '"' && xmp[p] != '\'')) continue;
      const char quote = xmp[p];
      const size_t end = xmp.find(quote, p + 1);
      if (end == std::string::npos || end - p > 64) return std::nullopt;
      return xmp.substr(p + 1, end - p - 1);
    }
    if (xmp[p] == '>' && (at == 0 || xmp[at - 1] == '<')) {
      const size_t end = xmp.find('<', p + 1);
      if (end == std::string::npos || end - p > 64) return std::nullopt;
      return xmp.substr(p + 1, end - p - 1);
    }
  }
  return std::nullopt;
}

// A number as DJI writes it ("+317.547", "-0.10"), strictly: the whole text, finite, within
// [lo, hi]; nothing otherwise.
std::optional<double> XmpNumber(const std::string& xmp, const std::string& name, double lo,
                                double hi) {
  const std::optional<std::string> text = XmpValue(xmp, name);
  if (!text || text->empty() || text->size() > 40) return std::nullopt;
  std::string s = *text;
  while (!s.empty() && s.front() == ' ') s.erase(s.begin());
  while (!s.empty() && s.back() == ' ') s.pop_back();
  if (!s.empty() && s.front() == '+') s.erase(s.begin());
  if (s.empty()) return std::nullopt;
  for (char c : s)
    if (!((c >= '0' && c <= '9') || c == '.' || c == '-' || c == 'e' || c == 'E'))
      return std::nullopt;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (end != s.c_str() + s.size() || !std::isfinite(v) || v < lo || v > hi) return std::nullopt;
  return v;
}

// "YYYY:MM:DD HH:MM:SS" with digits where digits belong; empty otherwise.
std::string CheckedDateTime(const std::string& s) {
  if (s.size() != 19) return "";
  for (size_t i = 0; i < s.size(); ++i) {
    const char c = s[i];
    const bool sep = i == 4 || i == 7 || i == 10 || i == 13 || i == 16;
    if (sep ? c != (i == 10 ? ' ' : ':') : (c < '0' || c > '9')) return "";
  }
  return s;
}

}  // namespace

Exif ReadExif(const std::string& path) {
  // A JPEG's EXIF lies in its first 64 KiB segments; a TIFF's IFDs may lie anywhere.
  std::ifstream in(path, std::ios::binary);
  if (!in) return {};
  constexpr size_t kMaxBytes = 64u << 20;
  std::vector<uint8_t> head(4);
  if (!in.read(reinterpret_cast<char*>(head.data()), 4)) return {};
  const bool tiff = (head[0] == 'I' && head[1] == 'I') || (head[0] == 'M' && head[1] == 'M');
  const size_t want = tiff ? kMaxBytes : (64u + 2u) * 65536u;
  std::vector<uint8_t> bytes(head);
  std::vector<char> buf(1 << 16);
  while (bytes.size() < want) {
    in.read(buf.data(), static_cast<std::streamsize>(buf.size()));
    const std::streamsize got = in.gcount();
    if (got <= 0) break;
    bytes.insert(bytes.end(), buf.begin(), buf.begin() + got);
  }
  return ParseExif(bytes);
}

Exif ParseExif(const std::vector<uint8_t>& file_bytes) {
  Exif x;
  x.dji = ParseDjiXmp(XmpPacket(file_bytes));
  Tiff t(ExifBlock(file_bytes));
  if (!t.Init()) return x;
  uint32_t exif_ifd = 0, gps_ifd = 0;
  for (const auto& e : t.Ifd(t.FirstIfd())) {
    if (e.tag == 0x010F) x.make = t.Text(e);
    if (e.tag == 0x0110) x.model = t.Text(e);
    if (e.tag == 0x8769) exif_ifd = t.Integer(e).value_or(0);
    if (e.tag == 0x8825) gps_ifd = t.Integer(e).value_or(0);
    if (e.tag == 0x0132 && x.datetime.empty()) x.datetime = CheckedDateTime(t.Text(e));
  }
  if (exif_ifd) {
    for (const auto& e : t.Ifd(exif_ifd)) {
      if (e.tag == 0x920A) x.focal_mm = t.Number(e);
      if (e.tag == 0x9003) {
        const std::string d = CheckedDateTime(t.Text(e));
        if (!d.empty()) x.datetime = d;
      }
      if (e.tag == 0xA405) x.focal_35mm = t.Number(e);
      if (e.tag == 0xA20E) x.focal_plane_x_res = t.Number(e);
      if (e.tag == 0xA002) {
        // Up to 2^20 pixels wide; anything wider is not a photo's width.
        if (auto w = t.Integer(e); w && *w > 0 && *w <= (1u << 20))
          x.width_px = static_cast<int>(*w);
      }
      if (e.tag == 0xA003) {
        if (auto h = t.Integer(e); h && *h > 0 && *h <= (1u << 20))
          x.height_px = static_cast<int>(*h);
      }
      if (e.tag == 0xA210) {
        const double unit = t.Number(e).value_or(2);
        x.focal_plane_unit_mm = unit == 3 ? 10.0 : unit == 4 ? 1.0 : unit == 5 ? 1e-3 : 25.4;
      }
    }
  }
  if (gps_ifd) {
    char lat_ref = 0, lon_ref = 0;
    int alt_ref = 0;
    std::optional<double> lat, lon, alt;
    auto dms = [&](const Tiff::Entry& e) -> std::optional<double> {
      const auto d = t.Number(e, 0), m = t.Number(e, 1), s = t.Number(e, 2);
      if (!d || !m || !s) return std::nullopt;
      return *d + *m / 60 + *s / 3600;
    };
    for (const auto& e : t.Ifd(gps_ifd)) {
      if (e.tag == 1) lat_ref = t.Char(e);
      if (e.tag == 2) lat = dms(e);
      if (e.tag == 3) lon_ref = t.Char(e);
      if (e.tag == 4) lon = dms(e);
      if (e.tag == 5) alt_ref = t.Byte(e).value_or(0);
      if (e.tag == 6) alt = t.Number(e);
    }
    // Degrees are unsigned (the reference letter carries the sign): an SRATIONAL below zero
    // is a broken file, not the southern hemisphere.
    if (lat && lon && *lat >= 0 && *lat <= 90 && *lon >= 0 && *lon <= 180) {
      x.lat_deg = lat_ref == 'S' ? -*lat : *lat;
      x.lon_deg = lon_ref == 'W' ? -*lon : *lon;
      if (alt) x.alt_m = alt_ref == 1 ? -*alt : *alt;
    }
  }
  return x;
}

std::optional<DjiXmp> ParseDjiXmp(const std::string& packet) {
  if (packet.find("drone-dji:") == std::string::npos) return std::nullopt;
  DjiXmp d;
  d.abs_alt_m = XmpNumber(packet, "AbsoluteAltitude", -1000, 20000);
  d.rel_alt_m = XmpNumber(packet, "RelativeAltitude", -2000, 20000);
  d.gimbal_pitch_deg = XmpNumber(packet, "GimbalPitchDegree", -180, 180);
  d.gimbal_yaw_deg = XmpNumber(packet, "GimbalYawDegree", -360, 360);
  d.gimbal_roll_deg = XmpNumber(packet, "GimbalRollDegree", -180, 180);
  d.flight_pitch_deg = XmpNumber(packet, "FlightPitchDegree", -180, 180);
  d.flight_yaw_deg = XmpNumber(packet, "FlightYawDegree", -360, 360);
  d.flight_roll_deg = XmpNumber(packet, "FlightRollDegree", -180, 180);
  d.lat_deg = XmpNumber(packet, "GpsLatitude", -90, 90);
  d.lon_deg = XmpNumber(packet, "GpsLongitude", -180, 180);
  if (auto f = XmpNumber(packet, "RtkFlag", 0, 255); f && *f == std::floor(*f))
    d.rtk_flag = static_cast<int>(*f);
  d.rtk_std_lon_m = XmpNumber(packet, "RtkStdLon", 0, 1000);
  d.rtk_std_lat_m = XmpNumber(packet, "RtkStdLat", 0, 1000);
  d.rtk_std_hgt_m = XmpNumber(packet, "RtkStdHgt", 0, 1000);
  d.calibrated_focal_px = XmpNumber(packet, "CalibratedFocalLength", 1, 1e6);
  d.calibrated_cx_px = XmpNumber(packet, "CalibratedOpticalCenterX", 0, 1e6);
  d.calibrated_cy_px = XmpNumber(packet, "CalibratedOpticalCenterY", 0, 1e6);
  return d;
}

std::optional<SensorSpec> SensorOf(const std::string& model) {
  // Sensor widths from the makers' published specifications: the sensor's format (1" 13.2
  // mm, 1/2.3" 6.17 mm, 1/2" 6.4 mm, 1/1.3" 9.7 mm, 4/3" 17.3 mm, APS-C 23.5 mm, full frame
  // 35.9 mm) or its stated size. The EXIF model is the camera's, not the aircraft's.
  static const SensorSpec kTable[] = {
      {"FC6310", 13.2, "DJI Phantom 4 Pro specifications: 1\" CMOS"},
      {"FC6310S", 13.2, "DJI Phantom 4 Pro V2.0 specifications: 1\" CMOS"},
      {"FC6310R", 13.2, "DJI Phantom 4 RTK specifications: 1\" CMOS"},
      {"FC6510", 13.2, "DJI Zenmuse X4S specifications: 1\" CMOS"},
      {"FC6520", 17.3, "DJI Zenmuse X5S specifications: 4/3\" CMOS"},
      {"FC6540", 23.5, "DJI Zenmuse X7 specifications: APS-C (23.5 x 15.7 mm)"},
      {"L1D-20C", 13.2, "DJI Mavic 2 Pro specifications: 1\" CMOS"},
      {"FC3411", 13.2, "DJI Air 2S specifications: 1\" CMOS"},
      {"FC330", 6.17, "DJI Phantom 4 specifications: 1/2.3\" CMOS"},
      {"FC300X", 6.17, "DJI Phantom 3 Professional specifications: 1/2.3\" CMOS"},
      {"FC300S", 6.17, "DJI Phantom 3 Advanced specifications: 1/2.3\" CMOS"},
      {"FC220", 6.17, "DJI Mavic Pro specifications: 1/2.3\" CMOS"},
      {"FC2103", 6.17, "DJI Mavic Air specifications: 1/2.3\" CMOS"},
      {"FC7203", 6.17, "DJI Mavic Mini specifications: 1/2.3\" CMOS"},
      {"FC7303", 6.17, "DJI Mini 2 specifications: 1/2.3\" CMOS"},
      {"FC3170", 6.4, "DJI Mavic Air 2 specifications: 1/2\" CMOS"},
      {"FC3582", 9.7, "DJI Mini 3 Pro specifications: 1/1.3\" CMOS"},
      {"FC8482", 9.7, "DJI Mini 4 Pro specifications: 1/1.3\" CMOS"},
      {"M3E", 17.3, "DJI Mavic 3 Enterprise specifications: 4/3\" CMOS"},
      {"L2D-20C", 17.3, "DJI Mavic 3 specifications: 4/3\" CMOS Hasselblad camera"},
      {"ZENMUSEP1", 35.9, "DJI Zenmuse P1 specifications: full frame (35.9 x 24 mm)"},
      {"ILCE-6000", 23.5, "Sony a6000 specifications: APS-C (23.5 x 15.6 mm)"},
      {"ILCE-5100", 23.5, "Sony a5100 specifications: APS-C (23.5 x 15.6 mm)"},
      {"DSC-RX1RM2", 35.9, "Sony RX1R II specifications: full frame (35.9 x 24 mm)"},
      {"CANONPOWERSHOTSX260HS", 6.17, "Canon PowerShot SX260 HS specifications: 1/2.3\" CMOS"},
  };
  std::string m;
  for (char c : model) {
    if (c != ' ') m += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  }
  for (const SensorSpec& s : kTable) {
    if (m == s.model) return s;
  }
  return std::nullopt;
}

std::optional<double> SensorWidthMm(const std::string& model) {
  if (auto s = SensorOf(model)) return s->width_mm;
  return std::nullopt;
}

namespace {

std::string Fixed(double v, int digits) {
  std::ostringstream o;
  o << std::fixed << std::setprecision(digits) << v;
  return o.str();
}

}  // namespace

std::optional<FocalPrior> FocalFromExif(const Exif& e, int width_px) {
  // The EXIF figures refer to the full-size image (PixelXDimension wide); a scaled image
  // scales them.
  const double full = e.width_px && *e.width_px > 0 ? *e.width_px : width_px;
  const double scale = width_px / full;
  if (e.dji && e.dji->calibrated_focal_px && *e.dji->calibrated_focal_px > 0) {
    return FocalPrior{*e.dji->calibrated_focal_px * scale, "dji_calibration", 0.005,
                      "DJI XMP CalibratedFocalLength " + Fixed(*e.dji->calibrated_focal_px, 1) +
                          " px at " + Fixed(full, 0) + " px wide"};
  }
  if (e.focal_mm && *e.focal_mm > 0 && e.focal_plane_x_res && *e.focal_plane_x_res > 0) {
    const double unit_mm = e.focal_plane_unit_mm.value_or(25.4);
    return FocalPrior{*e.focal_mm * *e.focal_plane_x_res / unit_mm * scale, "focal_plane", 0.01,
                      "focal length " + Fixed(*e.focal_mm, 2) + " mm, pixel pitch " +
                          Fixed(unit_mm / *e.focal_plane_x_res * 1000, 3) +
                          " um (EXIF FocalPlaneXResolution)"};
  }
  if (e.focal_mm && *e.focal_mm > 0) {
    if (auto s = SensorOf(e.model)) {
      return FocalPrior{*e.focal_mm / s->width_mm * width_px, "sensor_table", 0.01,
                        "focal length " + Fixed(*e.focal_mm, 2) + " mm on a " +
                            Fixed(s->width_mm, 2) + " mm wide sensor (" + s->source + ")"};
    }
  }
  if (e.focal_35mm && *e.focal_35mm > 0) {
    // The equivalent is defined on the native frame's diagonal: the image's width is taken
    // as that frame's, whose height is 2/3 of it for a 3:2 image, else 3/4 (a 4:3 sensor,
    // which is what a 16:9 or 4:3 picture of a UAV camera is cut from).
    const double h = e.height_px && *e.height_px > 0 ? *e.height_px : 0.0;
    const double aspect = h > 0 && std::abs(full / h - 1.5) < 0.01 ? 2.0 / 3.0 : 0.75;
    const double diag = width_px * std::sqrt(1.0 + aspect * aspect);
    return FocalPrior{*e.focal_35mm / 43.2666 * diag, "35mm", 0.05,
                      "35 mm equivalent " + Fixed(*e.focal_35mm, 1) + " mm on the diagonal of a " +
                          (aspect < 0.7 ? std::string("3:2") : std::string("4:3")) +
                          " frame (camera not in the sensor table)"};
  }
  return std::nullopt;
}

std::optional<double> FocalPx(const Exif& e, int width_px, std::string* source) {
  auto f = FocalFromExif(e, width_px);
  if (!f) return std::nullopt;
  if (source) *source = f->source;
  return f->px;
}

}  // namespace mound::recon
