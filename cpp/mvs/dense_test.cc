// Dense stereo on images the site simulator's renderer draws of a known heightfield (a low
// mound on textured ground), with the true poses: depth maps against the renderer's
// depths, the fused cloud against the heightfield, its coverage and normals.
#include <gtest/gtest.h>

#include <unistd.h>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "common/error.h"
#include "mvs/dense.h"
#include "sim/render.h"

namespace mound::mvs {
namespace {

constexpr double kMoundRadius = 10, kMoundHeight = 2;

double TrueHeight(double x, double y) {
  const double r = std::hypot(x, y);
  const double ground = 0.02 * x;  // a 2 % slope
  return ground +
         (r < kMoundRadius ? kMoundHeight * (1 - (r * r) / (kMoundRadius * kMoundRadius)) : 0.0);
}

struct Site {
  DenseInput input;
  std::vector<sim::RenderedImage> images;
};

// A 4 x 3 raster of nadir images at 30 m and four oblique ones, 400 x 300 pixels.
const Site& RenderedSite() {
  static const Site site = [] {
    const sim::Scene scene = sim::NoiseScene(TrueHeight, 40, 0.25, 5);
    Site s;
    geometry::CameraModel& cam = s.input.camera;
    cam.width = 400;
    cam.height = 300;
    cam.fx = cam.fy = 300;
    cam.cx = 199.5;
    cam.cy = 149.5;
    cam.dist = {-0.03, 0.005, 0, 0, 0};
    std::vector<geometry::Rigid3d> poses;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 4; ++j) {
        const Eigen::Vector3d c(-12 + 8.0 * j, -8 + 8.0 * i, 30);
        poses.push_back(geometry::LookAt(c, c - Eigen::Vector3d(0, -0.001, 30)));
      }
    for (int k = 0; k < 4; ++k) {
      const double a = k * M_PI / 2 + 0.3;
      poses.push_back(geometry::LookAt({30 * std::cos(a), 30 * std::sin(a), 22}, {0, 0, 0.5}));
    }
    const std::string dir = (std::filesystem::temp_directory_path() /
                             ("mound_dense_test_" + std::to_string(::getpid())))
                                .string();
    std::filesystem::create_directories(dir);
    // the images are removed when the test binary exits
    static const struct RemoveAtExit {
      std::string dir;
      ~RemoveAtExit() {
        std::error_code ec;
        std::filesystem::remove_all(dir, ec);
      }
    } remove_at_exit{dir};
    sim::RenderSettings rs;
    rs.noise_sigma = 1.0;
    rs.keep_geometry = true;
    for (size_t k = 0; k < poses.size(); ++k) {
      rs.noise_seed = k + 1;
      sim::RenderedImage im = sim::Render(scene, cam, poses[k], rs);
      cv::Mat rgb(im.height, im.width, CV_8UC3, im.rgb.data()), bgr;
      cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
      const std::string path = dir + "/" + std::to_string(k) + ".png";
      cv::imwrite(path, bgr);
      s.input.image_paths.push_back(path);
      s.input.cam_from_world.push_back(poses[k]);
      s.images.push_back(std::move(im));
    }
    // A sparse model: 3,000 points of the true surface.
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(-25, 25);
    for (int k = 0; k < 3000; ++k) {
      const double x = u(rng), y = u(rng);
      s.input.sparse_points.emplace_back(x, y, TrueHeight(x, y));
    }
    return s;
  }();
  return site;
}

double Percentile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(q * (v.size() - 1))];
}

TEST(Dense, TheSweepReachesAMoundsTopButNotAStrayPoint) {
  // 2,000 points of undulating ground (+-0.5 m), a 5 m cone's 15 points continuing them up
  // to its top, two stray points 40 m up and one 30 m down
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> ground(-0.5, 0.5);
  std::vector<double> h;
  for (int i = 0; i < 2000; ++i) h.push_back(ground(rng));
  for (int i = 1; i <= 15; ++i) h.push_back(0.5 + 4.5 * i / 15.0);
  h.insert(h.end(), {40.0, 41.0, -30.0});
  // the camera 30 m above the ground's middle: a 0.3 m pad at least
  const auto [lo, hi] = SweptHeightRange(h, 30.0);
  EXPECT_GE(hi, 5.0);  // the top, padded
  EXPECT_LT(hi, 6.0);  // not the strays
  EXPECT_GT(lo, -1.0);
  EXPECT_LT(lo, -0.5);
  // without the cone: the percentiles' span, padded by 1 % of the camera's height (more
  // than a tenth of the span)
  std::vector<double> flat(h.begin(), h.begin() + 2000);
  const auto [flo, fhi] = SweptHeightRange(flat, 30.0);
  EXPECT_NEAR(fhi - flo, 0.98 + 0.6, 0.03);
}

TEST(Dense, SourceViewsAreTheOverlappingNeighbours) {
  const Site& s = RenderedSite();
  const auto sources = SelectSourceViews(s.input, 4);
  ASSERT_EQ(sources.size(), s.input.image_paths.size());
  // Image 5 (second row, second column) overlaps its raster neighbours most.
  ASSERT_EQ(sources[5].size(), 4u);
  for (int j : sources[5]) EXPECT_NE(j, 5);
  const std::vector<int> raster_neighbours = {1, 4, 6, 9, 0, 2, 8, 10};
  EXPECT_NE(std::find(raster_neighbours.begin(), raster_neighbours.end(), sources[5][0]),
            raster_neighbours.end());
}

