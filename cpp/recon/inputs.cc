#include "recon/inputs.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "common/atomic_file.h"
#include "common/error.h"
#include "common/json_util.h"
#include "geometry/json_io.h"

namespace mound::recon {
geometry::CameraModel ReadCamera(const std::string& path, int width, int height) {
  return ParseCamera(ReadFile(path), path, width, height);
}

geometry::CameraModel ParseCamera(const std::string& text, const std::string& path, int width,
                                  int height) {
  const size_t first = text.find_first_not_of(" \t\r\n");
  if (first != std::string::npos && text[first] == '{') {
    const nlohmann::json doc = ParseJson(text, path);
    CheckSchema(doc, "mound.camera", 1, path);
    geometry::CameraModel c;
    try {
      c = geometry::CameraFromJson(doc, "");
    } catch (const InputError& e) {
      throw InputError(path + ": " + e.what());
    }
    if (c.width != width || c.height != height) {
      throw InputError(path + ": width x height " + std::to_string(c.width) + "x" +
                       std::to_string(c.height) + " does not match the images (" +
                       std::to_string(width) + "x" + std::to_string(height) + ")");
    }
    return c;
  }
  std::istringstream in(text);
  std::vector<double> K;
  double v;
  while (K.size() < 9 && in >> v) K.push_back(v);
  if (K.size() != 9) {
    throw InputError(path + ": expected a mound.camera JSON file or the 9 numbers of K");
  }
  return geometry::CameraFromK(K, width, height, path + ": K");
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
    if (o.contains("alt_datum")) {
      if (!o["alt_datum"].is_string() ||
          (o["alt_datum"] != "ellipsoid" && o["alt_datum"] != "egm96"))
        throw InputError(path + ": origin.alt_datum: expected \"ellipsoid\" or \"egm96\"");
      g.alt_datum = o["alt_datum"].get<std::string>();
    }
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
    const std::vector<double> v = RequireNumbers(images[k], "gps_enu_m", path + ": " + p, 3);
    g.enu_m[file] = Eigen::Vector3d(v[0], v[1], v[2]);
  }
  return g;
}

}  // namespace mound::recon
