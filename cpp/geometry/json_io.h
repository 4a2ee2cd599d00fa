// The camera and pose objects of the project's JSON files (mound.render's job, recon.json):
// validated, every error an InputError naming the field by its path.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "geometry/camera_model.h"
#include "geometry/rigid3.h"

namespace mound::geometry {

// A pinhole camera of width x height pixels from its 9 numbers of K, row-major: K must be
// [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] with fx, fy > 0 and the principal point on the
// image. `where` names K in the InputError.
CameraModel CameraFromK(const std::vector<double>& K, int width, int height,
                        const std::string& where);

// {"width", "height", "K": 3 x 3 [[fx, 0, cx], [0, fy, cy], [0, 0, 1]], optional
// "dist_k1k2p1p2k3"}: at most 20000 px a side, K as CameraFromK checks it.
CameraModel CameraFromJson(const nlohmann::json& c, const std::string& path);

// {"R": 3 x 3 rotation (R R^T = I within 1e-6, det +1), "t": 3 numbers}: cam_from_world.
Rigid3d PoseFromJson(const nlohmann::json& p, const std::string& path);

}  // namespace mound::geometry
