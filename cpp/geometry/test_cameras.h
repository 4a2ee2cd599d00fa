// Cameras for the tests (not for production code).
#pragma once

#include "geometry/camera_model.h"

namespace mound::geometry::testing {

// 1280 x 960, fx 900, fy 905, the principal point at the centre, and all five of OpenCV's
// distortion coefficients non-zero (k1 k2 p1 p2 k3).
inline CameraModel DistortedCamera() {
  CameraModel c;
  c.width = 1280;
  c.height = 960;
  c.fx = 900;
  c.fy = 905;
  c.cx = 640;
  c.cy = 480;
  c.dist = {-0.12, 0.03, 0.0008, -0.0005, 0.001};
  return c;
}

}  // namespace mound::geometry::testing
