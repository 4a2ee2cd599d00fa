#include "recon/inputs.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "common/atomic_file.h"
#include "common/error.h"
#include "common/json_util.h"

namespace mound::recon {
namespace {

std::vector<double> Numbers(const nlohmann::json& j, size_t n, const std::string& where) {
  if (!j.is_array() || j.size() != n)
    throw InputError(where + ": expected " + std::to_string(n) + " numbers");
  std::vector<double> v;
  for (const auto& x : j) {
    if (!x.is_number() || !std::isfinite(x.get<double>()))
      throw InputError(where + ": expected finite numbers");
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
  return ParseCamera(ReadFile(path), path, width, height);
}

geometry::CameraModel ParseCamera(const std::string& text, const std::string& path, int width,
                                  int height) {
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
    if (K.size() != 9 ||
        !std::all_of(K.begin(), K.end(), [](double x) { return std::isfinite(x); })) {
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
    throw InputError(path + ": the principal point (" + FormatNumber(c.cx) + ", " +
                     FormatNumber(c.cy) + ") lies outside the " + std::to_string(width) + "x" +
                     std::to_string(height) + " images: is this the images' camera?");
  }
  return c;
}

GpsPositions ReadGpsPoses(const std::string& path, const std::vector<std::string>& files) {
  return ParseGpsPoses(ReadFile(path), path, files);
}

GpsPositions ParseGpsPoses(const std::string& text, const std::string& path,
                           const std::vector<std::string>& files) {
  const nlohmann::json doc = ParseJson(text, path);
  CheckSchema(doc, "mound.poses", 1, path);
  GpsPositions g;
  g.source = "poses";
  if (doc.contains("origin") && doc["origin"].is_object()) {
    const auto& o = doc["origin"];
    g.origin =
        geometry::Geodetic{RequireFinite(o, "lat", "origin"), RequireFinite(o, "lon", "origin"),
                           o.contains("alt_m") ? RequireFinite(o, "alt_m", "origin") : 0.0};
  }
  const nlohmann::json& images = RequireField(doc, "images", "");
  if (!images.is_array()) throw InputError(path + ": images: expected an array");
  for (size_t k = 0; k < images.size(); ++k) {
    const std::string p = "images[" + std::to_string(k) + "]";
    if (!images[k].is_object()) throw InputError(path + ": " + p + ": expected an object");
    const std::string file =
        std::filesystem::path(RequireString(images[k], "file", p)).filename().string();
    if (std::find(files.begin(), files.end(), file) == files.end()) {
      throw InputError(path + ": " + p + ".file: no image '" + file + "' in the images folder");
    }
    if (!images[k].contains("gps_enu_m")) continue;
    const std::vector<double> v =
        Numbers(images[k]["gps_enu_m"], 3, path + ": " + p + ".gps_enu_m");
    g.enu_m[file] = Eigen::Vector3d(v[0], v[1], v[2]);
  }
  return g;
}

}  // namespace mound::recon
