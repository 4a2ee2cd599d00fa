#include "geometry/json_io.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "common/error.h"
#include "common/json_util.h"

namespace mound::geometry {

CameraModel CameraFromK(const std::vector<double>& K, int width, int height,
                        const std::string& where) {
  if (K.size() != 9 || !std::all_of(K.begin(), K.end(), [](double x) { return std::isfinite(x); }))
    throw InputError(where + ": expected 9 finite numbers");
  if (K[1] != 0 || K[3] != 0 || K[6] != 0 || K[7] != 0 || K[8] != 1) {
    throw InputError(where + ": expected [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]");
  }
  if (!(K[0] > 0) || !(K[4] > 0)) throw InputError(where + ": fx and fy must be > 0");
  CameraModel cam;
  cam.width = width;
  cam.height = height;
  cam.fx = K[0];
  cam.fy = K[4];
  cam.cx = K[2];
  cam.cy = K[5];
  if (cam.cx < 0 || cam.cx > width || cam.cy < 0 || cam.cy > height) {
    throw InputError(where + ": the principal point (" + FormatNumber(cam.cx) + ", " +
                     FormatNumber(cam.cy) + ") lies outside the " + std::to_string(width) + "x" +
                     std::to_string(height) + " image");
  }
  return cam;
}

CameraModel CameraFromJson(const nlohmann::json& c, const std::string& path) {
  const int width = RequireInt(c, "width", path, 1, 20000);
  const int height = RequireInt(c, "height", path, 1, 20000);
  CameraModel cam = CameraFromK(RequireMatrix3(c, "K", path), width, height, JoinPath(path, "K"));
  if (c.contains("dist_k1k2p1p2k3")) {
    const std::vector<double> d = RequireNumbers(c, "dist_k1k2p1p2k3", path, 5);
    std::copy(d.begin(), d.end(), cam.dist.begin());
  }
  return cam;
}

Rigid3d PoseFromJson(const nlohmann::json& p, const std::string& path) {
  const std::vector<double> R = RequireMatrix3(p, "R", path);
  const std::vector<double> t = RequireNumbers(p, "t", path, 3);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      double dot = 0;
      for (int k = 0; k < 3; ++k) dot += R[3 * r + k] * R[3 * c + k];
      if (std::fabs(dot - (r == c)) > 1e-6) {
        throw InputError(path + ".R: not a rotation matrix (R R^T != I)");
      }
    }
  }
  const double det = R[0] * (R[4] * R[8] - R[5] * R[7]) - R[1] * (R[3] * R[8] - R[5] * R[6]) +
                     R[2] * (R[3] * R[7] - R[4] * R[6]);
  if (det < 0) throw InputError(path + ".R: a reflection (det -1), not a rotation");
  return {Eigen::Matrix3d(Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(R.data())),
          Eigen::Vector3d(t[0], t[1], t[2])};
}

}  // namespace mound::geometry
