#include "sfm/two_view.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "ba/bundle_adjuster.h"
#include "common/error.h"
#include "sfm/features.h"

namespace mound::sfm {
using geometry::Skew;

namespace {

cv::Mat AsMat(const GreyImage& g) {
  if (g.width <= 0 || g.height <= 0 || g.pixels.size() != static_cast<size_t>(g.width) * g.height) {
    throw InputError("image: empty or inconsistent grey image");
  }
  return cv::Mat(g.height, g.width, CV_8UC1, const_cast<uint8_t*>(g.pixels.data()));
}

}  // namespace

GreyImage LoadGrey(const std::string& path) {
  const cv::Mat m = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (m.empty()) throw InputError(path + ": cannot read the image (missing or not an image)");
  GreyImage g;
  g.width = m.cols;
  g.height = m.rows;
  g.pixels.assign(m.datastart, m.dataend);
  return g;
}

Matches MatchFeatures(const GreyImage& a, const GreyImage& b, int max_features) {
  AsMat(a);  // validates
  AsMat(b);
  const ImageFeatures fa = ExtractFeatures(a.pixels.data(), a.width, a.height, max_features);
  const ImageFeatures fb = ExtractFeatures(b.pixels.data(), b.width, b.height, max_features);
  Matches out;
  for (const auto& [i, j] : MatchDescriptors(fa, fb)) {
    out.px1.push_back(fa.keypoints[i]);
    out.px2.push_back(fb.keypoints[j]);
  }
  return out;
}

std::vector<Eigen::Vector3d> Normalise(const std::vector<Eigen::Vector2d>& px,
                                       const geometry::CameraModel& K) {
  std::vector<Eigen::Vector3d> out;
  if (px.empty()) return out;
  cv::Mat src(static_cast<int>(px.size()), 1, CV_64FC2), dst;
  for (size_t i = 0; i < px.size(); ++i)
    src.at<cv::Vec2d>(static_cast<int>(i)) = {px[i].x(), px[i].y()};
  const cv::Matx33d Km(K.fx, 0, K.cx, 0, K.fy, K.cy, 0, 0, 1);
  cv::undistortPoints(src, dst, Km, std::vector<double>(K.dist.begin(), K.dist.end()));
  for (size_t i = 0; i < px.size(); ++i) {
    const cv::Vec2d v = dst.at<cv::Vec2d>(static_cast<int>(i));
    out.emplace_back(v[0], v[1], 1.0);
  }
  return out;
}

// Eqs. (9)-(11): the stacked epipolar system, solved exactly (see the header).
Eigen::VectorXd StackedEpipolarDepths(const std::vector<Eigen::Vector3d>& x1,
                                      const std::vector<Eigen::Vector3d>& x2,
                                      const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
  const size_t n = x1.size();
  // M^T M = [diag(d) b; b^T c].
  std::vector<double> d(n), b(n);
  std::vector<bool> valid(n);
  double c = 0, d_min = std::numeric_limits<double>::infinity();
  for (size_t j = 0; j < n; ++j) {
    const Eigen::Matrix3d s = Skew(x2[j]);
    const Eigen::Vector3d a = s * (R * x1[j]);
    const Eigen::Vector3d e = s * t;
    d[j] = a.squaredNorm();
    b[j] = a.dot(e);
    c += e.squaredNorm();
    valid[j] = d[j] > 1e-12 * (x1[j].squaredNorm() * x2[j].squaredNorm());
    if (valid[j]) d_min = std::min(d_min, d[j]);
  }
  Eigen::VectorXd v = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n) + 1);
  if (!std::isfinite(d_min)) return v;
  // The smallest eigenvalue mu solves f(mu) = c - mu - sum b_j^2 / (d_j - mu) = 0 on
  // [0, d_min), where f decreases from f(0) (the Schur complement, >= 0) to -infinity.
  auto f = [&](double mu) {
    double s = c - mu;
    for (size_t j = 0; j < n; ++j)
      if (valid[j]) s -= b[j] * b[j] / (d[j] - mu);
    return s;
  };
  double lo = 0, hi = d_min;
  if (f(0) > 0) {
    for (int it = 0; it < 200 && hi - lo > 1e-300; ++it) {
      const double mid = 0.5 * (lo + hi);
      if (mid <= lo || mid >= hi) break;
      (f(mid) > 0 ? lo : hi) = mid;
    }
  }
  const double mu = lo;
  // Eigenvector: (d_j - mu) lambda_j + b_j gamma = 0, with gamma = 1, then unit norm.
  for (size_t j = 0; j < n; ++j) {
    if (valid[j]) v[static_cast<Eigen::Index>(j)] = -b[j] / (d[j] - mu);
  }
  v[static_cast<Eigen::Index>(n)] = 1.0;
  return v / v.norm();
}

