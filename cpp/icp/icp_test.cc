// ICP with scale: a known similarity (rotation, translation, scale 0.5-2) of a terrain-like
// cloud is recovered, also with 30 % outliers and partial overlap, from the clouds' own
// frames (pca start) and from a shared frame; clouds that do not overlap are NoResultError;
// the surface distances of a constructed case equal the known offsets.
#include "icp/icp.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/error.h"

namespace mound::icp {
namespace {

// A 60 x 60 m terrain patch with a 4 m dome and gentle undulation, sampled at random.
double Height(double x, double y) {
  const double r2 = x * x + y * y;
  return 4.0 * std::max(0.0, 1 - r2 / 400.0) + 0.6 * std::sin(0.11 * x) * std::cos(0.07 * y) +
         0.02 * x;
}

std::vector<Eigen::Vector3d> Terrain(int n, uint64_t seed, double x0 = -30, double x1 = 30) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> ux(x0, x1), uy(-30, 30);
  std::vector<Eigen::Vector3d> p;
  for (int i = 0; i < n; ++i) {
    const double x = ux(rng), y = uy(rng);
    p.emplace_back(x, y, Height(x, y));
  }
  return p;
}

geometry::Sim3d Truth(double scale) {
  geometry::Sim3d s;
  s.scale = scale;
  s.rotation =
      Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, -0.3, 1).normalized()));
  s.translation = {120, -45, 8};
  return s;
}

void ExpectRecovered(const geometry::Sim3d& est, const geometry::Sim3d& truth_cloud_from_ref,
                     double tol_rel) {
  SCOPED_TRACE("scale " + std::to_string(truth_cloud_from_ref.scale));
  // est maps cloud -> reference; the truth maps reference -> cloud.
  const geometry::Sim3d inv = truth_cloud_from_ref.Inverse();
  EXPECT_NEAR(est.scale / inv.scale, 1.0, tol_rel);
  // Smooth terrain pins the in-plane rotation only through its gentle slopes: measured
  // 0.16 deg with 30 % clutter and 70 % overlap, 0.02 deg without.
  EXPECT_LT(est.rotation.angularDistance(inv.rotation), 5e-3);
  // Points of the site (in the cloud's frame: mapped there by the truth) land within 15 cm
  // (10.2 cm measured at 35 m from the centre).
  for (const Eigen::Vector3d& x :
       {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(20, -10, 2), Eigen::Vector3d(-25, 25, 0)}) {
    const Eigen::Vector3d in_cloud = truth_cloud_from_ref * x;
    EXPECT_LT((est * in_cloud - x).norm(), 0.15) << x.transpose();
  }
}

class ScaleCase : public ::testing::TestWithParam<double> {};

TEST_P(ScaleCase, RecoversASimilarityWithOutliersAndPartialOverlap) {
  const double scale = GetParam();
  const std::vector<Eigen::Vector3d> reference = Terrain(20000, 1);
  // The cloud: 70 % of the reference's extent (x in [-30, 12]), another sampling, 1 cm
  // noise, mapped by the similarity; plus 30 % outliers spread around it.
  std::vector<Eigen::Vector3d> cloud = Terrain(14000, 2, -30, 12);
  std::mt19937_64 rng(3);
  std::normal_distribution<double> g(0, 0.01);
  std::uniform_real_distribution<double> u(-35, 35), uz(-5, 15);
  for (auto& p : cloud) p += Eigen::Vector3d(g(rng), g(rng), g(rng));
  for (int i = 0; i < 6000; ++i) cloud.emplace_back(u(rng), u(rng), uz(rng));
  const geometry::Sim3d T = Truth(scale);
  for (auto& p : cloud) p = T * p;
  Options o;
  o.init = Init::kPca;
  const Result r = Align(cloud, reference, o);
  EXPECT_EQ(r.init_used, Init::kPca);
  EXPECT_TRUE(r.converged) << r.iterations << " iterations";
  ExpectRecovered(r.reference_from_cloud, T, 5e-3);
  EXPECT_GT(r.inlier_fraction, 0.6);
  EXPECT_LT(r.inlier_fraction, 0.8);  // the outliers are not inliers
}

