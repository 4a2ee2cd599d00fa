// The 3-D stage's inputs: EXIF of a real drone photo (Caliterra, ../shared/data) and the
// camera files, with their bad cases.
#include "recon/recon_io.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>

#include "common/error.h"
#include "recon/exif.h"
#include "recon/photos.h"

namespace mound::recon {
namespace {

std::string Temp(const std::string& name, const std::string& text) {
  const std::string p = ::testing::TempDir() + "/" + name;
  std::ofstream(p) << text;
  return p;
}

TEST(Exif, FocalLengthFromTheSensorTableBeforeThe35mmEquivalent) {
  Exif e;
  e.focal_mm = 8.8;
  e.model = "FC6310";  // Phantom 4 Pro: a 1" sensor, 13.2 mm wide
  e.focal_35mm = 24;   // the sensor table comes before the 35 mm equivalent
  std::string source;
  EXPECT_NEAR(*FocalPx(e, 5472, &source), 8.8 / 13.2 * 5472, 1e-9);
  EXPECT_EQ(source, "sensor_table");
  Exif unknown;
  unknown.focal_mm = 8.8;
  unknown.model = "Some Camera";
  EXPECT_FALSE(FocalPx(unknown, 4000));
  EXPECT_EQ(*SensorWidthMm(" fc6310 "), 13.2);  // spaces and case do not matter
  unknown.focal_35mm = 24;
  unknown.width_px = 5472;
  unknown.height_px = 3648;  // 3:2: the diagonal of a 3:2 frame, 5472 px wide
  auto f = FocalFromExif(unknown, 5472);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->source, "35mm");
  EXPECT_NEAR(f->px, 24 / 43.2666 * std::hypot(5472.0, 3648.0), 1e-6);
  EXPECT_EQ(f->rel_sd, 0.05);  // the wider prior
}

// The focal prior of real cameras, each from its EXIF as the camera writes it (model,
// focal length, 35 mm equivalent, size), against the focal length the sensor's published
// width gives: every source, in order, and the 35 mm equivalent's aspect crop.
TEST(Exif, FocalPriorTable) {
  struct Row {
    const char* model;
    double focal_mm, f35;
    int w, h;
    double want_px;
    const char* source;
    double tol_px;
  };
  const Row rows[] = {
      // DJI Phantom 3 (FC300S): 3.61 mm on a 6.17 mm wide 1/2.3" sensor, 16:9 cut from 4:3
      {"FC300S", 3.61, 20, 4000, 2250, 3.61 / 6.17 * 4000, "sensor_table", 1e-9},
      // three current DJI cameras: Mavic 3 Enterprise, Mavic 3 (Hasselblad), Mini 4 Pro
      {"M3E", 12.29, 24, 5280, 3956, 12.29 / 17.3 * 5280, "sensor_table", 1e-9},
      {"L2D-20c", 12.29, 24, 5280, 3956, 12.29 / 17.3 * 5280, "sensor_table", 1e-9},
      {"FC8482", 6.72, 24, 8064, 6048, 6.72 / 9.7 * 8064, "sensor_table", 1e-9},
      // a camera the table lacks: the 35 mm equivalent on a 4:3 frame's diagonal
      {"FC9999", 3.61, 20, 4000, 2250, 20 / 43.2666 * 5000, "35mm", 1e-6},
  };
  for (const Row& r : rows) {
    Exif e;
    e.model = r.model;
    e.focal_mm = r.focal_mm;
    e.focal_35mm = r.f35;
    e.width_px = r.w;
    e.height_px = r.h;
    auto f = FocalFromExif(e, r.w);
    ASSERT_TRUE(f) << r.model;
    EXPECT_EQ(f->source, r.source) << r.model;
    EXPECT_NEAR(f->px, r.want_px, r.tol_px) << r.model;
    EXPECT_NE(f->detail.find(r.source == std::string("35mm") ? "equivalent" : "specifications"),
              std::string::npos)
        << f->detail;
  }
  // The FC300S by its 35 mm equivalent alone, the old way (36 mm wide): 2,222 px, 5 % short
  // of the sensor's 2,340; on the 4:3 diagonal 2,311 px (1.2 % short), inside its 5 % prior.
  EXPECT_NEAR(20 / 36.0 * 4000, 2222.2, 0.1);
  EXPECT_NEAR(20 / 43.2666 * 5000 / (3.61 / 6.17 * 4000), 0.988, 0.001);
  // DJI's calibration in the XMP comes first, scaled to the image's width.
  Exif d;
  d.model = "M3E";
  d.focal_mm = 12.29;
  d.width_px = 5280;
  d.dji = DjiXmp{};
  d.dji->calibrated_focal_px = 3713.29;
  auto f = FocalFromExif(d, 2640);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->source, "dji_calibration");
  EXPECT_NEAR(f->px, 3713.29 / 2, 1e-9);
}

