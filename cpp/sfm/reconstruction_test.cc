// The mapper's pieces: tracks from matches (union-find, conflicts dropped), the robust
// similarity to GPS with outliers, and the transform of a model into the GPS frame.
#include "sfm/reconstruction.h"

#include <gtest/gtest.h>

#include <random>

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
  r.cam_from_world = {geometry::Rigid3d(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()).toRotationMatrix(),
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

}  // namespace
}  // namespace mound::sfm
