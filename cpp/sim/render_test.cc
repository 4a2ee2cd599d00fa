// Renderer geometry: a textured point lands where K [R | t] (with distortion) projects it,
// the stored per-pixel ground points re-project onto their pixels, and occlusion is right.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>

#include "common/error.h"
#include "common/npy.h"
#include "sim/render.h"

namespace mound::sim {
namespace {

Heightfield MakeTerrain(double half_m, double spacing_m,
                        const std::function<double(double, double)>& z) {
  Heightfield hf;
  hf.x0_m = hf.y0_m = -half_m;
  hf.spacing_m = spacing_m;
  hf.nx = hf.ny = static_cast<int>(std::lround(2 * half_m / spacing_m)) + 1;
  for (int i = 0; i < hf.ny; ++i)
    for (int j = 0; j < hf.nx; ++j) hf.z_m.push_back(static_cast<float>(z(hf.X(j), hf.Y(i))));
  return hf;
}

Texture MakeTexture(double half_m, double texel_m,
                    const std::function<double(double, double)>& grey) {
  const int n = static_cast<int>(std::lround(2 * half_m / texel_m)) + 1;
  std::vector<unsigned char> rgb;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const double g = grey(-half_m + j * texel_m, -half_m + i * texel_m);
      const auto v = static_cast<unsigned char>(std::clamp(std::lround(g), 0L, 255L));
      rgb.insert(rgb.end(), {v, v, v});
    }
  }
  return Texture(-half_m, -half_m, texel_m, n, n, std::move(rgb));
}

using geometry::CameraModel;
using Pose = geometry::Rigid3d;  // cam_from_world

Eigen::Vector3d Vec(const std::array<double, 3>& a) { return {a[0], a[1], a[2]}; }
Pose LookAt(const std::array<double, 3>& centre, const std::array<double, 3>& target) {
  return geometry::LookAt(Vec(centre), Vec(target));
}

CameraModel MakeCamera(std::array<double, 5> dist = {}) {
  CameraModel cam;
  cam.width = 640;
  cam.height = 480;
  cam.fx = 500;
  cam.fy = 505;
  cam.cx = 321.3;
  cam.cy = 238.6;
  cam.dist = dist;
  return cam;
}

std::array<double, 2> Project(const CameraModel& cam, const Pose& pose, std::array<double, 3> X) {
  const Eigen::Vector3d pc = pose * Vec(X);
  const Eigen::Vector2d uv = cam.ImageFromNormalised({pc.x() / pc.z(), pc.y() / pc.z()});
  return {uv.x(), uv.y()};
}

// Intensity-weighted centroid of (value - background) in a window around `guess`.
std::array<double, 2> BlobCentroid(const RenderedImage& im, std::array<double, 2> guess, int half,
                                   double background) {
  double sw = 0, su = 0, sv = 0;
  const int u0 = static_cast<int>(std::lround(guess[0])),
            v0 = static_cast<int>(std::lround(guess[1]));
  for (int v = v0 - half; v <= v0 + half; ++v) {
    for (int u = u0 - half; u <= u0 + half; ++u) {
      const double w = im.rgb[(static_cast<size_t>(v) * im.width + u) * 3] - background;
      if (w <= 0) continue;
      sw += w;
      su += w * u;
      sv += w * v;
    }
  }
  return {su / sw, sv / sw};
}

struct BlobCase {
  std::array<double, 5> dist;
  std::array<double, 3> camera_centre;
};

class BlobTest : public ::testing::TestWithParam<BlobCase> {};

