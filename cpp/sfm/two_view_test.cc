// Two-view initialisation: the stacked-epipolar depths against a dense SVD, exact depths on
// exact data, and the whole chain (SIFT matches, RANSAC, 8-point, pose, depths) on images
// rendered by the site simulator's renderer, against its ground truth.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <functional>
#include <iostream>
#include <random>

#include "common/error.h"
#include "sfm/two_view.h"
#include "sim/render.h"

namespace mound::sfm {
namespace {

using geometry::Skew;

struct Scene {
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  std::vector<Eigen::Vector3d> x1, x2;
  std::vector<double> depth1;
};

Scene RandomScene(int n, double noise, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::normal_distribution<double> g(0, noise);
  Scene s;
  s.R = Eigen::AngleAxisd(0.2, Eigen::Vector3d(0.3, 1, 0.2).normalized()).toRotationMatrix();
  s.t = Eigen::Vector3d(-1, 0.2, 0.1).normalized();
  for (int j = 0; j < n; ++j) {
    const Eigen::Vector3d X(3 * u(rng), 3 * u(rng), 8 + 2 * u(rng));
    const Eigen::Vector3d X2 = s.R * X + s.t;
    s.x1.push_back(Eigen::Vector3d(X.x() / X.z() + g(rng), X.y() / X.z() + g(rng), 1));
    s.x2.push_back(Eigen::Vector3d(X2.x() / X2.z() + g(rng), X2.y() / X2.z() + g(rng), 1));
    s.depth1.push_back(X.z());
  }
  return s;
}

TEST(StackedEpipolarDepths, EqualsTheDenseSvdSolution) {
  const Scene s = RandomScene(30, 2e-3, 7);
  const int n = 30;
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(3 * n, n + 1);
  for (int j = 0; j < n; ++j) {
    M.block<3, 1>(3 * j, j) = Skew(s.x2[j]) * s.R * s.x1[j];
    M.block<3, 1>(3 * j, n) = Skew(s.x2[j]) * s.t;
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(M, Eigen::ComputeFullV);
  Eigen::VectorXd dense = svd.matrixV().col(n);
  if (dense[n] < 0) dense = -dense;
  const Eigen::VectorXd ours = StackedEpipolarDepths(s.x1, s.x2, s.R, s.t);
  EXPECT_NEAR(ours.norm(), 1.0, 1e-12);
  EXPECT_LT((ours - dense).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_GT(svd.singularValues()[n - 1], 1e-6);  // noisy: a real least-squares problem
}

TEST(StackedEpipolarDepths, ExactDataGivesTheTrueDepths) {
  const Scene s = RandomScene(50, 0.0, 3);
  const Eigen::VectorXd v = StackedEpipolarDepths(s.x1, s.x2, s.R, s.t);
  const double gamma = v[50];
  for (int j = 0; j < 50; ++j) EXPECT_NEAR(v[j] / gamma, s.depth1[j], 1e-9 * s.depth1[j]);
}

// --- rendered images -------------------------------------------------------------------

struct PairResult {
  size_t matches = 0;
  TwoViewResult r;
  double rot_deg = 0, dir_deg = 0;        // after InitialiseTwoView
  double ba_rot_deg = 0, ba_dir_deg = 0;  // after RefineTwoView
  std::pair<double, double> rmse;
  std::vector<double> depth_rel_err;  // initialisation, sorted
};

// Renders a terrain from two cameras and runs the two-view chain on the images.
PairResult RenderedPair(const std::function<double(double, double)>& height,
                        const Eigen::Vector3d& c1, const Eigen::Vector3d& look1,
                        const Eigen::Vector3d& c2, const Eigen::Vector3d& look2) {
  const sim::Scene scene = sim::NoiseScene(height, 40, 0.25, 11);
  geometry::CameraModel cam;
  cam.width = 800;
  cam.height = 600;
  cam.fx = cam.fy = 700;
  cam.cx = 399.5;
  cam.cy = 299.5;
  cam.dist = {-0.05, 0.01, 0, 0, 0};
  const geometry::Rigid3d p1 = geometry::LookAt(c1, look1), p2 = geometry::LookAt(c2, look2);
  sim::RenderSettings rs;
  rs.keep_geometry = true;
  rs.noise_sigma = 1.0;
  const sim::RenderedImage a = sim::Render(scene, cam, p1, rs), b = sim::Render(scene, cam, p2, rs);
  auto grey = [](const sim::RenderedImage& im) {
    GreyImage g{im.width, im.height, {}};
    for (size_t k = 0; k < im.rgb.size(); k += 3) g.pixels.push_back(im.rgb[k]);
    return g;
  };
  PairResult out;
  const Matches m = MatchFeatures(grey(a), grey(b), 3000);
  out.matches = m.px1.size();
  out.r = InitialiseTwoView(m, cam);
  // Ground truth relative pose cam2_from_cam1.
  const geometry::Rigid3d truth = p2 * p1.Inverse();
  const Eigen::Matrix3d R_true = truth.RotationMatrix();
  const Eigen::Vector3d t_true = truth.translation;
  auto rot_deg = [&](const Eigen::Matrix3d& R) {
    return Eigen::AngleAxisd(R * R_true.transpose()).angle() * 180 / M_PI;
  };
  auto dir_deg = [&](const Eigen::Vector3d& t) {
    return std::acos(std::clamp(t.dot(t_true.normalized()), -1.0, 1.0)) * 180 / M_PI;
  };
  out.rot_deg = rot_deg(out.r.cam2_from_cam1.RotationMatrix());
  out.dir_deg = dir_deg(out.r.cam2_from_cam1.translation);
  // Depths, up to the one scale two views leave open (|t_true| here).
  for (size_t k = 0; k < out.r.inliers.size(); ++k) {
    const Eigen::Vector2d px = m.px1[out.r.inliers[k]];
    const int u = static_cast<int>(std::lround(px.x())), v = static_cast<int>(std::lround(px.y()));
    const double gt = a.depth_m[static_cast<size_t>(v) * a.width + u];
    if (!std::isnan(gt))
      out.depth_rel_err.push_back(std::fabs(out.r.depth1[k] * t_true.norm() - gt) / gt);
  }
  std::sort(out.depth_rel_err.begin(), out.depth_rel_err.end());
  TwoViewResult refined = out.r;
  out.rmse = RefineTwoView(m, cam, &refined);
  out.ba_rot_deg = rot_deg(refined.cam2_from_cam1.RotationMatrix());
  out.ba_dir_deg = dir_deg(refined.cam2_from_cam1.translation);
  std::cout << out.matches << " matches, " << out.r.inliers.size() << " inliers; 8-point: "
            << "rotation error " << out.rot_deg << " deg, translation direction error "
            << out.dir_deg << " deg; after two-view BA (" << out.rmse.first << " -> "
            << out.rmse.second << " px): " << out.ba_rot_deg << " / " << out.ba_dir_deg << " deg\n";
  return out;
}

TEST(TwoView, RecoversPoseAndDepthsFromRenderedImages) {
  const PairResult p = RenderedPair(
      [](double x, double y) {
        const double r = std::hypot(x, y);
        return r < 15 ? std::sqrt(15.0 * 15 - r * r) / 3 : 0.0;
      },
      {-5, -3, 40}, {0, 0, 0}, {5, 1, 38}, {1, 0, 0});
  ASSERT_GT(p.matches, 500u);
  EXPECT_GT(p.r.inliers.size(), p.matches * 8 / 10);
  EXPECT_EQ(p.r.positive_depth, static_cast<int>(p.r.inliers.size()));
  EXPECT_LT(p.rot_deg, 0.1);
  EXPECT_LT(p.dir_deg, 1.0);
  const std::vector<double>& rel = p.depth_rel_err;
  ASSERT_GT(rel.size(), 400u);
  std::cout << "depth error median " << rel[rel.size() / 2] << ", 90th percentile "
            << rel[rel.size() * 9 / 10] << "\n";
  EXPECT_LT(rel[rel.size() / 2], 0.01);
  EXPECT_LT(rel[rel.size() * 9 / 10], 0.03);
  EXPECT_LT(p.ba_rot_deg, 0.05);
  EXPECT_LT(p.ba_dir_deg, 0.2);
  EXPECT_LT(p.rmse.second, p.rmse.first);
}

TEST(TwoView, BundleAdjustmentRepairsTheNearlyPlanarCase) {
  // Gently undulating ground seen from straight above: nearly a plane, where the 8-point
  // algorithm's translation is poorly determined; the adjustment fixes it.
  const PairResult p =
      RenderedPair([](double x, double y) { return 0.3 * std::sin(0.2 * x) * std::cos(0.15 * y); },
                   {-6, 0, 40}, {-6, 0.001, 0}, {6, 0, 40}, {6, 0.001, 0});
  EXPECT_LT(p.ba_rot_deg, 0.05);
  EXPECT_LT(p.ba_dir_deg, 0.2);
  EXPECT_LT(p.ba_dir_deg, p.dir_deg);
  EXPECT_LT(p.rmse.second, 0.5);
}

TEST(TwoView, TooFewMatchesIsAClearError) {
  Matches m;
  for (int k = 0; k < 5; ++k) {
    m.px1.emplace_back(k, k);
    m.px2.emplace_back(k + 1, k);
  }
  geometry::CameraModel K;
  K.fx = K.fy = 500;
  K.cx = 320;
  K.cy = 240;
  EXPECT_THROW(InitialiseTwoView(m, K), NoResultError);  // a degenerate scene, not bad input
}

}  // namespace
}  // namespace mound::sfm
