// The scene the renderer draws: a heightfield (the terrain surface) and a shaded texture
// draped over it, both on regular grids in the site's ENU frame (metres, x east, y north,
// z up). The camera is the project's one model (geometry/camera_model.h).
//
// Grid convention (as numpy's z[i, j] in python/mound/sim/terrain.py): vertex (i, j) lies at
// x = x0 + j * spacing, y = y0 + i * spacing; row i grows northwards.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace mound::sim {

struct Heightfield {
  double x0_m = 0, y0_m = 0, spacing_m = 1;
  int nx = 0, ny = 0;
  std::vector<float> z_m;  // ny * nx, row-major

  double X(int j) const { return x0_m + j * spacing_m; }
  double Y(int i) const { return y0_m + i * spacing_m; }
  float Z(int i, int j) const { return z_m[static_cast<size_t>(i) * nx + j]; }
  // Bilinear height; false when (x, y) is outside the grid.
  bool HeightAt(double x, double y, double* z) const;
};

// An RGB texture with a mipmap pyramid (2x2 box filter per level) for trilinear sampling.
class Texture {
 public:
  Texture() = default;
  Texture(double x0_m, double y0_m, double texel_m, int width, int height,
          std::vector<unsigned char> rgb);

  double texel_m() const { return texel_m_; }
  int levels() const { return static_cast<int>(levels_.size()); }
  // Colour at ground point (x, y) seen through a pixel whose footprint on the ground is
  // `footprint_m` wide: trilinear between the two mipmap levels that bracket it.
  std::array<float, 3> Sample(double x, double y, double footprint_m) const;

 private:
  struct Level {
    int width = 0, height = 0;
    std::vector<unsigned char> rgb;
  };
  std::array<float, 3> Bilinear(const Level& level, double u, double v) const;

  double x0_m_ = 0, y0_m_ = 0, texel_m_ = 1;
  std::vector<Level> levels_;
};

// A grey multi-octave value-noise texture (bilinear lattices of 64, 16, 4 and 2 texels)
// over the square [-half_m, half_m]^2: the tests' stand-in for ground with features.
Texture ValueNoiseTexture(double half_m, double texel_m, uint32_t seed);

struct Scene {
  Heightfield terrain;
  Texture texture;
  std::array<double, 3> background_rgb{200, 210, 225};  // sky / outside the site
};

// A square scene [-half_m, half_m]^2 of height(x, y) sampled every `spacing_m`, draped with
// ValueNoiseTexture (5 cm texels): the tests' rendered sites.
Scene NoiseScene(const std::function<double(double, double)>& height, double half_m,
                 double spacing_m, uint32_t texture_seed);

}  // namespace mound::sim