// The Phantom 3's real EXIF and XMP (../shared/data/dji/photo_meta): 3.61 mm, 20 mm
// equivalent, 4000 x 2250, FC300S: 2,340 px from the sensor table.
TEST(Exif, ARealPhantom3PhotoGetsItsSensorsFocalLength) {
  const Exif e = ReadExif(std::string(MOUND_SHARED_DATA) + "/dji/photo_meta/phantom3_fc300s.jpg");
  EXPECT_EQ(e.model, "FC300S");
  ASSERT_TRUE(e.focal_mm && e.focal_35mm && e.width_px && e.height_px && e.dji);
  EXPECT_EQ(*e.width_px, 4000);
  EXPECT_EQ(*e.height_px, 2250);
  auto f = FocalFromExif(e, 4000);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->source, "sensor_table");
  EXPECT_NEAR(f->px, 2340.4, 0.1);
  EXPECT_NEAR(*e.dji->abs_alt_m, 198.31, 1e-9);
  EXPECT_FALSE(e.dji->calibrated_focal_px);  // a 2016 camera writes no calibration
}

TEST(Exif, ReadsFocalLengthPixelPitchAndGpsOfACanonPhoto) {
  const std::string path = std::string(MOUND_SHARED_DATA) + "/images/caliterra/images/IMG_9354.jpg";
  const Exif e = ReadExif(path);
  EXPECT_EQ(e.make, "Canon");
  ASSERT_TRUE(e.focal_mm && e.focal_plane_x_res && e.lat_deg && e.lon_deg && e.alt_m);
  EXPECT_NEAR(*e.focal_mm, 4.5, 1e-9);
  // 4.5 mm at 16393.44 pixels per inch: 2904 px over the 4000 px width.
  EXPECT_NEAR(*FocalPx(e, 4000), 4.5 * 16393.44262295082 / 25.4, 1e-6);
  EXPECT_NEAR(*FocalPx(e, 2000), 4.5 * 16393.44262295082 / 25.4 / 2, 1e-6);
  // exif_gps.txt: 30.171223 -98.089992 317.3 (west is negative).
  EXPECT_NEAR(*e.lat_deg, 30.171223, 1e-6);
  EXPECT_NEAR(*e.lon_deg, -98.089992, 1e-6);
  EXPECT_NEAR(*e.alt_m, 317.3, 1e-9);
  // Not a JPEG, or no EXIF: nothing reported, no error.
  EXPECT_FALSE(ReadExif(Temp("x.jpg", "hello")).focal_mm);
  // The capture time (DateTimeOriginal), as Pillow reads it too.
  EXPECT_EQ(e.datetime, "2014:10:19 13:20:51");
}

