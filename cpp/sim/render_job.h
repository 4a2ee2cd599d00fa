// The render job file (mound.render v1, written by python/mound/sim/site.py): which scene, which
// camera, which poses, and the sensor effects. Loading validates every field and reports the
// first problem as an InputError naming it ("images[3].cam_from_world.R: not a rotation").
//
// {"schema": "mound.render", "version": 1,
//  "heightfield": {"npy": "heightfield.npy", "x0_m": -80, "y0_m": -80, "spacing_m": 0.25},
//  "texture": {"npy": "texture.npy", "x0_m": -80, "y0_m": -80, "texel_m": 0.05},
//  "camera": {"width": 1280, "height": 960, "K": [[fx,0,cx],[0,fy,cy],[0,0,1]],
//             "dist_k1k2p1p2k3": [0,0,0,0,0]},
//  "images": [{"file": "images/0000.png", "cam_from_world": {"R": [[...]], "t": [...]}}],
//  "background_rgb": [200, 210, 225], "noise_sigma": 1.5, "vignetting": 0.2, "seed": 1}
//
// Paths in the file are relative to the file's own directory; image paths to the output
// directory. Heightfield: (ny, nx) float array; texture: (h, w, 3) uint8 RGB.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "geometry/camera_model.h"
#include "geometry/rigid3.h"
#include "sim/scene.h"

namespace mound::sim {

struct ImageJob {
  std::string file;
  geometry::Rigid3d cam_from_world;
};

struct RenderJob {
  Scene scene;
  geometry::CameraModel camera;
  std::vector<ImageJob> images;
  double noise_sigma = 0;
  double vignetting = 0;
  uint64_t seed = 0;
};

RenderJob LoadRenderJob(const std::string& path);
// The same from the job's text; `.npy` paths are relative to `dir`.
RenderJob ParseRenderJob(const std::string& text, const std::string& path, const std::string& dir);

}  // namespace mound::sim