TEST_P(BlobTest, TexturedPointLandsWhereTheCameraProjectsIt) {
  const std::array<double, 3> P = {3.13, -2.71, 0.42};  // on a tilted plane z = 0.1x - 0.04y
  auto plane = [](double x, double y) { return 0.1 * x - 0.04 * y + 0.0; };
  ASSERT_NEAR(plane(P[0], P[1]), 0.4214, 1e-3);
  Scene scene;
  scene.terrain = MakeTerrain(20, 0.5, plane);
  const double sigma = 0.12;
  scene.texture = MakeTexture(20, 0.02, [&](double x, double y) {
    const double r2 = (x - P[0]) * (x - P[0]) + (y - P[1]) * (y - P[1]);
    return 20 + 220 * std::exp(-0.5 * r2 / (sigma * sigma));
  });
  const CameraModel cam = MakeCamera(GetParam().dist);
  const Pose pose = LookAt(GetParam().camera_centre, {0.5, 0.3, 0});
  const RenderedImage im = Render(scene, cam, pose, RenderSettings{});
  const std::array<double, 3> Pz = {P[0], P[1], plane(P[0], P[1])};
  const std::array<double, 2> expected = Project(cam, pose, Pz);
  ASSERT_GT(expected[0], 20);
  ASSERT_LT(expected[0], cam.width - 20);
  const std::array<double, 2> got = BlobCentroid(im, expected, 14, 20.5);
  EXPECT_NEAR(got[0], expected[0], 0.1);
  EXPECT_NEAR(got[1], expected[1], 0.1);
}

INSTANTIATE_TEST_SUITE_P(Cameras, BlobTest,
                         ::testing::Values(BlobCase{{0, 0, 0, 0, 0}, {1.0, -1.5, 18.0}},
                                           BlobCase{{0, 0, 0, 0, 0}, {-6.0, -9.0, 12.0}},
                                           BlobCase{{-0.18, 0.05, 0.001, -0.0005, 0},
                                                    {1.0, -1.5, 18.0}},
                                           BlobCase{{0.1, -0.02, 0, 0, 0.01}, {-6.0, -9.0, 12.0}}));

double Bumps(double x, double y) { return 0.6 * std::sin(0.3 * x) * std::cos(0.23 * y) + 0.02 * x; }

TEST(Render, StoredGroundPointsReprojectOntoTheirPixels) {
  for (const std::array<double, 5>& dist :
       {std::array<double, 5>{0, 0, 0, 0, 0}, std::array<double, 5>{-0.2, 0.06, 0.001, 0.001, 0}}) {
    Scene scene;
    scene.terrain = MakeTerrain(25, 0.25, Bumps);
    scene.texture =
        MakeTexture(25, 0.1, [](double x, double y) { return 128 + 60 * std::sin(x * y); });
    const CameraModel cam = MakeCamera(dist);
    const Pose pose = LookAt({-4, -14, 10}, {2, 3, 0});
    RenderSettings rs;
    rs.keep_geometry = true;
    const RenderedImage im = Render(scene, cam, pose, rs);
    ASSERT_GT(im.covered_px, static_cast<size_t>(cam.width * cam.height / 2));
    double worst = 0;
    size_t checked = 0;
    for (int v = 0; v < cam.height; v += 3) {
      for (int u = 0; u < cam.width; u += 3) {
        const size_t k = static_cast<size_t>(v) * cam.width + u;
        if (std::isnan(im.depth_m[k])) continue;
        const std::array<double, 3> X = {im.xyz_m[3 * k], im.xyz_m[3 * k + 1], im.xyz_m[3 * k + 2]};
        // The point lies on the terrain surface ...
        EXPECT_NEAR(X[2], Bumps(X[0], X[1]), 0.01);
        // ... and projects back onto the pixel's centre.
        const std::array<double, 2> p = Project(cam, pose, X);
        worst = std::max({worst, std::fabs(p[0] - u), std::fabs(p[1] - v)});
        EXPECT_NEAR((pose * Vec(X)).z(), im.depth_m[k], 1e-3 * im.depth_m[k]);
        ++checked;
      }
    }
    EXPECT_GT(checked, 10000u);
    EXPECT_LT(worst, dist[0] == 0 ? 0.01 : 0.05) << "k1 = " << dist[0];
  }
}