// The same EXIF from the TIFF structure alone (a TIFF file), and from a JPEG cut short:
// the header segments read as far as they go, never beyond.
TEST(Exif, ReadsTiffFilesAndSurvivesTruncation) {
  const std::string jpeg = std::string(MOUND_SHARED_DATA) + "/images/caliterra/images/IMG_9354.jpg";
  std::ifstream in(jpeg, std::ios::binary);
  std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                             std::istreambuf_iterator<char>());
  // The TIFF block after APP1's "Exif\0\0".
  const std::string sig("Exif\0\0", 6);
  const auto at = std::search(bytes.begin(), bytes.end(), sig.begin(), sig.end());
  ASSERT_NE(at, bytes.end());
  const std::vector<uint8_t> tiff(at + 6, bytes.end());
  const Exif t = ParseExif(tiff);
  ASSERT_TRUE(t.lat_deg && t.lon_deg);
  EXPECT_NEAR(*t.lat_deg, 30.171223, 1e-6);
  EXPECT_EQ(t.make, "Canon");
  for (size_t cut : {size_t{0}, size_t{1}, size_t{3}, size_t{100}, size_t{2000}, size_t{9000}}) {
    const std::vector<uint8_t> part(bytes.begin(),
                                    bytes.begin() + static_cast<std::ptrdiff_t>(cut));
    const Exif p = ParseExif(part);  // no crash; nothing beyond what is there
    if (p.lat_deg) {
      EXPECT_NEAR(*p.lat_deg, 30.171223, 1e-6);
    }
  }
}

// A little-endian TIFF written by hand: IFD0 points to the EXIF IFD with a negative
// SRATIONAL (the fuzzer's finding: cast to an offset, undefined behaviour) and to a GPS IFD
// whose latitude is a SRATIONAL triple; `lat_deg` is its degrees.
std::vector<uint8_t> HandTiff(int32_t lat_deg) {
  std::vector<uint8_t> b;
  auto u16 = [&](uint32_t v) {
    b.push_back(v & 0xFF);
    b.push_back(v >> 8 & 0xFF);
  };
  auto u32 = [&](uint32_t v) {
    u16(v & 0xFFFF);
    u16(v >> 16);
  };
  auto entry = [&](uint16_t tag, uint16_t type, uint32_t count, uint32_t value) {
    u16(tag);
    u16(type);
    u32(count);
    u32(value);
  };
  b = {'I', 'I'};
  u16(42);
  u32(8);
  // IFD0 at 8: 2 entries (8 + 2 + 24 + 4 = 38), the SRATIONAL -1/1 at 38.
  u16(2);
  entry(0x8769, 10, 1, 38);
  entry(0x8825, 4, 1, 46);
  u32(0);
  u32(static_cast<uint32_t>(-1));
  u32(1);
  // GPS IFD at 46: 4 entries (46 + 2 + 48 + 4 = 100), lat at 100, lon at 124.
  u16(4);
  entry(1, 2, 2, 'N');
  entry(2, 10, 3, 100);
  entry(3, 2, 2, 'E');
  entry(4, 5, 3, 124);
  u32(0);
  for (int32_t v : {lat_deg, 1, 0, 1, 0, 1}) u32(static_cast<uint32_t>(v));
  for (uint32_t v : {28u, 1u, 0u, 1u, 0u, 1u}) u32(v);
  return b;
}

TEST(Exif, IntegerTagsAreNeverCastFromRationalsAndDegreesAreUnsigned) {
  const Exif ok = ParseExif(HandTiff(38));
  ASSERT_TRUE(ok.lat_deg && ok.lon_deg);
  EXPECT_EQ(*ok.lat_deg, 38.0);
  EXPECT_EQ(*ok.lon_deg, 28.0);
  EXPECT_FALSE(ok.focal_mm);  // the EXIF IFD pointer was a rational: not followed
  const Exif bad = ParseExif(HandTiff(-100));
  EXPECT_FALSE(bad.lat_deg);  // -100 degrees north is a broken file, not 100 south
  EXPECT_FALSE(bad.lon_deg);
}

