#include "sim/scene.h"

#include <algorithm>
#include <cmath>
#include <random>

namespace mound::sim {

bool Heightfield::HeightAt(double x, double y, double* z) const {
  const double fx = (x - x0_m) / spacing_m, fy = (y - y0_m) / spacing_m;
  if (!(fx >= 0 && fy >= 0 && fx <= nx - 1 && fy <= ny - 1)) return false;
  const int j = std::min(static_cast<int>(fx), nx - 2), i = std::min(static_cast<int>(fy), ny - 2);
  const double b = fx - j, a = fy - i;
  *z = (1 - a) * ((1 - b) * Z(i, j) + b * Z(i, j + 1)) +
       a * ((1 - b) * Z(i + 1, j) + b * Z(i + 1, j + 1));
  return true;
}

Texture::Texture(double x0_m, double y0_m, double texel_m, int width, int height,
                 std::vector<unsigned char> rgb)
    : x0_m_(x0_m), y0_m_(y0_m), texel_m_(texel_m) {
  levels_.push_back({width, height, std::move(rgb)});
  while (levels_.back().width > 1 || levels_.back().height > 1) {
    const Level& prev = levels_.back();
    Level next;
    next.width = (prev.width + 1) / 2;
    next.height = (prev.height + 1) / 2;
    next.rgb.resize(static_cast<size_t>(next.width) * next.height * 3);
    for (int i = 0; i < next.height; ++i) {
      const int i0 = 2 * i, i1 = std::min(2 * i + 1, prev.height - 1);
      for (int j = 0; j < next.width; ++j) {
        const int j0 = 2 * j, j1 = std::min(2 * j + 1, prev.width - 1);
        for (int c = 0; c < 3; ++c) {
          auto at = [&](int ii, int jj) {
            return static_cast<int>(prev.rgb[(static_cast<size_t>(ii) * prev.width + jj) * 3 + c]);
          };
          next.rgb[(static_cast<size_t>(i) * next.width + j) * 3 + c] = static_cast<unsigned char>(
              (at(i0, j0) + at(i0, j1) + at(i1, j0) + at(i1, j1) + 2) / 4);
        }
      }
    }
    levels_.push_back(std::move(next));
  }
}

std::array<float, 3> Texture::Bilinear(const Level& level, double u, double v) const {
  u = std::clamp(u, 0.0, static_cast<double>(level.width - 1));
  v = std::clamp(v, 0.0, static_cast<double>(level.height - 1));
  const int j = std::min(static_cast<int>(u), std::max(level.width - 2, 0));
  const int i = std::min(static_cast<int>(v), std::max(level.height - 2, 0));
  const int j1 = std::min(j + 1, level.width - 1), i1 = std::min(i + 1, level.height - 1);
  const float b = static_cast<float>(u - j), a = static_cast<float>(v - i);
  const unsigned char* p00 = &level.rgb[(static_cast<size_t>(i) * level.width + j) * 3];
  const unsigned char* p01 = &level.rgb[(static_cast<size_t>(i) * level.width + j1) * 3];
  const unsigned char* p10 = &level.rgb[(static_cast<size_t>(i1) * level.width + j) * 3];
  const unsigned char* p11 = &level.rgb[(static_cast<size_t>(i1) * level.width + j1) * 3];
  std::array<float, 3> out;
  for (int c = 0; c < 3; ++c) {
    out[c] = (1 - a) * ((1 - b) * p00[c] + b * p01[c]) + a * ((1 - b) * p10[c] + b * p11[c]);
  }
  return out;
}

std::array<float, 3> Texture::Sample(double x, double y, double footprint_m) const {
  const double lod = std::clamp(std::log2(std::max(footprint_m / texel_m_, 1.0)), 0.0,
                                static_cast<double>(levels() - 1));
  const int l0 = static_cast<int>(lod);
  const int l1 = std::min(l0 + 1, levels() - 1);
  const double f = lod - l0;
  // Level-0 texel coordinates; texel k of level l covers level-0 texels [k 2^l, (k+1) 2^l),
  // so its centre is at level-0 coordinate (k + 0.5) 2^l - 0.5.
  const double u0 = (x - x0_m_) / texel_m_, v0 = (y - y0_m_) / texel_m_;
  auto at_level = [&](int l) {
    const double s = std::ldexp(1.0, l);
    return Bilinear(levels_[l], (u0 + 0.5) / s - 0.5, (v0 + 0.5) / s - 0.5);
  };
  std::array<float, 3> c0 = at_level(l0);
  if (f > 1e-6 && l1 != l0) {
    const std::array<float, 3> c1 = at_level(l1);
    for (int c = 0; c < 3; ++c) c0[c] = static_cast<float>((1 - f) * c0[c] + f * c1[c]);
  }
  return c0;
}

Texture ValueNoiseTexture(double half_m, double texel_m, uint32_t seed) {
  const int n = static_cast<int>(std::lround(2 * half_m / texel_m)) + 1;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0, 1);
  std::vector<float> acc(static_cast<size_t>(n) * n, 0.f);
  for (int cell : {64, 16, 4, 2}) {
    const int m = n / cell + 2;
    std::vector<float> lattice(static_cast<size_t>(m) * m);
    for (float& v : lattice) v = u(rng);
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) {
        const float fy = static_cast<float>(i) / cell, fx = static_cast<float>(j) / cell;
        const int i0 = static_cast<int>(fy), j0 = static_cast<int>(fx);
        const float a = fy - i0, b = fx - j0;
        const float v =
            (1 - a) * ((1 - b) * lattice[i0 * m + j0] + b * lattice[i0 * m + j0 + 1]) +
            a * ((1 - b) * lattice[(i0 + 1) * m + j0] + b * lattice[(i0 + 1) * m + j0 + 1]);
        acc[static_cast<size_t>(i) * n + j] += v;
      }
    }
  }
  std::vector<unsigned char> rgb;
  for (float v : acc) {
    const auto c = static_cast<unsigned char>(std::clamp(v * 64.f, 0.f, 255.f));
    rgb.insert(rgb.end(), {c, c, c});
  }
  return Texture(-half_m, -half_m, texel_m, n, n, std::move(rgb));
}

Scene NoiseScene(const std::function<double(double, double)>& height, double half_m,
                 double spacing_m, uint32_t texture_seed) {
  Scene scene;
  Heightfield& hf = scene.terrain;
  hf.x0_m = hf.y0_m = -half_m;
  hf.spacing_m = spacing_m;
  hf.nx = hf.ny = static_cast<int>(std::lround(2 * half_m / spacing_m)) + 1;
  for (int i = 0; i < hf.ny; ++i)
    for (int j = 0; j < hf.nx; ++j) hf.z_m.push_back(static_cast<float>(height(hf.X(j), hf.Y(i))));
  scene.texture = ValueNoiseTexture(half_m, 0.05, texture_seed);
  return scene;
}

}  // namespace mound::sim