TEST(Render, PointBehindTheMoundIsHiddenFromALowObliqueView) {
  auto mound = [](double x, double y) { return std::max(0.0, 8.0 - 0.5 * std::hypot(x, y)); };
  auto flat = [](double, double) { return 0.0; };
  const std::array<double, 3> behind = {0.0, 20.0, 0.0};  // north of the mound, on the ground
  const CameraModel cam = MakeCamera();
  const Pose pose = LookAt({0, -40, 5}, behind);  // low, from the south
  const std::array<double, 2> px = Project(cam, pose, behind);
  const int u = static_cast<int>(std::lround(px[0])), v = static_cast<int>(std::lround(px[1]));
  const size_t k = static_cast<size_t>(v) * cam.width + u;
  const double true_depth = (pose * Vec(behind)).z();
  RenderSettings rs;
  rs.keep_geometry = true;
  for (bool with_mound : {false, true}) {
    Scene scene;
    scene.terrain =
        MakeTerrain(40, 0.25, with_mound ? std::function<double(double, double)>(mound) : flat);
    scene.texture = MakeTexture(40, 0.1, [](double x, double) { return 100 + x; });
    const RenderedImage im = Render(scene, cam, pose, rs);
    ASSERT_FALSE(std::isnan(im.depth_m[k]));
    if (with_mound) {
      EXPECT_LT(im.depth_m[k], true_depth - 15) << "the mound must hide the point";
      EXPECT_GT(im.xyz_m[3 * k + 2], 1.0) << "the pixel sees the mound's flank";
      EXPECT_LT(im.xyz_m[3 * k + 1], 0.0) << "on the near (south) side";
    } else {
      // Seen at grazing incidence, half a pixel spans about 0.6 m of ground here.
      EXPECT_NEAR(im.depth_m[k], true_depth, 0.01 * true_depth);
      EXPECT_NEAR(im.xyz_m[3 * k + 1], behind[1], 1.0);
    }
  }
}

TEST(Render, NoiseAndVignettingAreSeededAndBounded) {
  Scene scene;
  scene.terrain = MakeTerrain(30, 0.5, [](double, double) { return 0.0; });
  scene.texture = MakeTexture(30, 0.5, [](double, double) { return 128; });
  const CameraModel cam = MakeCamera();
  const Pose pose = LookAt({0, 0, 10}, {0, 0.001, 0});
  RenderSettings rs;
  rs.noise_sigma = 3;
  rs.noise_seed = 42;
  const RenderedImage a = Render(scene, cam, pose, rs), b = Render(scene, cam, pose, rs);
  EXPECT_EQ(a.rgb, b.rgb);
  rs.noise_seed = 43;
  EXPECT_NE(Render(scene, cam, pose, rs).rgb, a.rgb);
  double sum = 0, sum2 = 0;
  for (unsigned char c : a.rgb) {
    sum += c;
    sum2 += c * c;
  }
  const double n = static_cast<double>(a.rgb.size()), mean = sum / n;
  EXPECT_NEAR(mean, 128, 0.05);
  EXPECT_NEAR(std::sqrt(sum2 / n - mean * mean), 3.0, 0.1);  // rounding adds 1/12 DN^2
  rs.noise_sigma = 0;
  rs.vignetting = 0.3;
  const RenderedImage vig = Render(scene, cam, pose, rs);
  EXPECT_EQ(vig.rgb[(240 * 640 + 321) * 3], 128);
  EXPECT_EQ(vig.rgb[0], std::lround(128 * 0.7));  // the corner falls by 30 %
}

