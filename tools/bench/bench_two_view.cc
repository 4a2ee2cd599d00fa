// Benchmark (not a test): two-view initialisation (cpp/sfm) on a simulated site's images
// against the simulator's ground-truth poses.
//
//   build/tools/bench/mound_bench_two_view SITE_DIR
//
// For each image and the next one of the same flight pattern: SIFT matches, RANSAC +
// 8-point pose, stacked-epipolar depths, then two-view bundle adjustment; prints matches,
// inliers (how well the images can be tracked), the rotation error and the
// translation-direction error against poses.json (degrees) before and after the
// adjustment, and the medians.
#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "sfm/two_view.h"

namespace {

mound::geometry::Rigid3d CamFromWorld(const nlohmann::json& im) {
  const auto& p = im.at("cam_from_world");
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) R(r, c) = p.at("R")[r][c].get<double>();
    t[r] = p.at("t")[r].get<double>();
  }
  return {R, t};
}

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? NAN : v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: mound_bench_two_view SITE_DIR\n";
    return 2;
  }
  const std::string dir = argv[1];
  std::ifstream pf(dir + "/poses.json"), cf(dir + "/camera.json");
  if (!pf || !cf) {
    std::cerr << "mound_bench_two_view: " << dir << " needs poses.json and camera.json\n";
    return 2;
  }
  const nlohmann::json poses = nlohmann::json::parse(pf), camera = nlohmann::json::parse(cf);
  mound::geometry::CameraModel K;
  K.fx = camera.at("K")[0][0];
  K.fy = camera.at("K")[1][1];
  K.cx = camera.at("K")[0][2];
  K.cy = camera.at("K")[1][2];
  for (int k = 0; k < 5; ++k) K.dist[k] = camera.at("dist_k1k2p1p2k3")[k];
  const auto& images = poses.at("images");
  std::vector<double> rot, dir_err, rot_init, dir_init, secs;
  std::map<std::string, std::vector<double>> inliers;  // per flight pattern
  for (size_t a = 0; a + 1 < images.size(); ++a) {
    if (images[a].at("pattern") != images[a + 1].at("pattern")) continue;
    const auto t0 = std::chrono::steady_clock::now();
    const mound::sfm::Matches m = mound::sfm::MatchFeatures(
        mound::sfm::LoadGrey(dir + "/" + images[a].at("file").get<std::string>()),
        mound::sfm::LoadGrey(dir + "/" + images[a + 1].at("file").get<std::string>()));
    mound::sfm::TwoViewResult r = mound::sfm::InitialiseTwoView(m, K);
    const Eigen::Matrix3d R_init = r.cam2_from_cam1.RotationMatrix();
    const Eigen::Vector3d t_init = r.cam2_from_cam1.translation;
    const std::pair<double, double> rmse = mound::sfm::RefineTwoView(m, K, &r);
    secs.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    const mound::geometry::Rigid3d truth =
        CamFromWorld(images[a + 1]) * CamFromWorld(images[a]).Inverse();
    const Eigen::Matrix3d R_true = truth.RotationMatrix();
    const Eigen::Vector3d t_true = truth.translation.normalized();
    auto rot_deg = [&](const Eigen::Matrix3d& R) {
      return Eigen::AngleAxisd(R * R_true.transpose()).angle() * 180 / M_PI;
    };
    auto dir_deg = [&](const Eigen::Vector3d& t) {
      return std::acos(std::clamp(t.dot(t_true), -1.0, 1.0)) * 180 / M_PI;
    };
    inliers[images[a].at("pattern").get<std::string>()].push_back(r.inliers.size());
    rot_init.push_back(rot_deg(R_init));
    dir_init.push_back(dir_deg(t_init));
    rot.push_back(rot_deg(r.cam2_from_cam1.RotationMatrix()));
    dir_err.push_back(dir_deg(r.cam2_from_cam1.translation));
    std::cout << images[a].at("pattern").get<std::string>() << " " << a << "-" << a + 1 << ": "
              << m.px1.size() << " matches, " << r.inliers.size()
              << " inliers; 8-point: " << rot_init.back() << " / " << dir_init.back()
              << " deg; after BA (" << rmse.first << " -> " << rmse.second << " px): " << rot.back()
              << " / " << dir_err.back() << " deg (rotation / translation direction error)\n";
  }
  for (const auto& [pattern, v] : inliers) {
    std::cout << pattern << ": median " << Median(v) << " RANSAC inliers (min "
              << *std::min_element(v.begin(), v.end()) << ") over " << v.size()
              << " consecutive pairs\n";
  }
  std::cout << rot.size() << " pairs, 8-point: median rotation error " << Median(rot_init)
            << " deg (max " << *std::max_element(rot_init.begin(), rot_init.end())
            << "), median translation direction error " << Median(dir_init) << " deg (max "
            << *std::max_element(dir_init.begin(), dir_init.end()) << ")\n";
  std::cout << "after two-view BA: median rotation error " << Median(rot) << " deg (max "
            << *std::max_element(rot.begin(), rot.end()) << "), median translation direction error "
            << Median(dir_err) << " deg (max " << *std::max_element(dir_err.begin(), dir_err.end())
            << "), median " << Median(secs) << " s per pair\n";
  return 0;
}