TwoViewResult InitialiseTwoView(const Matches& m, const geometry::CameraModel& K, double ransac_px,
                                uint64_t seed) {
  const size_t n = m.px1.size();
  if (m.px2.size() != n) throw InternalError("InitialiseTwoView: px1 and px2 differ in length");
  if (n < 8) throw NoResultError("two-view: need at least 8 matches, got " + std::to_string(n));
  const std::vector<Eigen::Vector3d> x1 = Normalise(m.px1, K), x2 = Normalise(m.px2, K);
  // RANSAC on undistorted pixel coordinates, so that the threshold is in pixels.
  std::vector<cv::Point2d> p1, p2;
  for (size_t i = 0; i < n; ++i) {
    p1.emplace_back(K.fx * x1[i].x() + K.cx, K.fy * x1[i].y() + K.cy);
    p2.emplace_back(K.fx * x2[i].x() + K.cx, K.fy * x2[i].y() + K.cy);
  }
  cv::theRNG() = cv::RNG(seed);
  std::vector<unsigned char> mask;
  cv::findFundamentalMat(p1, p2, cv::FM_RANSAC, ransac_px, 0.999, mask);
  TwoViewResult r;
  r.matches = static_cast<int>(n);
  std::vector<cv::Point2d> q1, q2;
  for (size_t i = 0; i < mask.size(); ++i) {
    if (mask[i]) {
      r.inliers.push_back(static_cast<int>(i));
      q1.push_back(p1[i]);
      q2.push_back(p2[i]);
    }
  }
  if (r.inliers.size() < 8) {
    throw NoResultError("two-view: " + std::to_string(r.inliers.size()) +
                        " RANSAC inliers, need at least 8 (too little overlap or texture?)");
  }
  // The 8-point algorithm (Hartley-normalised, in OpenCV) on every inlier.
  const cv::Mat F = cv::findFundamentalMat(q1, q2, cv::FM_8POINT);
  if (F.rows != 3) throw NoResultError("two-view: the 8-point algorithm found no solution");
  Eigen::Matrix3d Fe, Ke;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) Fe(i, j) = F.at<double>(i, j);
  Ke = K.K();
  const Eigen::Matrix3d E = Ke.transpose() * Fe * Ke;
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(E, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU(), V = svd.matrixV();
  if (U.determinant() < 0) U = -U;
  if (V.determinant() < 0) V = -V;
  Eigen::Matrix3d W;
  W << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  const Eigen::Matrix3d Rs[2] = {U * W * V.transpose(), U * W.transpose() * V.transpose()};
  const Eigen::Vector3d u3 = U.col(2);
  std::vector<Eigen::Vector3d> y1, y2;
  for (int i : r.inliers) {
    y1.push_back(x1[i]);
    y2.push_back(x2[i]);
  }
  int best = -1;
  for (const Eigen::Matrix3d& R : Rs) {
    for (double sign : {1.0, -1.0}) {
      const Eigen::Vector3d t = sign * u3;
      const Eigen::VectorXd v = StackedEpipolarDepths(y1, y2, R, t);
      const double gamma = v[v.size() - 1];
      if (gamma <= 1e-12) continue;
      std::vector<double> d1, d2;
      int positive = 0;
      for (size_t j = 0; j < y1.size(); ++j) {
        const double l1 = v[static_cast<Eigen::Index>(j)] / gamma;
        const Eigen::Vector3d X2 = l1 * (R * y1[j]) + t;
        const double l2 = X2.z();
        d1.push_back(l1);
        d2.push_back(l2);
        if (l1 > 0 && l2 > 0) ++positive;
      }
      if (positive > best) {
        best = positive;
        r.cam2_from_cam1 = geometry::Rigid3d(R, t);
        r.depth1 = d1;
        r.depth2 = d2;
        r.positive_depth = positive;
      }
    }
  }
  if (best <= 0) throw NoResultError("two-view: no pose puts the points in front of both cameras");
  return r;
}

std::pair<double, double> RefineTwoView(const Matches& m, const geometry::CameraModel& K,
                                        TwoViewResult* r) {
  ba::Problem p;
  p.camera = K;
  p.cam_from_world = {geometry::Rigid3d(), r->cam2_from_cam1};
  std::vector<Eigen::Vector2d> px;
  for (int i : r->inliers) px.push_back(m.px1[i]);
  const std::vector<Eigen::Vector3d> x1 = Normalise(px, K);
  std::vector<int> index(r->inliers.size(), -1);
  for (size_t k = 0; k < r->inliers.size(); ++k) {
    if (!(r->depth1[k] > 0 && r->depth2[k] > 0)) continue;  // behind a camera: left out
    index[k] = static_cast<int>(p.points.size());
    p.points.push_back(r->depth1[k] * x1[k]);
    const int i = r->inliers[k];
    p.observations.push_back({0, index[k], m.px1[i]});
    p.observations.push_back({1, index[k], m.px2[i]});
  }
  ba::Options o;
  o.fixed_view = 0;
  o.scale_view = 1;
  const ba::Summary s = ba::Adjust(&p, o);
  r->cam2_from_cam1 = p.cam_from_world[1];
  for (size_t k = 0; k < index.size(); ++k) {
    if (index[k] < 0) continue;
    const Eigen::Vector3d& X = p.points[index[k]];
    r->depth1[k] = X.z();
    r->depth2[k] = (r->cam2_from_cam1 * X).z();
  }
  return {s.initial_rmse_px, s.final_rmse_px};
}

}  // namespace mound::sfm
