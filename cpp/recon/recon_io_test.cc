// The 3-D stage's inputs: EXIF of a real drone photo (Caliterra, ../shared/data) and the
// camera files, with their bad cases.
#include "recon/recon_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "common/error.h"
#include "recon/exif.h"

namespace mound::recon {
namespace {

std::string Temp(const std::string& name, const std::string& text) {
  const std::string p = ::testing::TempDir() + "/" + name;
  std::ofstream(p) << text;
  return p;
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
}

TEST(Camera, ReadsStrechaKAndTheSimulatorsCameraAndRefusesMisfits) {
  const geometry::CameraModel k = ReadCamera(Temp("K.txt", "2759.48 0 1520.69\n0 2764.16 1006.81\n0 0 1\n"), 3072, 2048);
  EXPECT_EQ(k.fx, 2759.48);
  EXPECT_EQ(k.cy, 1006.81);
  const std::string cam = Temp("camera.json", R"({"schema": "mound.camera", "version": 1, "width": 640,
      "height": 480, "K": [[457, 0, 319.5], [0, 457, 239.5], [0, 0, 1]],
      "dist_k1k2p1p2k3": [-0.1, 0.01, 0, 0, 0]})");
  const geometry::CameraModel c = ReadCamera(cam, 640, 480);
  EXPECT_EQ(c.dist[0], -0.1);
  EXPECT_THROW(ReadCamera(cam, 1280, 960), InputError);                              // other images
  EXPECT_THROW(ReadCamera(Temp("K2.txt", "2759 0 1520 0 2764 1006 0 0 1"), 640, 480), InputError);  // pp outside
  EXPECT_THROW(ReadCamera(Temp("K3.txt", "1 2 3"), 640, 480), InputError);
  EXPECT_THROW(ReadCamera(Temp("K4.txt", "100 5 300 0 100 200 0 0 1"), 640, 480), InputError);  // skew
}

}  // namespace
}  // namespace mound::recon
