// The mapper's pieces: tracks from matches (union-find, conflicts dropped), the robust
// similarity to GPS with outliers, and the transform of a model into the GPS frame; and the
// incremental mapper itself on a synthetic scene (COLMAP's SynthesizeDataset pattern).
#include "sfm/reconstruction.h"

#include "sfm/georegistration.h"
#include "sfm/incremental_mapper.h"
#include "sfm/tracks.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "common/error.h"
#include "geometry/sim3.h"

namespace mound::sfm {
namespace {

TEST(Tracks, UnionFindJoinsChainsAndDropsTracksSeeingAnImageTwice) {
  std::vector<VerifiedPair> pairs(3);
  pairs[0] = {0, 1, {{0, 5}, {1, 6}}, 0};  // a0-b5, a1-b6
  pairs[1] = {1, 2, {{5, 9}, {6, 3}}, 0};  // b5-c9, b6-c3
  pairs[2] = {0, 2, {{1, 4}}, 0};          // a1-c4: a1's track now holds c3 and c4
  const auto tracks = BuildTracks(pairs, {10, 10, 10});
  ASSERT_EQ(tracks.size(), 1u);  // a0-b5-c9; the a1 track sees image 2 twice: dropped
  ASSERT_EQ(tracks[0].size(), 3u);
  EXPECT_EQ(tracks[0][0].image, 0);
  EXPECT_EQ(tracks[0][0].keypoint, 0);
  EXPECT_EQ(tracks[0][1].keypoint, 5);
  EXPECT_EQ(tracks[0][2].keypoint, 9);
}

TEST(GeoFit, RobustSimilarityIgnoresGrossGpsErrors) {
  std::mt19937 rng(2);
  std::normal_distribution<double> g(0, 1);
  geometry::Sim3d truth;
  truth.scale = 37.0;
  truth.rotation = Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, -0.4, 1).normalized());
  truth.translation = {120, -50, 80};
  std::vector<Eigen::Vector3d> model, world;
  for (int i = 0; i < 30; ++i) {
    model.emplace_back(g(rng), g(rng), 0.1 * g(rng));
    Eigen::Vector3d w = truth * model.back() + 0.5 * Eigen::Vector3d(g(rng), g(rng), g(rng));
    if (i % 6 == 0) w += Eigen::Vector3d(60, -40, 25);  // five GPS fixes grossly wrong
    world.push_back(w);
  }
  const auto fit = FitSim3Robust(model, world, 1);
  ASSERT_TRUE(fit);
  EXPECT_EQ(fit->inliers, 25);
  for (int i = 0; i < 30; ++i) EXPECT_EQ(fit->inlier[i], i % 6 != 0) << i;
  EXPECT_NEAR(fit->world_from_model.scale, 37.0, 0.5);
  EXPECT_LT(fit->rmse_m, 1.2);  // the 0.5 m per axis noise
  EXPECT_FALSE(FitSim3Robust({model[0], model[1]}, {world[0], world[1]}, 1));
}

TEST(GeoFit, LevelledFitIgnoresAClimbingGpsAltitude) {
  // Cameras on a level plane looking straight down in the model's own frame (down = +z
  // there); the GPS heights climb 80 m along the flight, as Caliterra's do.
  std::mt19937 rng(4);
  std::normal_distribution<double> g(0, 1);
  geometry::Sim3d truth;
  truth.scale = 9.0;
  truth.rotation = Eigen::AngleAxisd(0.9, Eigen::Vector3d::UnitZ()) *
                   Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX());  // model +z -> world -z
  truth.translation = {300, -200, 60};
  std::vector<Eigen::Vector3d> model, world;
  for (int i = 0; i < 40; ++i) {
    model.emplace_back((i % 10) - 4.5, (i / 10) * 3.0 - 4.5, 0.0);
    world.push_back(truth * model.back() + Eigen::Vector3d(2 * g(rng), 2 * g(rng), 80.0 * i / 39));
  }
  const auto level = FitLevelledSim3Robust(model, world, Eigen::Vector3d::UnitZ(), 1);
  ASSERT_TRUE(level);
  EXPECT_NEAR(level->world_from_model.scale, 9.0, 0.15);
  EXPECT_LT(geometry::RotationAngle(level->world_from_model.rotation, truth.rotation), 0.01);
  EXPECT_LT(level->rmse_horizontal_m, 3.5);
  // The 7-parameter fit follows the climb and tilts the model by degrees.
  const auto full = FitSim3Robust(model, world, 1);
  ASSERT_TRUE(full);
  EXPECT_GT(geometry::RotationAngle(full->world_from_model.rotation, truth.rotation), 0.1);
}

TEST(GeoFit, TransformKeepsPosesRigidAndMovesPointsAndCentres) {
  Reconstruction r;
  r.registered = {true, true};
  r.cam_from_world = {
      geometry::Rigid3d(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()).toRotationMatrix(),
                        Eigen::Vector3d(1, 2, 3)),
      geometry::Rigid3d()};
  Point3D p;
  p.xyz = {0.5, -1, 8};
  r.points.push_back(p);
  geometry::Sim3d s;
  s.scale = 2.5;
  s.rotation = Eigen::AngleAxisd(-1.2, Eigen::Vector3d::UnitZ());
  s.translation = {10, 20, 30};
  const Eigen::Vector3d c0 = r.cam_from_world[0].Centre();
  const Eigen::Vector3d cam_point = r.cam_from_world[0] * p.xyz;
  Transform(s, &r);
  EXPECT_NEAR((r.cam_from_world[0].Centre() - s * c0).norm(), 0, 1e-12);
  EXPECT_NEAR((r.points[0].xyz - s * p.xyz).norm(), 0, 1e-12);
  // The point seen from the camera: the same direction, s times farther (metres now).
  EXPECT_NEAR((r.cam_from_world[0] * r.points[0].xyz - s.scale * cam_point).norm(), 0, 1e-12);
}

