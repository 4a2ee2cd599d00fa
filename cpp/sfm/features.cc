#include "sfm/features.h"

#include <algorithm>
#include <cmath>
#include <mutex>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/flann.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/error.h"

namespace mound::sfm {

ImageFeatures ExtractFeatures(const std::string& path, const FeatureOptions& o) {
  const cv::Mat bgr = cv::imread(path, cv::IMREAD_COLOR);
  if (bgr.empty()) throw InputError(path + ": cannot read the image (missing or not an image)");
  ImageFeatures f;
  f.width = bgr.cols;
  f.height = bgr.rows;
  const double scale = std::min(1.0, static_cast<double>(o.max_image_size) / std::max(bgr.cols, bgr.rows));
  cv::Mat small = bgr;
  if (scale < 1) cv::resize(bgr, small, cv::Size(), scale, scale, cv::INTER_AREA);
  cv::Mat grey;
  cv::cvtColor(small, grey, cv::COLOR_BGR2GRAY);
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc;
  cv::SIFT::create(o.max_features)->detectAndCompute(grey, cv::noArray(), kps, desc);
  f.descriptors.resize(static_cast<Eigen::Index>(kps.size()), 128);
  for (size_t k = 0; k < kps.size(); ++k) {
    // Pixel centres: full-image coordinate = (small coordinate + 0.5) / scale - 0.5.
    const double u = (kps[k].pt.x + 0.5) / scale - 0.5, v = (kps[k].pt.y + 0.5) / scale - 0.5;
    f.keypoints.emplace_back(u, v);
    const int x = std::clamp(static_cast<int>(std::lround(u)), 0, bgr.cols - 1);
    const int y = std::clamp(static_cast<int>(std::lround(v)), 0, bgr.rows - 1);
    const cv::Vec3b c = bgr.at<cv::Vec3b>(y, x);
    f.colors.push_back({c[2], c[1], c[0]});
    for (int j = 0; j < 128; ++j) f.descriptors(static_cast<Eigen::Index>(k), j) = desc.at<float>(static_cast<int>(k), j);
  }
  return f;
}

namespace {

cv::Mat AsMat(const ImageFeatures& f) {
  return cv::Mat(static_cast<int>(f.descriptors.rows()), 128, CV_32F,
                 const_cast<float*>(f.descriptors.data()));
}

}  // namespace

MatchList MatchDescriptors(const ImageFeatures& a, const ImageFeatures& b, float ratio) {
  MatchList out;
  if (a.descriptors.rows() < 2 || b.descriptors.rows() < 2) return out;
  // Approximate nearest neighbours (FLANN, randomised k-d trees) for large sets, as
  // COLMAP and OpenMVG do on the CPU; exact brute force for small ones.
  std::vector<std::vector<cv::DMatch>> ab, ba;
  const cv::Mat da = AsMat(a), db = AsMat(b);
  if (std::min(da.rows, db.rows) >= 1000) {
    // FLANN draws the trees' split dimensions from the C library's global rand(): build
    // each index under one lock from a fixed seed, so that the matches do not depend on
    // which thread got there first (searching draws nothing).
    auto trained = [](const cv::Mat& train) {
      auto m = cv::makePtr<cv::FlannBasedMatcher>(cv::makePtr<cv::flann::KDTreeIndexParams>(4),
                                                  cv::makePtr<cv::flann::SearchParams>(64));
      static std::mutex flann_rand;
      std::lock_guard<std::mutex> lock(flann_rand);
      cvflann::seed_random(1);
      m->add(std::vector<cv::Mat>{train});
      m->train();
      return m;
    };
    trained(db)->knnMatch(da, ab, 2);
    trained(da)->knnMatch(db, ba, 1);
  } else {
    cv::BFMatcher matcher(cv::NORM_L2);
    matcher.knnMatch(da, db, ab, 2);
    matcher.knnMatch(db, da, ba, 1);
  }
  for (const auto& m : ab) {
    if (m.size() < 2 || m[0].distance >= ratio * m[1].distance) continue;
    const auto& back = ba[m[0].trainIdx];
    if (back.empty() || back[0].trainIdx != m[0].queryIdx) continue;  // not mutual
    out.emplace_back(m[0].queryIdx, m[0].trainIdx);
  }
  return out;
}

VerifiedPair VerifyPair(int i1, int i2, const ImageFeatures& a, const ImageFeatures& b,
                        const MatchList& matches, const geometry::CameraModel& camera,
                        double max_error_px, uint64_t seed) {
  VerifiedPair out;
  out.image1 = i1;
  out.image2 = i2;
  if (matches.size() < 15) return out;
  // Undistorted pixels (K applied again), so the threshold is in pixels.
  std::vector<cv::Point2d> p1, p2;
  for (const auto& [k1, k2] : matches) {
    const Eigen::Vector2d x1 = camera.NormalisedFromImage(a.keypoints[k1]);
    const Eigen::Vector2d x2 = camera.NormalisedFromImage(b.keypoints[k2]);
    p1.emplace_back(camera.fx * x1.x() + camera.cx, camera.fy * x1.y() + camera.cy);
    p2.emplace_back(camera.fx * x2.x() + camera.cx, camera.fy * x2.y() + camera.cy);
  }
  cv::theRNG() = cv::RNG(seed);
  std::vector<unsigned char> mask, hmask;
  const cv::Mat F = cv::findFundamentalMat(p1, p2, cv::FM_RANSAC, max_error_px, 0.999, 2000, mask);
  if (F.empty() || mask.size() != matches.size()) return out;
  for (size_t i = 0; i < mask.size(); ++i)
    if (mask[i]) out.inliers.push_back(matches[i]);
  const cv::Mat H = cv::findHomography(p1, p2, cv::RANSAC, max_error_px, hmask, 2000, 0.999);
  if (!H.empty()) out.homography_inliers = static_cast<int>(std::count(hmask.begin(), hmask.end(), 1));
  return out;
}

}  // namespace mound::sfm
