#include "sfm/features.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <mutex>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/flann.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>
#include <unordered_map>

#include "common/error.h"
#include "sfm/cascade_hash.h"

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

namespace {

ImageFeatures Sift(const Loaded& l, int max_features, double contrast_threshold) {
  ImageFeatures f;
  f.width = l.bgr.cols;
  f.height = l.bgr.rows;
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc;
  cv::SIFT::create(max_features, 3, contrast_threshold)
      ->detectAndCompute(l.grey, cv::noArray(), kps, desc);
  f.descriptors.resize(static_cast<Eigen::Index>(kps.size()), 128);
  // OpenCV's SIFT builds its pyramid on the image upsampled 2x by linear interpolation
  // (output pixel X samples the input at X / 2 - 0.25) and halves it by taking every other
  // pixel, yet reports positions as octave pixel x 2^(octave - 1): every keypoint lies
  // 0.25 px right of and below the image content it was found on (opencv/opencv#23123;
  // features_test.cc measures it). Uncorrected, the bias acts as a shifted principal point
  // and bends the model (camera centres on the simulated orbit: 9.9 mm -> 3.8 mm).
  constexpr float kSiftBiasPx = 0.25f;
  for (size_t k = 0; k < kps.size(); ++k) {
    AddKeypoint(l, kps[k].pt - cv::Point2f(kSiftBiasPx, kSiftBiasPx), &f);
    for (int j = 0; j < 128; ++j)
      f.descriptors(static_cast<Eigen::Index>(k), j) = desc.at<float>(static_cast<int>(k), j);
  }
  return f;
}

}  // namespace

void SetLibraryThreads(int threads) { cv::setNumThreads(threads > 0 ? threads : -1); }

ImageFeatures ExtractFeatures(const std::string& path, const FeatureOptions& o) {
  return Sift(Load(path, o.max_image_size), o.max_features, o.contrast_threshold);
}

ImageFeatures ExtractFeatures(const uint8_t* grey, int width, int height, int max_features,
                              double contrast_threshold) {
  if (grey == nullptr || width <= 0 || height <= 0) throw InputError("image: empty grey image");
  Loaded l;
  l.grey = cv::Mat(height, width, CV_8UC1, const_cast<uint8_t*>(grey)).clone();
  cv::cvtColor(l.grey, l.bgr, cv::COLOR_GRAY2BGR);
  return Sift(l, max_features, contrast_threshold);
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
      cv::calcOpticalFlowPyrLK(prev.grey, cur.grey, prev_pts, fwd, st1, err, cv::Size(21, 21), 5,
                               term);
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

// Nearest-neighbour search over one image's descriptors: approximate (FLANN, randomised
// k-d trees) for large sets, as COLMAP and OpenMVG do on the CPU; exact brute force for
// small ones.
class SearchIndex {
 public:
  explicit SearchIndex(const ImageFeatures& f, bool exact = false) : train_(AsMat(f)) {
    if (exact || train_.rows < 1000) return;
    // FLANN draws the trees' split dimensions from the C library's global rand(): build
    // each index under one lock from a fixed seed, so that the trees do not depend on
    // which thread got there first (searching draws nothing).
    static std::mutex flann_rand;
    std::lock_guard<std::mutex> lock(flann_rand);
    cvflann::seed_random(1);
    flann_ = std::make_unique<cv::flann::Index>(train_, cv::flann::KDTreeIndexParams(4));
  }
  // The k nearest training rows of each query row (index -1 where fewer exist).
  void Search(const cv::Mat& queries, int k, cv::Mat* indices, cv::Mat* dists) const {
    if (flann_) {
      flann_->knnSearch(queries, *indices, *dists, k, cv::flann::SearchParams(64));
      return;
    }
    std::vector<std::vector<cv::DMatch>> m;
    cv::BFMatcher(cv::NORM_L2).knnMatch(queries, train_, m, k);
    *indices = cv::Mat(queries.rows, k, CV_32S, cv::Scalar(-1));
    *dists = cv::Mat(queries.rows, k, CV_32F, cv::Scalar(0));
    for (size_t q = 0; q < m.size(); ++q)
      for (size_t r = 0; r < m[q].size() && static_cast<int>(r) < k; ++r) {
        indices->at<int>(static_cast<int>(q), static_cast<int>(r)) = m[q][r].trainIdx;
        // FLANN reports squared L2 distances: so does this.
        dists->at<float>(static_cast<int>(q), static_cast<int>(r)) =
            m[q][r].distance * m[q][r].distance;
      }
  }

 private:
  cv::Mat train_;  // a view of the features' descriptors
  std::unique_ptr<cv::flann::Index> flann_;
};

// Ratio test on a's nearest two in b, then the mutual check: b's nearest in a, searched
// only for the survivors.
MatchList MatchWith(const ImageFeatures& a, const SearchIndex& index_a, const ImageFeatures& b,
                    const SearchIndex& index_b, float ratio) {
  MatchList out;
  if (a.descriptors.rows() < 2 || b.descriptors.rows() < 2) return out;
  cv::Mat idx, dist;
  index_b.Search(AsMat(a), 2, &idx, &dist);
  const float ratio2 = ratio * ratio;  // squared distances
  std::vector<std::pair<int, int>> candidates;
  for (int q = 0; q < idx.rows; ++q) {
    const int n0 = idx.at<int>(q, 0), n1 = idx.at<int>(q, 1);
    if (n0 < 0 || n1 < 0 || !(dist.at<float>(q, 0) < ratio2 * dist.at<float>(q, 1))) continue;
    candidates.emplace_back(q, n0);
  }
  if (candidates.empty()) return out;
  cv::Mat back_queries(static_cast<int>(candidates.size()), 128, CV_32F);
  for (size_t c = 0; c < candidates.size(); ++c)
    std::memcpy(back_queries.ptr<float>(static_cast<int>(c)),
                b.descriptors.row(candidates[c].second).data(), 128 * sizeof(float));
  cv::Mat back_idx, back_dist;
  index_a.Search(back_queries, 1, &back_idx, &back_dist);
  for (size_t c = 0; c < candidates.size(); ++c)
    if (back_idx.at<int>(static_cast<int>(c), 0) == candidates[c].first)
      out.push_back(candidates[c]);
  return out;
}

}  // namespace