TEST(Npy, Float32RoundTripAndErrors) {
  const std::string path = (std::filesystem::temp_directory_path() / "mound_npy_test.npy").string();
  WriteNpyFloat32(path, {2, 3}, {1, 2, 3, 4, 5, 6.5f});
  const NpyArray a = ReadNpy(path);
  EXPECT_EQ(a.descr, "<f4");
  EXPECT_EQ(a.shape, (std::vector<size_t>{2, 3}));
  EXPECT_EQ(a.AsDouble(), (std::vector<double>{1, 2, 3, 4, 5, 6.5}));
  {
    std::FILE* f = std::fopen(path.c_str(), "ab");
    std::fputc(0, f);
    std::fclose(f);
  }
  EXPECT_THROW(ReadNpy(path), std::exception);
  // A corrupt header claiming 2^33 elements (whose byte count would overflow when
  // multiplied out naively) is refused by its shape, not by reading past the data.
  {
    std::string header = "{'descr': '<f8', 'fortran_order': False, 'shape': (8589934592, 2), }";
    header += std::string(64 - (10 + header.size() + 1) % 64, ' ') + "\n";
    std::string raw = std::string("\x93NUMPY\x01\x00", 8);
    raw += static_cast<char>(header.size() & 0xff);
    raw += static_cast<char>(header.size() >> 8);
    raw += header + std::string(16, '\0');
    std::FILE* f = std::fopen(path.c_str(), "wb");
    std::fwrite(raw.data(), 1, raw.size(), f);
    std::fclose(f);
    try {
      ReadNpy(path);
      ADD_FAILURE() << "accepted a 2^34-element shape";
    } catch (const std::exception& e) {
      EXPECT_NE(std::string(e.what()).find("2^31"), std::string::npos) << e.what();
    }
  }
  std::filesystem::remove(path);
  EXPECT_THROW(ReadNpy(path), std::exception);
}

// A version-2 header (4-byte length) holding `header`, then `data`.
void WriteRawNpy(const std::string& path, const std::string& header, const std::string& data) {
  std::string raw = std::string("\x93NUMPY\x02\x00", 8);
  for (int k = 0; k < 4; ++k) raw += static_cast<char>((header.size() >> (8 * k)) & 0xff);
  raw += header + data;
  std::FILE* f = std::fopen(path.c_str(), "wb");
  std::fwrite(raw.data(), 1, raw.size(), f);
  std::fclose(f);
}

std::string NpyError(const std::string& path) {
  try {
    ReadNpy(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "accepted";
}

// Fuzzer findings (issue 14): each is refused with an InputError naming the problem, with
// no crash (a 30,000-character descr and a 10,000-entry shape overflowed the stack inside
// std::regex) and no runaway read.
TEST(Npy, HostileHeadersAreRefused) {
  const std::string path = ::testing::TempDir() + "/mound_npy_hostile.npy";
  WriteRawNpy(path,
              "{'descr': '" + std::string(30000, 'f') +
                  "', 'fortran_order': False, "
                  "'shape': (2,), }\n",
              std::string(8, '\0'));
  EXPECT_NE(NpyError(path).find("dtype"), std::string::npos) << NpyError(path);
  std::string dims;
  for (int k = 0; k < 10000; ++k) dims += "1, ";
  WriteRawNpy(path, "{'descr': '<f4', 'fortran_order': False, 'shape': (" + dims + "), }\n",
              std::string(4, '\0'));
  EXPECT_NE(NpyError(path).find("dimensions"), std::string::npos) << NpyError(path);
  WriteRawNpy(path, std::string(70000, ' '), "");
  EXPECT_NE(NpyError(path).find("header of 70000 bytes"), std::string::npos) << NpyError(path);
  WriteRawNpy(path, "{'descr': '<f4', 'fortran_order': False, 'shape': (2,), }\n",
              std::string(1 << 20, '\0'));
  EXPECT_NE(NpyError(path).find("more data than the shape needs"), std::string::npos);
  WriteRawNpy(path, "{'descr': '<f4', 'fortran_order': maybe, 'shape': (2,), }\n",
              std::string(8, '\0'));
  EXPECT_NE(NpyError(path).find("fortran_order"), std::string::npos);
  WriteRawNpy(path, "{'descr': '<f4', 'fortran_order': False, 'shape': (2, x), }\n",
              std::string(8, '\0'));
  EXPECT_NE(NpyError(path).find("integers"), std::string::npos);
  WriteRawNpy(path, "{'descr': '<f4', 'fortran_order': False, 'shape': (1000, 1000), }\n",
              std::string(8, '\0'));
  EXPECT_NE(NpyError(path).find("shape needs 4000000"), std::string::npos) << NpyError(path);
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace mound::sim