INSTANTIATE_TEST_SUITE_P(Scales, ScaleCase, ::testing::Values(0.5, 1.3, 2.0));

TEST(Align, SharedFrameStartsFromIdentity) {
  const std::vector<Eigen::Vector3d> reference = Terrain(20000, 4);
  std::vector<Eigen::Vector3d> cloud = Terrain(15000, 5);
  geometry::Sim3d small;  // a GPS-sized error: 1.5 m, 1 degree, 2 %
  small.scale = 1.02;
  small.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(0.017, Eigen::Vector3d::UnitZ()));
  small.translation = {1.5, -1.0, 0.8};
  for (auto& p : cloud) p = small * p;
  const Result r = Align(cloud, reference, Options{});
  EXPECT_EQ(r.init_used, Init::kNone);
  ExpectRecovered(r.reference_from_cloud, small, 2e-3);
  EXPECT_LT(r.rmse_m, 0.5);
}

TEST(Align, DisjointCloudsOrTooFewPointsAreReported) {
  const std::vector<Eigen::Vector3d> reference = Terrain(2000, 6);
  std::vector<Eigen::Vector3d> far = Terrain(2000, 7);
  for (auto& p : far) p += Eigen::Vector3d(1e4, 0, 0);
  Options o;
  o.init = Init::kNone;
  EXPECT_THROW(Align(far, reference, o), NoResultError);
  EXPECT_THROW(Align({{0, 0, 0}}, reference, o), InputError);
  o.max_iterations = 0;
  EXPECT_THROW(Align(reference, reference, o), InputError);
}

TEST(Options, NamesRoundTripAndCheckNamesTheField) {
  for (Init i : {Init::kAuto, Init::kNone, Init::kPca})
    EXPECT_EQ(FromName(NameOf(i, kInitNames), kInitNames), i);
  for (Method m : {Method::kPointToPlane, Method::kPclPointToPoint})
    EXPECT_EQ(FromName(NameOf(m, kMethodNames), kMethodNames), m);
  EXPECT_FALSE(FromName("sideways", kInitNames));
  EXPECT_FALSE(FromName("Point_To_Plane", kMethodNames));
  EXPECT_EQ(ExpectedNames(kInitNames), "auto, none or pca");
  Options o;
  EXPECT_NO_THROW(o.Check());
  o.median_factor = 0.5;
  try {
    o.Check();
    ADD_FAILURE() << "median_factor 0.5 accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "icp.median_factor: must be > 1");
  }
}

TEST(SurfaceDistances, KnownOffsetsFromAPlaneAndBeyondItsEdge) {
  // Reference: the plane z = 0.1 x sampled on a 0.5 m grid over [0, 20]^2.
  std::vector<Eigen::Vector3d> ref;
  for (int i = 0; i <= 40; ++i)
    for (int j = 0; j <= 40; ++j) ref.emplace_back(0.5 * i, 0.5 * j, 0.05 * i);
  const Eigen::Vector3d n = Eigen::Vector3d(-0.1, 0, 1).normalized();
  std::vector<Eigen::Vector3d> pts;
  const std::vector<double> offsets = {0.0, 0.03, 0.2, 1.0};
  for (double d : offsets)
    pts.push_back(Eigen::Vector3d(7.3, 11.1, 0.73) + d * n);  // off-grid positions
  pts.emplace_back(30.0, 10.0, 3.0);  // 10 m beyond the edge, on the plane's extension
  const std::vector<double> dist = SurfaceDistances(pts, ref);
  for (size_t k = 0; k < offsets.size(); ++k) EXPECT_NEAR(dist[k], offsets[k], 1e-4) << k;
  EXPECT_GT(dist[4], 9.0);  // not 0: the surface ends at x = 20
}

}  // namespace
}  // namespace mound::icp
