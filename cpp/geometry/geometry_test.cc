// The shared camera model and transforms: OpenCV's distortion formula at hand-computed
// values, undistortion as its inverse, rigid-transform algebra, and Umeyama's similarity
// recovering a known one.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/error.h"
#include "geometry/camera_model.h"
#include "geometry/geodesy.h"
#include "geometry/rigid3.h"
#include "geometry/sim3.h"
#include "geometry/test_cameras.h"

namespace mound::geometry {
namespace {

using testing::DistortedCamera;

TEST(CameraModel, DistortionIsOpenCvsPolynomial) {
  const CameraModel c = DistortedCamera();
  const double x = 0.3, y = -0.2, r2 = x * x + y * y;
  const double radial = 1 - 0.12 * r2 + 0.03 * r2 * r2 + 0.001 * r2 * r2 * r2;
  const double xd = x * radial + 2 * 0.0008 * x * y + -0.0005 * (r2 + 2 * x * x);
  const double yd = y * radial + 0.0008 * (r2 + 2 * y * y) + 2 * -0.0005 * x * y;
  const Eigen::Vector2d uv = c.ImageFromNormalised({x, y});
  EXPECT_NEAR(uv.x(), 900 * xd + 640, 1e-9);
  EXPECT_NEAR(uv.y(), 905 * yd + 480, 1e-9);
  Eigen::Vector2d px;
  EXPECT_TRUE(c.ImageFromCamera(Eigen::Vector3d(3 * x, 3 * y, 3), &px));
  EXPECT_NEAR((px - uv).norm(), 0, 1e-9);
  EXPECT_FALSE(c.ImageFromCamera(Eigen::Vector3d(0.1, 0.1, -1), &px));
}

TEST(CameraModel, UndistortionInvertsDistortion) {
  const CameraModel c = DistortedCamera();
  for (double u : {0.0, 300.0, 640.0, 1279.0}) {
    for (double v : {0.0, 480.0, 959.0}) {
      const Eigen::Vector2d xy = c.NormalisedFromImage({u, v});
      EXPECT_NEAR((c.ImageFromNormalised(xy) - Eigen::Vector2d(u, v)).norm(), 0, 1e-8);
    }
  }
  const CameraModel round = CameraModel::FromParams(c.Params().data(), c.width, c.height);
  EXPECT_EQ(round.Params(), c.Params());
}

TEST(Rigid3d, ComposesInvertsAndFindsTheCentre) {
  const Rigid3d a(Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix(),
                  Eigen::Vector3d(1, -2, 5));
  const Rigid3d b(Eigen::AngleAxisd(-1.1, Eigen::Vector3d(0, 1, 0)).toRotationMatrix(),
                  Eigen::Vector3d(0.5, 0, -3));
  const Eigen::Vector3d x(0.3, 0.7, -1.9);
  EXPECT_NEAR(((a * b) * x - a * (b * x)).norm(), 0, 1e-12);
  EXPECT_NEAR((a.Inverse() * (a * x) - x).norm(), 0, 1e-12);
  EXPECT_NEAR((a * a.Centre()).norm(), 0, 1e-12);  // the camera centre maps to the origin
  EXPECT_NEAR(RotationAngle(a.rotation, (a * b).rotation * b.rotation.conjugate()), 0, 1e-12);
}

TEST(Rigid3d, LookAtPutsTheTargetOnTheOpticalAxisWithNorthUp) {
  const Eigen::Vector3d c(3, -20, 15), target(1, 2, 0);
  const Rigid3d cam_from_world = LookAt(c, target);
  const Eigen::Vector3d t = cam_from_world * target;
  EXPECT_NEAR(t.x(), 0, 1e-12);
  EXPECT_NEAR(t.y(), 0, 1e-12);
  EXPECT_NEAR(t.z(), (target - c).norm(), 1e-12);
  EXPECT_NEAR((cam_from_world.Centre() - c).norm(), 0, 1e-12);
  // A point north of the target appears above it in the image (smaller y).
  EXPECT_LT((cam_from_world * (target + Eigen::Vector3d(0, 1, 0))).y(), 0);
}

TEST(Rigid3d, LookAtAlongNorthIsARotationWithEastToTheRight) {
  // The degenerate case of the north-up rule (it gave NaN): as the Python twin, image x is
  // east and the rotation stays proper.
  for (const Eigen::Vector3d& dir : {Eigen::Vector3d(0, 5, 0), Eigen::Vector3d(0, -2, 0)}) {
    const Eigen::Vector3d c(1, 2, 3);
    const Rigid3d cam_from_world = LookAt(c, c + dir);
    const Eigen::Matrix3d R = cam_from_world.RotationMatrix();
    ASSERT_TRUE(R.allFinite());
    EXPECT_NEAR((R * R.transpose() - Eigen::Matrix3d::Identity()).norm(), 0, 1e-12);
    EXPECT_NEAR(R.determinant(), 1, 1e-12);
    EXPECT_NEAR((R.row(0).transpose() - Eigen::Vector3d(1, 0, 0)).norm(), 0, 1e-12);
    EXPECT_NEAR((R.row(2).transpose() - dir.normalized()).norm(), 0, 1e-12);
  }
  EXPECT_THROW(LookAt({1, 2, 3}, {1, 2, 3}), InputError);
}

TEST(Sim3d, UmeyamaRecoversAKnownSimilarity) {
  std::mt19937 rng(3);
  std::normal_distribution<double> g(0, 10);
  Sim3d truth;
  truth.scale = 2.7;
  truth.rotation = Eigen::AngleAxisd(2.0, Eigen::Vector3d(-1, 0.5, 2).normalized());
  truth.translation = {100, -40, 7};
  std::vector<Eigen::Vector3d> src, dst;
  for (int i = 0; i < 20; ++i) {
    src.emplace_back(g(rng), g(rng), g(rng));
    dst.push_back(truth * src.back());
  }
  const std::optional<Sim3d> s = EstimateSim3d(src, dst);
  ASSERT_TRUE(s);
  EXPECT_NEAR(s->scale, 2.7, 1e-9);
  EXPECT_NEAR(RotationAngle(s->rotation, truth.rotation), 0, 1e-9);
  EXPECT_NEAR((s->translation - truth.translation).norm(), 0, 1e-8);
  EXPECT_NEAR((s->Inverse() * dst[3] - src[3]).norm(), 0, 1e-9);
  // Collinear sources and too few pairs give no answer.
  EXPECT_FALSE(EstimateSim3d({{0, 0, 0}, {1, 1, 1}, {2, 2, 2}, {3, 3, 3}}, dst));
  EXPECT_FALSE(EstimateSim3d({src[0], src[1]}, {dst[0], dst[1]}));
  // Weighted: equal weights give the unweighted answer; a pair moved 50 m away and given
  // a millionth of the weight (an RTK float among fixes) barely moves it, unweighted it
  // does.
  const auto even = EstimateSim3d(src, dst, std::vector<double>(src.size(), 3.0));
  ASSERT_TRUE(even);
  EXPECT_NEAR(even->scale, 2.7, 1e-9);
  EXPECT_NEAR((even->translation - truth.translation).norm(), 0, 1e-7);
  std::vector<Eigen::Vector3d> bad = dst;
  bad[4] += Eigen::Vector3d(50, 0, 0);
  std::vector<double> w(src.size(), 1.0);
  w[4] = 1e-6;
  const auto weighted = EstimateSim3d(src, bad, w);
  const auto plain = EstimateSim3d(src, bad);
  ASSERT_TRUE(weighted && plain);
  EXPECT_LT((weighted->translation - truth.translation).norm(), 1e-3);
  EXPECT_GT((plain->translation - truth.translation).norm(), 1.0);
  EXPECT_FALSE(EstimateSim3d(src, dst, std::vector<double>(src.size() - 1, 1.0)));
  w[4] = 0;
  EXPECT_FALSE(EstimateSim3d(src, bad, w));
}

TEST(Sim3d, ComposesRightToLeftAndInverts) {
  Sim3d a, b;
  a.scale = 1.5;
  a.rotation = Eigen::AngleAxisd(0.7, Eigen::Vector3d(0, 0, 1));
  a.translation = {3, -2, 1};
  b.scale = 0.4;
  b.rotation = Eigen::AngleAxisd(-1.1, Eigen::Vector3d(1, 2, 0).normalized());
  b.translation = {-5, 0.5, 9};
  const Eigen::Vector3d x(2, -7, 4);
  EXPECT_NEAR(((a * b) * x - a * (b * x)).norm(), 0, 1e-12);
  EXPECT_NEAR(((a * a.Inverse()) * x - x).norm(), 0, 1e-12);
}

TEST(Skew, IsTheCrossProduct) {
  const Eigen::Vector3d v(0.3, -2, 5), w(-1, 4, 0.5);
  EXPECT_NEAR((Skew(v) * w - v.cross(w)).norm(), 0, 1e-12);
  EXPECT_NEAR((Skew(v) + Skew(v).transpose()).norm(), 0, 0);
}

TEST(Geodesy, Wgs84KnownPointsAndRoundTrips) {
  const Eigen::Vector3d equator = EcefFromGeodetic({0, 0, 0});
  EXPECT_NEAR((equator - Eigen::Vector3d(6378137.0, 0, 0)).norm(), 0, 1e-6);
  EXPECT_NEAR(EcefFromGeodetic({90, 0, 0}).z(), 6356752.314245, 1e-5);  // semi-minor axis
  const Geodetic origin{38.5705, 27.9862, 95.0};
  const Eigen::Vector3d up = EnuFromGeodetic(origin, {38.5705, 27.9862, 195.0});
  EXPECT_NEAR((up - Eigen::Vector3d(0, 0, 100)).norm(), 0, 1e-6);
  // One arc-second of latitude is about 30.8 m of northing here.
  const Eigen::Vector3d north = EnuFromGeodetic(origin, {38.5705 + 1.0 / 3600, 27.9862, 95.0});
  EXPECT_NEAR(north.y(), 30.85, 0.05);
  EXPECT_NEAR(north.x(), 0, 1e-6);
  for (const Eigen::Vector3d& enu :
       {Eigen::Vector3d(30000, -20000, 500), Eigen::Vector3d(-5, 7, -3)}) {
    EXPECT_NEAR((EnuFromGeodetic(origin, GeodeticFromEnu(origin, enu)) - enu).norm(), 0, 1e-6);
  }
}

}  // namespace
}  // namespace mound::geometry
