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
namespace {

std::vector<double> Numbers(const nlohmann::json& j, size_t n, const std::string& where) {
  if (!j.is_array() || j.size() != n) throw InputError(where + ": expected " + std::to_string(n) + " numbers");
  std::vector<double> v;
  for (const auto& x : j) {
    if (!x.is_number() || !std::isfinite(x.get<double>())) throw InputError(where + ": expected finite numbers");
    v.push_back(x.get<double>());
  }
  return v;
}

void CheckK(const std::vector<double>& K, const std::string& where) {
  if (K[1] != 0 || K[3] != 0 || K[6] != 0 || K[7] != 0 || K[8] != 1 || !(K[0] > 0) || !(K[4] > 0)) {
    throw InputError(where + ": expected [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] with fx, fy > 0");
  }
}

}  // namespace

geometry::CameraModel ReadCamera(const std::string& path, int width, int height) {
  const std::string text = ReadFile(path);
  geometry::CameraModel c;
  std::vector<double> K;
  const size_t first = text.find_first_not_of(" \t\r\n");
  if (first != std::string::npos && text[first] == '{') {
    const nlohmann::json doc = ParseJson(text, path);
    CheckSchema(doc, "mound.camera", 1, path);
    const nlohmann::json& k = RequireField(doc, "K", "");
    if (!k.is_array() || k.size() != 3) throw InputError(path + ": K: expected 3 rows");
    for (int r = 0; r < 3; ++r) {
      const std::vector<double> row = Numbers(k[r], 3, path + ": K[" + std::to_string(r) + "]");
      K.insert(K.end(), row.begin(), row.end());
    }
    if (doc.contains("dist_k1k2p1p2k3")) {
      const std::vector<double> d = Numbers(doc["dist_k1k2p1p2k3"], 5, path + ": dist_k1k2p1p2k3");
      std::copy(d.begin(), d.end(), c.dist.begin());
    }
    const double w = RequireFinite(doc, "width", ""), h = RequireFinite(doc, "height", "");
    if (w != width || h != height) {
      throw InputError(path + ": width x height " + FormatNumber(w) + "x" + FormatNumber(h) +
                       " does not match the images (" + std::to_string(width) + "x" +
                       std::to_string(height) + ")");
    }
  } else {
    std::istringstream in(text);
    double v;
    while (K.size() < 9 && in >> v) K.push_back(v);
    if (K.size() != 9 || !std::all_of(K.begin(), K.end(), [](double x) { return std::isfinite(x); })) {
      throw InputError(path + ": expected a mound.camera JSON file or the 9 numbers of K");
    }
  }
  CheckK(K, path + ": K");
  c.width = width;
  c.height = height;
  c.fx = K[0];
  c.fy = K[4];
  c.cx = K[2];
  c.cy = K[5];
  if (c.cx < 0 || c.cx > width || c.cy < 0 || c.cy > height) {
    throw InputError(path + ": the principal point (" + FormatNumber(c.cx) + ", " + FormatNumber(c.cy) +
                     ") lies outside the " + std::to_string(width) + "x" + std::to_string(height) +
                     " images: is this the images' camera?");
  }
  return c;
}

GpsPositions ReadGpsPoses(const std::string& path, const std::vector<std::string>& files) {
  const nlohmann::json doc = ParseJson(ReadFile(path), path);
  CheckSchema(doc, "mound.poses", 1, path);
  GpsPositions g;
  g.source = "poses";
  if (doc.contains("origin") && doc["origin"].is_object()) {
    const auto& o = doc["origin"];
    g.origin = geometry::Geodetic{RequireFinite(o, "lat", "origin"), RequireFinite(o, "lon", "origin"),
                                  o.contains("alt_m") ? RequireFinite(o, "alt_m", "origin") : 0.0};
  }
  const nlohmann::json& images = RequireField(doc, "images", "");
  if (!images.is_array()) throw InputError(path + ": images: expected an array");
  for (size_t k = 0; k < images.size(); ++k) {
    const std::string p = "images[" + std::to_string(k) + "]";
    if (!images[k].is_object()) throw InputError(path + ": " + p + ": expected an object");
    const std::string file = std::filesystem::path(RequireString(images[k], "file", p)).filename().string();
    if (std::find(files.begin(), files.end(), file) == files.end()) {
      throw InputError(path + ": " + p + ".file: no image '" + file + "' in the images folder");
    }
    if (!images[k].contains("gps_enu_m")) continue;
    const std::vector<double> v = Numbers(images[k]["gps_enu_m"], 3, path + ": " + p + ".gps_enu_m");
    g.enu_m[file] = Eigen::Vector3d(v[0], v[1], v[2]);
  }
  return g;
}

nlohmann::json CameraJson(const geometry::CameraModel& c) {
  return {{"model", "opencv_pinhole"}, {"width", c.width}, {"height", c.height},
          {"K", {{c.fx, 0.0, c.cx}, {0.0, c.fy, c.cy}, {0.0, 0.0, 1.0}}},
          {"dist_k1k2p1p2k3", c.dist}};
}

void WritePly(const std::string& path, const sfm::Reconstruction& r) {
  std::ostringstream h;
  h << "ply\nformat binary_little_endian 1.0\ncomment mound.recon v1 points\nelement vertex "
    << r.points.size()
    << "\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\n"
       "property uchar green\nproperty uchar blue\nproperty int track_length\nend_header\n";
  std::string out = h.str();
  for (const sfm::Point3D& p : r.points) {
    const float xyz[3] = {static_cast<float>(p.xyz.x()), static_cast<float>(p.xyz.y()),
                          static_cast<float>(p.xyz.z())};
    const int32_t len = static_cast<int32_t>(p.track.size());
    char buf[19];
    std::memcpy(buf, xyz, 12);  // x86-64 and aarch64 are little-endian
    std::memcpy(buf + 12, p.color.data(), 3);
    std::memcpy(buf + 15, &len, 4);
    out.append(buf, sizeof buf);
  }
  WriteFileAtomic(path, out);
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
    cam << "1 OPENCV " << c.width << " " << c.height << " " << c.fx << " " << c.fy << " " << cx << " "
        << cy << " " << c.dist[0] << " " << c.dist[1] << " " << c.dist[2] << " " << c.dist[3] << "\n";
  }
  // Per image: its keypoints that belong to a point (POINT2D index -> point id).
  std::vector<std::vector<std::pair<int, int>>> obs(files.size());  // (keypoint, point)
  for (size_t j = 0; j < r.points.size(); ++j)
    for (const sfm::TrackElement& e : r.points[j].track) obs[e.image].emplace_back(e.keypoint, static_cast<int>(j));
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
    img << i + 1 << " " << q.w() << " " << q.x() << " " << q.y() << " " << q.z() << " " << t.x() << " "
        << t.y() << " " << t.z() << " 1 " << files[i] << "\n";
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
    pts << j + 1 << " " << p.xyz.x() << " " << p.xyz.y() << " " << p.xyz.z() << " " << int(p.color[0]) << " "
        << int(p.color[1]) << " " << int(p.color[2]) << " " << p.error_px;
    for (const sfm::TrackElement& e : p.track) pts << " " << e.image + 1 << " " << point2d_index[e.image][e.keypoint];
    pts << "\n";
  }
  WriteFileAtomic(dir + "/cameras.txt", cam.str());
  WriteFileAtomic(dir + "/images.txt", img.str());
  WriteFileAtomic(dir + "/points3D.txt", pts.str());
}

}  // namespace mound::recon
