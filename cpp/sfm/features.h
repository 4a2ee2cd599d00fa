// Features, matches and two-view geometry of an image set, the front end of the
// reconstruction (COLMAP's feature extraction, matching and geometric verification).
//
// SIFT (OpenCV) on the image downscaled to at most `max_image_size` pixels on its longer
// side; keypoints are reported in the full image's pixels (pixel (0, 0) is the centre of the
// top-left pixel). Matching: nearest neighbours by L2 with Lowe's ratio test, kept when
// mutual. Verification: RANSAC on the fundamental matrix of undistorted pixels; the
// homography's inliers are counted too (a pair a homography explains has little parallax).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "geometry/camera_model.h"

namespace mound::sfm {

struct ImageFeatures {
  int width = 0, height = 0;                   // of the full image
  std::vector<Eigen::Vector2d> keypoints;      // full-image pixels
  std::vector<std::array<uint8_t, 3>> colors;  // RGB at each keypoint
  Eigen::Matrix<float, Eigen::Dynamic, 128, Eigen::RowMajor> descriptors;
};

struct FeatureOptions {
  int max_image_size = 2000;  // longer side, pixels; larger images are downscaled
  // Real photos' settings (what the survey runs on a card; on Caliterra and fountain-P11
  // they match or beat pycolmap's cameras, docs/results.md issue 58). The simulated sites
  // (640 x 480 renders) take 4000 and 0.04 (python/mound/recon/defaults.py).
  int max_features = 6000;
  // SIFT's contrast threshold (OpenCV's, divided by the 3 scales of an octave for the DoG
  // peaks): 0.04 is OpenCV's default; COLMAP's peak threshold 0.02 / 3 is 0.02 here, which
  // finds ~2.5x the keypoints on a survey image; 0.01 finds COLMAP's density.
  double contrast_threshold = 0.01;
};

// OpenCV's own parallel loops (inside SIFT, resizing, RANSAC) use at most `threads` threads
// from now on (0: OpenCV's default, every core), so that a tool run with --threads N uses N
// cores, not N times the cores. Process-wide: call it before the work, not during it.
void SetLibraryThreads(int threads);

// InputError naming the file when it cannot be read as an image.
ImageFeatures ExtractFeatures(const std::string& path, const FeatureOptions& options);
// The same on an 8-bit grey image in memory (row-major, no downscaling; colours grey).
ImageFeatures ExtractFeatures(const uint8_t* grey, int width, int height, int max_features,
                              double contrast_threshold = 0.04);

// Keypoint index pairs (in a, in b).
using MatchList = std::vector<std::pair<int, int>>;

// The paper's alternative for small motions: tracking instead of matching. Shi-Tomasi
// corners tracked from each image into the next by pyramidal Lucas-Kanade (21 x 21 window,
// 4 levels) with a forward-backward check (0.5 px); an image's keypoints are the points
// tracked into it plus new corners away from them, so tracks run along the sequence.
// Returns the features of every image and, for k >= 1, the matches (k-1, k) in
// `consecutive[k - 1]`.
struct KltResult {
  std::vector<ImageFeatures> features;
  std::vector<MatchList> consecutive;
};
KltResult TrackKlt(const std::vector<std::string>& paths, const FeatureOptions& options);
// Descriptor matches of a in b (ratio test, mutual check), one per pixel pair
// (OnePerPixel).
MatchList MatchDescriptors(const ImageFeatures& a, const ImageFeatures& b, float ratio = 0.8f);

// OpenCV's SIFT returns one keypoint per dominant orientation at the same pixel (each with
// its own descriptor): 18 % of a real DJI card's observations were such twins, 36 % of
// Caliterra's 3-D points had a twin, counted twice in bundle adjustment. Both descriptors
// are kept for matching (COLMAP's choice: a second orientation finds matches the first
// misses); a match then names the first keypoint at its pixel, so that a pixel is observed
// once. FirstAtSamePixel: for each keypoint, the first one at exactly its position.
std::vector<int> FirstAtSamePixel(const ImageFeatures& f);
// The matches in those first keypoints' indices, each pixel pair once; a pixel whose
// orientations matched two different pixels of the other image is dropped (ambiguous).
MatchList OnePerPixel(const MatchList& matches, const std::vector<int>& first_a,
                      const std::vector<int>& first_b);

// The same for many pairs of one image set: each image's search index is built once, on
// first use, and shared by every pair it is in; the backward search of the mutual check
// runs only for the matches that passed the ratio test. The index: FLANN randomised k-d
// trees (4 trees, 64 checks) for 1,000 descriptors or more, brute force below; or cascade
// hashing (cascade_hash.h: codes centred on the set's mean descriptor, the 20 nearest in
// Hamming distance compared exactly); or exact (brute force over every descriptor: the
// reference the approximate ones are measured against, ~50x slower). Matches are one per
// pixel pair (OnePerPixel). Match() is thread-safe and its result does not depend on the
// order of calls or on the threads.
enum class MatcherKind { kFlann, kCascadeHash, kExact };

class DescriptorMatcher {
 public:
  explicit DescriptorMatcher(const std::vector<ImageFeatures>& features, float ratio = 0.8f,
                             MatcherKind kind = MatcherKind::kFlann);
  ~DescriptorMatcher();
  DescriptorMatcher(const DescriptorMatcher&) = delete;
  DescriptorMatcher& operator=(const DescriptorMatcher&) = delete;
  MatchList Match(int i, int j) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

struct VerifiedPair {
  int image1 = 0, image2 = 0;
  MatchList inliers;  // consistent with the fundamental matrix
  int homography_inliers = 0;
};

// Geometric verification of `matches` (RANSAC on F at `max_error_px` undistorted pixels).
VerifiedPair VerifyPair(int i1, int i2, const ImageFeatures& a, const ImageFeatures& b,
                        const MatchList& matches, const geometry::CameraModel& camera,
                        double max_error_px, uint64_t seed);

}  // namespace mound::sfm
