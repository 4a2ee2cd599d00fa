#include "recon/recon_io.h"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <iomanip>
#include <sstream>

#include "common/atomic_file.h"
#include "common/error.h"
#include "common/json_util.h"

namespace mound::recon {

nlohmann::json CameraJson(const geometry::CameraModel& c) {
  return {{"model", "opencv_pinhole"},
          {"width", c.width},
          {"height", c.height},
          {"K", {{c.fx, 0.0, c.cx}, {0.0, c.fy, c.cy}, {0.0, 0.0, 1.0}}},
          {"dist_k1k2p1p2k3", c.dist}};
}

void WritePly(const std::string& path, const sfm::Reconstruction& r) {
  geometry::PlyCloud cloud;
  cloud.comments = {"mound.recon v1 points"};
  std::vector<double>& track_length = cloud.scalars["track_length"];
  cloud.int_scalars = {"track_length"};
  for (const sfm::Point3D& p : r.points) {
    cloud.xyz.push_back(p.xyz);
    cloud.rgb.push_back(p.color);
    track_length.push_back(static_cast<double>(p.track.size()));
  }
  geometry::WritePly(path, cloud);
}

void WriteColmapText(const std::string& dir, const sfm::Reconstruction& r,
                     const std::vector<std::string>& files,
                     const std::vector<sfm::ImageFeatures>& features) {
  const geometry::CameraModel& c = r.camera;
  std::ostringstream cam;
  cam << std::setprecision(17);
  cam << "# Camera list with one line of data per camera:\n"
      << "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n# Number of cameras: 1\n";
  // OpenCV's k3 needs COLMAP's FULL_OPENCV (k1 k2 p1 p2 k3 k4 k5 k6). COLMAP puts pixel
  // (0, 0) at the top-left corner of the first pixel, OpenCV at its centre: +0.5 to the
  // principal point and to every keypoint.
  const double cx = c.cx + 0.5, cy = c.cy + 0.5;
  if (c.dist[4] != 0) {
    cam << "1 FULL_OPENCV " << c.width << " " << c.height << " " << c.fx << " " << c.fy << " " << cx
        << " " << cy << " " << c.dist[0] << " " << c.dist[1] << " " << c.dist[2] << " " << c.dist[3]
        << " " << c.dist[4] << " 0 0 0\n";
  } else {
    cam << "1 OPENCV " << c.width << " " << c.height << " " << c.fx << " " << c.fy << " " << cx
        << " " << cy << " " << c.dist[0] << " " << c.dist[1] << " " << c.dist[2] << " " << c.dist[3]
        << "\n";
  }
  // Per image: its keypoints that belong to a point (POINT2D index -> point id).
  std::vector<std::vector<std::pair<int, int>>> obs(files.size());  // (keypoint, point)
  for (size_t j = 0; j < r.points.size(); ++j)
    for (const sfm::TrackElement& e : r.points[j].track)
      obs[e.image].emplace_back(e.keypoint, static_cast<int>(j));
  std::vector<std::map<int, int>> point2d_index(files.size());
  std::ostringstream img;
  img << std::setprecision(17);
  img << "# Image list with two lines of data per image:\n"
      << "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
      << "#   POINTS2D[] as (X, Y, POINT3D_ID)\n# Number of images: " << r.NumRegistered() << "\n";
  for (size_t i = 0; i < files.size(); ++i) {
    if (!r.registered[i]) continue;
    const auto& q = r.cam_from_world[i].rotation;
    const auto& t = r.cam_from_world[i].translation;
    img << i + 1 << " " << q.w() << " " << q.x() << " " << q.y() << " " << q.z() << " " << t.x()
        << " " << t.y() << " " << t.z() << " 1 " << files[i] << "\n";
    std::sort(obs[i].begin(), obs[i].end());
    for (size_t k = 0; k < obs[i].size(); ++k) {
      // COLMAP's pixel convention puts (0, 0) at the top-left corner of the first pixel.
      const Eigen::Vector2d& px = features[i].keypoints[obs[i][k].first];
      img << (k ? " " : "") << px.x() + 0.5 << " " << px.y() + 0.5 << " " << obs[i][k].second + 1;
      point2d_index[i][obs[i][k].first] = static_cast<int>(k);
    }
    img << "\n";
  }
  std::ostringstream pts;
  pts << std::setprecision(17);
  pts << "# 3D point list with one line of data per point:\n"
      << "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n"
      << "# Number of points: " << r.points.size() << "\n";
  for (size_t j = 0; j < r.points.size(); ++j) {
    const sfm::Point3D& p = r.points[j];
    pts << j + 1 << " " << p.xyz.x() << " " << p.xyz.y() << " " << p.xyz.z() << " "
        << int(p.color[0]) << " " << int(p.color[1]) << " " << int(p.color[2]) << " " << p.error_px;
    for (const sfm::TrackElement& e : p.track)
      pts << " " << e.image + 1 << " " << point2d_index[e.image][e.keypoint];
    pts << "\n";
  }
  WriteFileAtomic(dir + "/cameras.txt", cam.str());
  WriteFileAtomic(dir + "/images.txt", img.str());
  WriteFileAtomic(dir + "/points3D.txt", pts.str());
}

geometry::PlyCloud ReadCloud(const std::string& path, const std::string& what) {
  geometry::PlyCloud c = geometry::ReadPly(path);
  if (c.xyz.size() < 10)
    throw InputError(what + ": " + path + " has " + std::to_string(c.xyz.size()) +
                     " points (need >= 10)");
  return c;
}

nlohmann::json LoadRecon(const std::string& path) {
  nlohmann::json doc = ParseJson(ReadFile(path), path);
  CheckSchema(doc, "mound.recon", 1, path);
  return doc;
}

}  // namespace mound::recon