// A JPEG header (SOI, one APP1 XMP segment) holding `xmp`, as DJI's cameras write it.
std::vector<uint8_t> JpegWithXmp(const std::string& xmp) {
  const std::string name("http://ns.adobe.com/xap/1.0/\0", 29);
  const std::string body = name + xmp;
  std::vector<uint8_t> b = {0xFF, 0xD8, 0xFF, 0xE1};
  const size_t len = body.size() + 2;
  b.push_back(static_cast<uint8_t>(len >> 8));
  b.push_back(static_cast<uint8_t>(len & 0xFF));
  b.insert(b.end(), body.begin(), body.end());
  for (uint8_t c : {0xFF, 0xDA, 0x00, 0x02}) b.push_back(c);
  return b;
}

TEST(Exif, ReadsADjiPhotosXmpAsAttributesOrElements) {
  const Exif e = ParseExif(
      JpegWithXmp("<x:xmpmeta><rdf:RDF><rdf:Description rdf:about=\"DJI Meta Data\" "
                  "drone-dji:AbsoluteAltitude=\"+317.547\" drone-dji:RelativeAltitude=\"+109.400\" "
                  "drone-dji:GimbalPitchDegree=\"-90.00\" drone-dji:GimbalYawDegree=\"+12.30\" "
                  "drone-dji:FlightYawDegree=\"+11.90\" drone-dji:RtkFlag=\"50\" "
                  "drone-dji:RtkStdLon=\"0.01234\" drone-dji:RtkStdLat=\"0.01456\">"
                  "<drone-dji:RtkStdHgt>0.0256</drone-dji:RtkStdHgt></rdf:Description></rdf:RDF>"
                  "</x:xmpmeta>"));
  ASSERT_TRUE(e.dji);
  EXPECT_DOUBLE_EQ(*e.dji->abs_alt_m, 317.547);
  EXPECT_DOUBLE_EQ(*e.dji->rel_alt_m, 109.4);
  EXPECT_DOUBLE_EQ(*e.dji->gimbal_pitch_deg, -90.0);
  EXPECT_DOUBLE_EQ(*e.dji->gimbal_yaw_deg, 12.3);
  EXPECT_DOUBLE_EQ(*e.dji->flight_yaw_deg, 11.9);
  EXPECT_EQ(*e.dji->rtk_flag, 50);
  EXPECT_DOUBLE_EQ(*e.dji->rtk_std_lon_m, 0.01234);
  EXPECT_DOUBLE_EQ(*e.dji->rtk_std_hgt_m, 0.0256);  // the element form
  EXPECT_FALSE(e.dji->lat_deg);
  // out of range, not a number, unclosed: not reported; no drone-dji field: no XMP
  const Exif bad = ParseExif(
      JpegWithXmp("drone-dji:AbsoluteAltitude=\"1e9\" drone-dji:GimbalPitchDegree=\"nan\" "
                  "drone-dji:RelativeAltitude=\"12"));
  ASSERT_TRUE(bad.dji);
  EXPECT_FALSE(bad.dji->abs_alt_m || bad.dji->gimbal_pitch_deg || bad.dji->rel_alt_m);
  EXPECT_FALSE(ParseExif(JpegWithXmp("<x:xmpmeta/>")).dji);
}

