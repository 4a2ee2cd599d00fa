// Benchmark (not a test): can features be tracked in the simulator's images?
//
//   build/tools/bench/mound_bench_features SITE_DIR
//
// For pairs of images of a simulated site (each image with the next one of the
// same flight pattern), detects up to 4,000 SIFT features (OpenCV), matches them with
// Lowe's ratio test (0.8) and counts the inliers of a RANSAC fundamental matrix (1 px,
// 0.999). Prints one line per pair and the median inlier count per pattern.
#include <algorithm>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: mound_bench_features SITE_DIR\n";
    return 2;
  }
  const std::string dir = argv[1];
  std::ifstream in(dir + "/poses.json");
  if (!in) {
    std::cerr << "mound_bench_features: cannot read " << dir << "/poses.json\n";
    return 2;
  }
  const nlohmann::json poses = nlohmann::json::parse(in);
  const nlohmann::json& images = poses.at("images");
  cv::Ptr<cv::SIFT> sift = cv::SIFT::create(4000);
  std::vector<std::vector<cv::KeyPoint>> keypoints(images.size());
  std::vector<cv::Mat> descriptors(images.size());
  for (size_t k = 0; k < images.size(); ++k) {
    const cv::Mat grey = cv::imread(dir + "/" + images[k].at("file").get<std::string>(),
                                    cv::IMREAD_GRAYSCALE);
    sift->detectAndCompute(grey, cv::noArray(), keypoints[k], descriptors[k]);
  }
  cv::BFMatcher matcher(cv::NORM_L2);
  std::map<std::string, std::vector<int>> per_pattern;
  for (size_t a = 0; a + 1 < images.size(); ++a) {
    const size_t b = a + 1;
    const std::string pattern = images[a].at("pattern");
    if (images[b].at("pattern") != pattern) continue;
    std::vector<std::vector<cv::DMatch>> knn;
    matcher.knnMatch(descriptors[a], descriptors[b], knn, 2);
    std::vector<cv::Point2f> pa, pb;
    for (const auto& m : knn) {
      if (m.size() == 2 && m[0].distance < 0.8f * m[1].distance) {
        pa.push_back(keypoints[a][m[0].queryIdx].pt);
        pb.push_back(keypoints[b][m[0].trainIdx].pt);
      }
    }
    int inliers = 0;
    if (pa.size() >= 8) {
      std::vector<unsigned char> mask;
      cv::findFundamentalMat(pa, pb, cv::FM_RANSAC, 1.0, 0.999, mask);
      inliers = static_cast<int>(std::count(mask.begin(), mask.end(), 1));
    }
    per_pattern[pattern].push_back(inliers);
    std::cout << pattern << " " << a << "-" << b << ": " << keypoints[a].size() << "/"
              << keypoints[b].size() << " features, " << pa.size() << " ratio-test matches, "
              << inliers << " RANSAC inliers\n";
  }
  for (auto& [pattern, v] : per_pattern) {
    std::sort(v.begin(), v.end());
    std::cout << pattern << ": median " << v[v.size() / 2] << " inliers, min " << v.front()
              << " over " << v.size() << " consecutive pairs\n";
  }
  return 0;
}
