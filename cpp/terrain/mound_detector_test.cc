// The reference-free mound detector on constructed clouds: a dome on undulating, sloping
// ground is found and measured; the same ground without it, an elongated ridge and a
// sparse cloud are not mounds or are reported.
#include "terrain/mound_detector.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/error.h"

namespace mound::terrain {
namespace {

std::vector<Eigen::Vector3d> Site(double dome_h, double dome_d, bool ridge, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-60, 60);
  std::normal_distribution<double> g(0, 0.03);
  std::vector<Eigen::Vector3d> p;
  for (int i = 0; i < 80000; ++i) {
    const double x = u(rng), y = u(rng);
    double z = 50 + 0.03 * x - 0.02 * y + 0.4 * std::sin(x / 23.0 + 1) * std::cos(y / 31.0) + g(rng);
    const double r = std::hypot(x - 5, y + 3);
    if (dome_h > 0 && r < dome_d / 2) z += dome_h * (1 - 4 * r * r / (dome_d * dome_d));
    if (ridge && std::fabs(y) < 3 && std::fabs(x) < 40) z += 2.0 * (1 - y * y / 9);
    p.emplace_back(x, y, z);
  }
  return p;
}

TEST(DetectMound, FindsAndMeasuresADome) {
  const Detection d = DetectMound(Site(6.0, 40.0, false, 1), {0, 0}, 58, DetectorOptions{});
  ASSERT_TRUE(d.tallest.has_value());
  EXPECT_TRUE(d.mound) << d.reason;
  EXPECT_GT(d.confidence, 0.9);
  const Rise& r = *d.tallest;
  EXPECT_NEAR(r.height_m, 6.0, 0.5) << d.reason;
  EXPECT_NEAR(r.base_diameter_m, 40.0, 4.0) << d.reason;
  EXPECT_LT((r.centre - Eigen::Vector2d(5, -3)).norm(), 1.0);
  // Paraboloid volume pi R^2 H / 2 = 3770 m^3; the rise above 0.3 m holds most of it.
  EXPECT_NEAR(r.volume_m3, M_PI * 400 * 6 / 2, 500);
  EXPECT_GT(r.roundness, 0.9);
  EXPECT_GT(r.dome_r2, 0.9);
  EXPECT_LT(d.ground_noise_m, 0.2);
}

TEST(DetectMound, FlatGroundAndARidgeAreNoMound) {
  const Detection flat = DetectMound(Site(0, 0, false, 2), {0, 0}, 58, DetectorOptions{});
  EXPECT_FALSE(flat.mound) << flat.reason;
  const Detection ridge = DetectMound(Site(0, 0, true, 3), {0, 0}, 58, DetectorOptions{});
  EXPECT_FALSE(ridge.mound) << ridge.reason;
  ASSERT_TRUE(ridge.tallest.has_value());
  EXPECT_LT(ridge.tallest->roundness, 0.3);  // 80 m long, 6 m wide
}

TEST(DetectMound, TooFewPointsOrBadRadius) {
  std::vector<Eigen::Vector3d> few(50, Eigen::Vector3d::Zero());
  EXPECT_THROW(DetectMound(few, {0, 0}, 10, DetectorOptions{}), NoResultError);
  EXPECT_THROW(DetectMound(few, {0, 0}, 0, DetectorOptions{}), InputError);
}

}  // namespace
}  // namespace mound::terrain
