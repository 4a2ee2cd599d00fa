// Rendering a heightfield scene from a camera pose: a z-buffer rasteriser.
//
// The terrain grid is a triangle mesh (two triangles per cell). Each vertex is moved into the
// camera frame and projected with the full distortion model; triangles are rasterised in
// the (distorted) image with edge functions at pixel centres (OpenCV: pixel (u, v) is
// centred at integer (u, v)) and barycentric weights made perspective-correct by
// interpolating 1/z. Because cells are small (a few pixels), a triangle drawn with straight
// edges in the distorted image departs from the true curved image by far less than a
// pixel. The nearest surface wins (depth test on 1/z), so occlusion is exact for the mesh.
//
// A second pass colours each covered pixel from the texture at the interpolated ground
// point, with a mipmap level chosen from the pixel's footprint on the ground (the
// finite difference of ground points with its neighbours, as GPUs do), then applies
// vignetting and Gaussian sensor noise. Uncovered pixels (sky, off the site) get the
// background colour.
//
// Limits: triangles with a vertex closer than `near_m` to the camera plane are dropped (the
// job loader rejects cameras below the ground, so this only touches terrain right under a
// very low camera); no cast shadows (shading is baked into the texture).
#pragma once

#include <cstdint>
#include <vector>

#include "geometry/camera_model.h"
#include "geometry/rigid3.h"
#include "sim/scene.h"

namespace mound::sim {

struct RenderSettings {
  double noise_sigma = 0;  // Gaussian sensor noise, digital numbers (0..255 scale)
  double vignetting = 0;   // brightness falls to (1 - vignetting) in the corners, as r^2
  uint64_t noise_seed = 0;
  double near_m = 1e-3;
  bool keep_geometry = false;  // fill depth_m and xyz_m
};

struct RenderedImage {
  int width = 0, height = 0;
  std::vector<unsigned char> rgb;  // height * width * 3, RGB
  // With keep_geometry: camera-frame depth z (m) and ENU ground point per pixel; NaN where
  // no surface is seen.
  std::vector<float> depth_m;
  std::vector<float> xyz_m;
  size_t covered_px = 0;
};

RenderedImage Render(const Scene& scene, const geometry::CameraModel& camera,
                     const geometry::Rigid3d& cam_from_world, const RenderSettings& settings);

}  // namespace mound::sim