// A synthetic survey: `rows` x `cols` cameras at 30 m over rough ground (points at heights
// of +-3 m over 60 x 60 m), looking down with a small tilt each, 640 x 480 px, f = 460 px;
// every point seen by two images is a verified match of theirs, its keypoints with 0.3 px
// noise and 2 % of each pair's matches wrong.
struct Synthetic {
  geometry::CameraModel camera;
  std::vector<geometry::Rigid3d> cam_from_world;
  std::vector<Eigen::Vector3d> points;
  std::vector<ImageFeatures> features;
  std::vector<VerifiedPair> pairs;
};

Synthetic Synthesize(int rows, int cols, uint64_t seed) {
  Synthetic s;
  s.camera.width = 640;
  s.camera.height = 480;
  s.camera.fx = s.camera.fy = 460;
  s.camera.cx = 319.5;
  s.camera.cy = 239.5;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::normal_distribution<double> px(0, 0.3);
  for (int k = 0; k < 1500; ++k) s.points.emplace_back(30 * u(rng), 30 * u(rng), 3 * u(rng));
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      const Eigen::Vector3d centre(-20 + 40.0 * c / std::max(1, cols - 1),
                                   -15 + 30.0 * r / std::max(1, rows - 1), 30);
      // Looking down (camera z along world -z, x east), tilted a few degrees.
      Eigen::Matrix3d R;
      R << 1, 0, 0, 0, -1, 0, 0, 0, -1;
      R = Eigen::AngleAxisd(0.05 * u(rng), Eigen::Vector3d::UnitX()).toRotationMatrix() *
          Eigen::AngleAxisd(0.05 * u(rng), Eigen::Vector3d::UnitY()).toRotationMatrix() * R;
      s.cam_from_world.emplace_back(R, -R * centre);
    }
  const int n = static_cast<int>(s.cam_from_world.size());
  std::vector<std::vector<int>> keypoint_of(n, std::vector<int>(s.points.size(), -1));
  s.features.resize(n);
  for (int i = 0; i < n; ++i) {
    s.features[i].width = 640;
    s.features[i].height = 480;
    for (size_t p = 0; p < s.points.size(); ++p) {
      Eigen::Vector2d uv;
      if (!s.camera.ImageFromCamera(s.cam_from_world[i] * s.points[p], &uv)) continue;
      if (uv.x() < 0 || uv.y() < 0 || uv.x() > 639 || uv.y() > 479) continue;
      keypoint_of[i][p] = static_cast<int>(s.features[i].keypoints.size());
      s.features[i].keypoints.push_back(uv + Eigen::Vector2d(px(rng), px(rng)));
      s.features[i].colors.push_back({100, 120, 80});
    }
  }
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) {
      VerifiedPair v{i, j, {}, 0};
      for (size_t p = 0; p < s.points.size(); ++p)
        if (keypoint_of[i][p] >= 0 && keypoint_of[j][p] >= 0)
          v.inliers.push_back({keypoint_of[i][p], keypoint_of[j][p]});
      // 2 % wrong matches: keypoints of different points.
      const size_t wrong = v.inliers.size() / 50;
      for (size_t k = 0; k + 1 < v.inliers.size() && k < wrong; ++k)
        std::swap(v.inliers[2 * k].second, v.inliers[2 * k + 1].second);
      if (v.inliers.size() >= 30) s.pairs.push_back(v);
    }
  return s;
}

TEST(IncrementalMap, RecoversASyntheticSurveyUpToASimilarity) {
  const Synthetic s = Synthesize(3, 4, 7);
  MapperOptions o;
  o.seed = 3;
  const Reconstruction r = IncrementalMap(s.features, s.pairs, s.camera, o);
  ASSERT_EQ(r.NumRegistered(), 12);
  EXPECT_LT(r.rmse_px, 0.6);  // the keypoints' noise is 0.3 px per axis
  std::vector<Eigen::Vector3d> est, truth;
  for (int i = 0; i < 12; ++i) {
    est.push_back(r.cam_from_world[i].Centre());
    truth.push_back(s.cam_from_world[i].Centre());
  }
  const auto sim = geometry::EstimateSim3d(est, truth);
  ASSERT_TRUE(sim.has_value());
  double worst = 0;
  for (int i = 0; i < 12; ++i) worst = std::max(worst, (*sim * est[i] - truth[i]).norm());
  EXPECT_LT(worst, 0.05);  // metres, cameras 30 m above the ground
  // Most points are triangulated and lie where they are, after the same similarity.
  EXPECT_GT(r.points.size(), 1000u);
  std::vector<double> err;
  for (const Point3D& p : r.points) {
    double best = 1e9;
    const Eigen::Vector3d x = *sim * p.xyz;
    for (const Eigen::Vector3d& t : s.points) best = std::min(best, (x - t).norm());
    err.push_back(best);
  }
  std::sort(err.begin(), err.end());
  EXPECT_LT(err[err.size() / 2], 0.05);
}

TEST(IncrementalMap, TooFewMatchesIsNoResult) {
  Synthetic s = Synthesize(1, 2, 9);
  for (VerifiedPair& v : s.pairs) v.inliers.resize(10);
  EXPECT_THROW(IncrementalMap(s.features, s.pairs, s.camera, MapperOptions()), NoResultError);
}

}  // namespace
}  // namespace mound::sfm