std::vector<int> FirstAtSamePixel(const ImageFeatures& f) {
  std::vector<int> first(f.keypoints.size());
  // Exactly the same position: OpenCV gives every orientation of a keypoint the same one.
  std::map<std::pair<double, double>, int> seen;
  for (size_t k = 0; k < f.keypoints.size(); ++k)
    first[k] =
        seen.emplace(std::make_pair(f.keypoints[k].x(), f.keypoints[k].y()), static_cast<int>(k))
            .first->second;
  return first;
}

MatchList OnePerPixel(const MatchList& matches, const std::vector<int>& first_a,
                      const std::vector<int>& first_b) {
  MatchList m;
  m.reserve(matches.size());
  for (const auto& [i, j] : matches) {
    const bool in_range = i >= 0 && j >= 0 && static_cast<size_t>(i) < first_a.size() &&
                          static_cast<size_t>(j) < first_b.size();
    if (!in_range) throw InternalError("OnePerPixel: a match names no keypoint");
    m.emplace_back(first_a[static_cast<size_t>(i)], first_b[static_cast<size_t>(j)]);
  }
  std::sort(m.begin(), m.end());
  m.erase(std::unique(m.begin(), m.end()), m.end());
  // A pixel matched to two different pixels (its orientations disagree): neither is kept.
  std::unordered_map<int, int> uses_a, uses_b;
  for (const auto& [i, j] : m) {
    ++uses_a[i];
    ++uses_b[j];
  }
  MatchList out;
  out.reserve(m.size());
  for (const auto& [i, j] : m)
    if (uses_a[i] == 1 && uses_b[j] == 1) out.emplace_back(i, j);
  return out;
}

MatchList MatchDescriptors(const ImageFeatures& a, const ImageFeatures& b, float ratio) {
  return OnePerPixel(MatchWith(a, SearchIndex(a), b, SearchIndex(b), ratio), FirstAtSamePixel(a),
                     FirstAtSamePixel(b));
}