// A card: images with and without GPS, a text file, an empty file, a link to a folder
// above it (a loop, not followed), a folder without permission (listed as skipped).
TEST(Card, ListsEveryFileWithItsKindAndExif) {
  namespace fs = std::filesystem;
  const fs::path card = fs::path(::testing::TempDir()) / "card";
  fs::remove_all(card);
  fs::create_directories(card / "DCIM" / "100MEDIA");
  const std::string shared = MOUND_SHARED_DATA;
  fs::copy_file(shared + "/images/caliterra/images/IMG_9354.jpg",
                card / "DCIM" / "100MEDIA" / "a.jpg");
  fs::copy_file(shared + "/images/fountain-P11/images/0000.jpg", card / "DCIM" / "b.jpg");
  std::ofstream(card / "notes.txt") << "hello";
  std::ofstream(card / "empty.jpg");
  fs::create_directory_symlink("..", card / "DCIM" / "loop");
  fs::create_directories(card / "locked");
  std::ofstream(card / "locked" / "c.jpg") << "x";
  fs::permissions(card / "locked", fs::perms::none);
  const CardListing l = ListCard(card.string());
  fs::permissions(card / "locked", fs::perms::owner_all);
  std::map<std::string, CardFile> by;
  for (const auto& f : l.files) by[f.file] = f;
  ASSERT_TRUE(by.count("DCIM/100MEDIA/a.jpg"));
  EXPECT_EQ(by["DCIM/100MEDIA/a.jpg"].kind, "jpeg");
  EXPECT_TRUE(by["DCIM/100MEDIA/a.jpg"].exif.lat_deg.has_value());
  EXPECT_EQ(by["DCIM/b.jpg"].kind, "jpeg");
  EXPECT_FALSE(by["DCIM/b.jpg"].exif.lat_deg.has_value());  // fountain-P11: no GPS
  EXPECT_EQ(by["notes.txt"].kind, "not_an_image");
  EXPECT_EQ(by["empty.jpg"].kind, "not_an_image");
  for (const auto& f : l.files) EXPECT_EQ(f.file.find("loop"), std::string::npos) << f.file;
  if (::geteuid() != 0) {  // root reads any folder
    EXPECT_FALSE(by.count("locked/c.jpg"));
    EXPECT_EQ(l.skipped.size(), 1u);
  }
  EXPECT_THROW(ListCard((card / "notes.txt").string()), InputError);
}

TEST(Camera, ReadsStrechaKAndTheSimulatorsCameraAndRefusesMisfits) {
  const geometry::CameraModel k =
      ReadCamera(Temp("K.txt", "2759.48 0 1520.69\n0 2764.16 1006.81\n0 0 1\n"), 3072, 2048);
  EXPECT_EQ(k.fx, 2759.48);
  EXPECT_EQ(k.cy, 1006.81);
  const std::string cam =
      Temp("camera.json", R"({"schema": "mound.camera", "version": 1, "width": 640,
      "height": 480, "K": [[457, 0, 319.5], [0, 457, 239.5], [0, 0, 1]],
      "dist_k1k2p1p2k3": [-0.1, 0.01, 0, 0, 0]})");
  const geometry::CameraModel c = ReadCamera(cam, 640, 480);
  EXPECT_EQ(c.dist[0], -0.1);
  EXPECT_THROW(ReadCamera(cam, 1280, 960), InputError);  // other images
  EXPECT_THROW(ReadCamera(Temp("K2.txt", "2759 0 1520 0 2764 1006 0 0 1"), 640, 480),
               InputError);  // pp outside
  EXPECT_THROW(ReadCamera(Temp("K3.txt", "1 2 3"), 640, 480), InputError);
  EXPECT_THROW(ReadCamera(Temp("K4.txt", "100 5 300 0 100 200 0 0 1"), 640, 480),
               InputError);  // skew
  // The JSON and the text form go through the same checks (geometry::CameraFromK), and a
  // field's error names the file and the field.
  const std::string bad = Temp("bad.json", R"({"schema": "mound.camera", "version": 1,
      "width": 640, "height": 480, "K": [[457, 0, 319.5], [0, -457, 239.5], [0, 0, 1]]})");
  try {
    ReadCamera(bad, 640, 480);
    ADD_FAILURE() << "a negative fy was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), bad + ": K: fx and fy must be > 0");
  }
  try {
    ReadCamera(Temp("K5.txt", "457 0 319.5 0 -457 239.5 0 0 1"), 640, 480);
    ADD_FAILURE() << "a negative fy was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("K: fx and fy must be > 0"), std::string::npos);
  }
}

}  // namespace
}  // namespace mound::recon
