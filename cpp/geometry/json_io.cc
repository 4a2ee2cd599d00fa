#include "geometry/json_io.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "common/error.h"
#include "common/json_util.h"

namespace mound::geometry {

CameraModel CameraFromJson(const nlohmann::json& c, const std::string& path) {
  CameraModel cam;
  cam.width = RequireInt(c, "width", path, 1, 20000);
  cam.height = RequireInt(c, "height", path, 1, 20000);
  const std::vector<double> K = RequireMatrix3(c, "K", path);
  if (K[1] != 0 || K[3] != 0 || K[6] != 0 || K[7] != 0 || K[8] != 1) {
    throw InputError(JoinPath(path, "K") + ": expected [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]");
  }
  if (K[0] <= 0 || K[4] <= 0) throw InputError(JoinPath(path, "K") + ": fx and fy must be > 0");
  cam.fx = K[0];
  cam.fy = K[4];
  cam.cx = K[2];
  cam.cy = K[5];
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