TEST(Dense, WithoutRoomToKeepThemImagesAreReadWhereNeededWithTheSameDepths) {
  const Site& s = RenderedSite();
  DenseOptions o;
  o.max_image_size = 160;
  o.threads = 2;
  const auto sources = SelectSourceViews(s.input, o.source_views);
  int kept = 0, again = 0;
  const std::vector<DepthMap> a = ComputeDepthMaps(s.input, sources, o, &kept);
  o.image_cache_mb = 0;
  const std::vector<DepthMap> b = ComputeDepthMaps(s.input, sources, o, &again);
  size_t uses = 0;
  for (const auto& v : sources) uses += 1 + v.size();
  EXPECT_EQ(kept, static_cast<int>(s.input.image_paths.size()));
  EXPECT_EQ(again, static_cast<int>(uses));
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a[i].depth, b[i].depth) << i;
}

TEST(Dense, DepthMapMatchesTheRenderedDepths) {
  const Site& s = RenderedSite();
  DenseOptions o;
  o.max_image_size = 400;
  const auto sources = SelectSourceViews(s.input, o.source_views);
  const DepthMap m = PlaneSweepDepthMap(s.input, 5, sources[5], o);
  ASSERT_EQ(m.width, 400);
  const sim::RenderedImage& truth = s.images[5];
  std::vector<double> rel;
  for (int y = 0; y < m.height; ++y)
    for (int x = 0; x < m.width; ++x) {
      const float d = m.At(x, y);
      // The rendered image is distorted; the depth map is not: compare where the map is
      // valid at the distorted pixel of the same ray.
      const Eigen::Vector2d uv = s.input.camera.ImageFromNormalised(
          {(x - m.camera.cx) / m.camera.fx, (y - m.camera.cy) / m.camera.fy});
      const int u = static_cast<int>(std::lround(uv.x())),
                v = static_cast<int>(std::lround(uv.y()));
      if (!(d > 0) || u < 0 || v < 0 || u >= truth.width || v >= truth.height) continue;
      const float t = truth.depth_m[static_cast<size_t>(v) * truth.width + u];
      if (std::isnan(t)) continue;
      rel.push_back(std::fabs(d - t) / t);
    }
  std::cout << "depth map: " << m.valid << " of " << m.width * m.height << " pixels, " << m.planes
            << " planes, relative error median " << Percentile(rel, 0.5) << ", p90 "
            << Percentile(rel, 0.9) << "\n";
  EXPECT_GT(m.valid, m.width * m.height * 7 / 10);
  EXPECT_LT(Percentile(rel, 0.5), 0.002);  // 6 cm at 30 m
  EXPECT_LT(Percentile(rel, 0.9), 0.01);
}

TEST(Dense, FusedCloudLiesOnTheSurfaceAndCoversTheMound) {
  const Site& s = RenderedSite();
  DenseOptions o;
  o.max_image_size = 400;
  o.resolution_m = 0.2;
  o.threads = 2;
  const auto sources = SelectSourceViews(s.input, o.source_views);
  int reads = 0;
  const std::vector<DepthMap> maps = ComputeDepthMaps(s.input, sources, o, &reads);
  EXPECT_EQ(reads, static_cast<int>(s.input.image_paths.size()));  // each image read once
  const DenseCloud c = FuseDepthMaps(maps, o);
  ASSERT_GT(c.xyz.size(), 10000u);
  ASSERT_EQ(c.normal.size(), c.xyz.size());
  std::vector<double> err, tilt;
  std::vector<char> covered(50 * 50, 0);  // 0.5 m cells over the mound's square
  for (size_t k = 0; k < c.xyz.size(); ++k) {
    const Eigen::Vector3d& p = c.xyz[k];
    err.push_back(std::fabs(p.z() - TrueHeight(p.x(), p.y())));
    if (std::hypot(p.x(), p.y()) > 12 && c.normal[k].norm() > 0)
      tilt.push_back(std::acos(c.normal[k].z()) * 180 / M_PI);
    const int i = static_cast<int>(std::floor((p.y() + 12.5) / 0.5)),
              j = static_cast<int>(std::floor((p.x() + 12.5) / 0.5));
    if (i >= 0 && j >= 0 && i < 50 && j < 50) covered[i * 50 + j] = 1;
  }
  int inside = 0, hit = 0;
  for (int i = 0; i < 50; ++i)
    for (int j = 0; j < 50; ++j) {
      const double x = -12.25 + 0.5 * j, y = -12.25 + 0.5 * i;
      if (std::hypot(x, y) > kMoundRadius) continue;
      ++inside;
      hit += covered[i * 50 + j];
    }
  std::cout << c.xyz.size() << " points; height error median " << Percentile(err, 0.5) << " m, p90 "
            << Percentile(err, 0.9) << " m; mound footprint covered " << 100.0 * hit / inside
            << " %; flat-ground normal tilt median " << Percentile(tilt, 0.5) << " deg\n";
  EXPECT_LT(Percentile(err, 0.5), 0.05);
  EXPECT_LT(Percentile(err, 0.9), 0.15);
  EXPECT_GT(static_cast<double>(hit) / inside, 0.95);
  EXPECT_LT(Percentile(tilt, 0.5), 10.0);  // the ground's 1.1 degree slope, plus noise
}

TEST(Dense, BadInputIsAClearError) {
  auto why = [](const DenseOptions& o) {
    try {
      o.Check();
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  DenseOptions o;
  EXPECT_EQ(why(o), "");
  o.window = 4;
  EXPECT_EQ(why(o), "--window: must be odd and >= 3");
  o = DenseOptions();
  o.resolution_m = 0;
  EXPECT_EQ(why(o), "--resolution-m: must be >= 0.001 m");
  DenseInput in = RenderedSite().input;
  in.image_paths[0] = "/nonexistent/0.png";
  EXPECT_THROW(PlaneSweepDepthMap(in, 0, {1, 2}, DenseOptions()), InputError);
}

}  // namespace
}  // namespace mound::mvs