namespace {

Eigen::Matrix<float, 1, 128> MeanDescriptor(const std::vector<ImageFeatures>& features) {
  Eigen::Matrix<double, 1, 128> sum = Eigen::Matrix<double, 1, 128>::Zero();
  double count = 0;
  for (const ImageFeatures& f : features) {
    sum += f.descriptors.cast<double>().colwise().sum();
    count += static_cast<double>(f.descriptors.rows());
  }
  return count > 0 ? Eigen::Matrix<float, 1, 128>((sum / count).cast<float>())
                   : Eigen::Matrix<float, 1, 128>::Zero();
}

constexpr int kCascadeCandidates = 20;

// The ratio test and mutual check of MatchWith, on cascade hashes.
MatchList MatchHashed(const ImageFeatures& a, const CascadeHasher::Hashed& ha,
                      const ImageFeatures& b, const CascadeHasher::Hashed& hb,
                      const CascadeHasher& hasher, float ratio) {
  MatchList out;
  if (a.descriptors.rows() < 2 || b.descriptors.rows() < 2) return out;
  std::vector<std::array<int, 2>> idx;
  std::vector<std::array<float, 2>> d2;
  hasher.Nearest2(a.descriptors, ha, b.descriptors, hb, {}, kCascadeCandidates, &idx, &d2);
  const float ratio2 = ratio * ratio;
  std::vector<std::pair<int, int>> candidates;
  std::vector<int> back_rows;
  for (int q = 0; q < static_cast<int>(idx.size()); ++q) {
    if (idx[q][0] < 0 || idx[q][1] < 0 || !(d2[q][0] < ratio2 * d2[q][1])) continue;
    candidates.emplace_back(q, idx[q][0]);
    back_rows.push_back(idx[q][0]);
  }
  if (candidates.empty()) return out;
  hasher.Nearest2(b.descriptors, hb, a.descriptors, ha, back_rows, kCascadeCandidates, &idx, &d2);
  for (size_t c = 0; c < candidates.size(); ++c)
    if (idx[c][0] == candidates[c].first) out.push_back(candidates[c]);
  return out;
}

}  // namespace

struct DescriptorMatcher::Impl {
  const std::vector<ImageFeatures>& features;
  float ratio;
  MatcherKind kind;
  mutable std::vector<std::unique_ptr<SearchIndex>> index;
  mutable std::vector<std::unique_ptr<CascadeHasher::Hashed>> hashed;
  mutable std::vector<std::once_flag> built;
  std::unique_ptr<CascadeHasher> hasher;
  std::vector<std::vector<int>> first_at;  // FirstAtSamePixel of each image
  const SearchIndex& Index(int i) const {
    std::call_once(built[i], [&] {
      index[i] = std::make_unique<SearchIndex>(features[i], kind == MatcherKind::kExact);
    });
    return *index[i];
  }
  const CascadeHasher::Hashed& Hash(int i) const {
    std::call_once(built[i], [&] {
      hashed[i] = std::make_unique<CascadeHasher::Hashed>(hasher->Hash(features[i].descriptors));
    });
    return *hashed[i];
  }
};

DescriptorMatcher::DescriptorMatcher(const std::vector<ImageFeatures>& features, float ratio,
                                     MatcherKind kind)
    : impl_(new Impl{features,
                     ratio,
                     kind,
                     std::vector<std::unique_ptr<SearchIndex>>(features.size()),
                     std::vector<std::unique_ptr<CascadeHasher::Hashed>>(features.size()),
                     std::vector<std::once_flag>(features.size()),
                     nullptr,
                     {}}) {
  impl_->first_at.reserve(features.size());
  for (const ImageFeatures& f : features) impl_->first_at.push_back(FirstAtSamePixel(f));
  if (kind == MatcherKind::kCascadeHash)
    impl_->hasher = std::make_unique<CascadeHasher>(MeanDescriptor(features));
}

DescriptorMatcher::~DescriptorMatcher() = default;

MatchList DescriptorMatcher::Match(int i, int j) const {
  const int n = static_cast<int>(impl_->features.size());
  if (i < 0 || j < 0 || i >= n || j >= n)
    throw InternalError("DescriptorMatcher::Match: image out of range");
  const MatchList m = impl_->kind == MatcherKind::kCascadeHash
                          ? MatchHashed(impl_->features[i], impl_->Hash(i), impl_->features[j],
                                        impl_->Hash(j), *impl_->hasher, impl_->ratio)
                          : MatchWith(impl_->features[i], impl_->Index(i), impl_->features[j],
                                      impl_->Index(j), impl_->ratio);
  return OnePerPixel(m, impl_->first_at[i], impl_->first_at[j]);
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
  if (!H.empty())
    out.homography_inliers = static_cast<int>(std::count(hmask.begin(), hmask.end(), 1));
  return out;
}

}  // namespace mound::sfm
