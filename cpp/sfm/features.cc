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
#include <opencv2/video/tracking.hpp>

#include "common/error.h"

namespace mound::sfm {

namespace {

struct Loaded {
  cv::Mat bgr, grey;  // grey at the working scale
  double scale = 1;
};

Loaded Load(const std::string& path, int max_image_size) {
  Loaded l;
  l.bgr = cv::imread(path, cv::IMREAD_COLOR);
  if (l.bgr.empty()) throw InputError(path + ": cannot read the image (missing or not an image)");
  l.scale = std::min(1.0, static_cast<double>(max_image_size) / std::max(l.bgr.cols, l.bgr.rows));
  cv::Mat small = l.bgr;
  if (l.scale < 1) cv::resize(l.bgr, small, cv::Size(), l.scale, l.scale, cv::INTER_AREA);
  cv::cvtColor(small, l.grey, cv::COLOR_BGR2GRAY);
  return l;
}

// Adds a keypoint at working-scale position p: full-image pixel centres, (p + 0.5) / scale
// - 0.5, and the colour there.
void AddKeypoint(const Loaded& l, const cv::Point2f& p, ImageFeatures* f) {
  const double u = (p.x + 0.5) / l.scale - 0.5, v = (p.y + 0.5) / l.scale - 0.5;
  f->keypoints.emplace_back(u, v);
  const int x = std::clamp(static_cast<int>(std::lround(u)), 0, l.bgr.cols - 1);
  const int y = std::clamp(static_cast<int>(std::lround(v)), 0, l.bgr.rows - 1);
  const cv::Vec3b c = l.bgr.at<cv::Vec3b>(y, x);
  f->colors.push_back({c[2], c[1], c[0]});
}

}  // namespace

ImageFeatures ExtractFeatures(const std::string& path, const FeatureOptions& o) {
  const Loaded l = Load(path, o.max_image_size);
  ImageFeatures f;
  f.width = l.bgr.cols;
  f.height = l.bgr.rows;
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc;
  cv::SIFT::create(o.max_features)->detectAndCompute(l.grey, cv::noArray(), kps, desc);
  f.descriptors.resize(static_cast<Eigen::Index>(kps.size()), 128);
  for (size_t k = 0; k < kps.size(); ++k) {
    AddKeypoint(l, kps[k].pt, &f);
    for (int j = 0; j < 128; ++j) f.descriptors(static_cast<Eigen::Index>(k), j) = desc.at<float>(static_cast<int>(k), j);
  }
  return f;
}

KltResult TrackKlt(const std::vector<std::string>& paths, const FeatureOptions& o) {
  KltResult r;
  Loaded prev;
  std::vector<cv::Point2f> prev_pts;  // working-scale positions of the previous keypoints
  const cv::TermCriteria term(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01);
  for (size_t k = 0; k < paths.size(); ++k) {
    Loaded cur = Load(paths[k], o.max_image_size);
    ImageFeatures f;
    f.width = cur.bgr.cols;
    f.height = cur.bgr.rows;
    std::vector<cv::Point2f> pts;
    MatchList matches;
    cv::Mat taken = cv::Mat::ones(cur.grey.size(), CV_8U) * 255;  // where new corners may go
    if (k > 0 && !prev_pts.empty() && cur.grey.size() == prev.grey.size()) {
      std::vector<cv::Point2f> fwd, back;
      std::vector<unsigned char> st1, st2;
      std::vector<float> err;
      cv::calcOpticalFlowPyrLK(prev.grey, cur.grey, prev_pts, fwd, st1, err, cv::Size(21, 21), 5, term);
      cv::calcOpticalFlowPyrLK(cur.grey, prev.grey, fwd, back, st2, err, cv::Size(21, 21), 5, term);
      for (size_t i = 0; i < prev_pts.size(); ++i) {
        const cv::Point2f& p = fwd[i];
        if (!st1[i] || !st2[i] || cv::norm(back[i] - prev_pts[i]) > 0.5f) continue;
        if (p.x < 0 || p.y < 0 || p.x > cur.grey.cols - 1 || p.y > cur.grey.rows - 1) continue;
        matches.emplace_back(static_cast<int>(i), static_cast<int>(pts.size()));
        pts.push_back(p);
        cv::circle(taken, p, 7, 0, -1);
      }
    }
    // New corners where nothing is tracked.
    std::vector<cv::Point2f> corners;
    const int want = o.max_features - static_cast<int>(pts.size());
    if (want > 0) cv::goodFeaturesToTrack(cur.grey, corners, want, 0.001, 7, taken, 7);
    pts.insert(pts.end(), corners.begin(), corners.end());
    for (const cv::Point2f& p : pts) AddKeypoint(cur, p, &f);
    if (k > 0) r.consecutive.push_back(std::move(matches));
    r.features.push_back(std::move(f));
    prev = std::move(cur);
    prev_pts = std::move(pts);
  }
  return r;
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
