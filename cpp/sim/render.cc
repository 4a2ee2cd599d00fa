#include "sim/render.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace mound::sim {
namespace {

struct Vertex {
  float u = 0, v = 0;  // pixel position (distorted)
  float iz = 0;        // 1 / depth
  bool ok = false;     // in front of the camera and not far outside the image
};

// Per-pixel G-buffer of the rasterisation pass.
struct GBuffer {
  int width, height;
  std::vector<float> iz, x, y, z;  // 1/depth (0: empty) and the ENU ground point
  GBuffer(int w, int h)
      : width(w),
        height(h),
        iz(static_cast<size_t>(w) * h, 0.f),
        x(iz.size()),
        y(iz.size()),
        z(iz.size()) {}
};

// Rasterises triangle (a, b, c) with ENU points pa, pb, pc into the G-buffer.
void DrawTriangle(const Vertex& a, const Vertex& b, const Vertex& c, const float* pa,
                  const float* pb, const float* pc, GBuffer* g) {
  const float area = (b.u - a.u) * (c.v - a.v) - (b.v - a.v) * (c.u - a.u);
  if (std::fabs(area) < 1e-12f) return;
  const int u0 = std::max(0, static_cast<int>(std::ceil(std::min({a.u, b.u, c.u}))));
  const int u1 = std::min(g->width - 1, static_cast<int>(std::floor(std::max({a.u, b.u, c.u}))));
  const int v0 = std::max(0, static_cast<int>(std::ceil(std::min({a.v, b.v, c.v}))));
  const int v1 = std::min(g->height - 1, static_cast<int>(std::floor(std::max({a.v, b.v, c.v}))));
  if (u0 > u1 || v0 > v1) return;
  const float inv_area = 1.f / area;
  const float tol = -1e-6f;  // inclusive edges: no cracks between neighbouring triangles
  for (int v = v0; v <= v1; ++v) {
    for (int u = u0; u <= u1; ++u) {
      const float pu = static_cast<float>(u), pv = static_cast<float>(v);
      const float wa = ((b.u - pu) * (c.v - pv) - (b.v - pv) * (c.u - pu)) * inv_area;
      const float wb = ((c.u - pu) * (a.v - pv) - (c.v - pv) * (a.u - pu)) * inv_area;
      const float wc = 1.f - wa - wb;
      if (wa < tol || wb < tol || wc < tol) continue;
      const float iz = wa * a.iz + wb * b.iz + wc * c.iz;
      const size_t k = static_cast<size_t>(v) * g->width + u;
      if (iz <= g->iz[k]) continue;
      // Perspective-correct weights: w_i / z_i normalised.
      const float qa = wa * a.iz / iz, qb = wb * b.iz / iz, qc = 1.f - qa - qb;
      g->iz[k] = iz;
      g->x[k] = qa * pa[0] + qb * pb[0] + qc * pc[0];
      g->y[k] = qa * pa[1] + qb * pb[1] + qc * pc[1];
      g->z[k] = qa * pa[2] + qb * pb[2] + qc * pc[2];
    }
  }
}

// Box-Muller on a fixed engine, so the noise is the same on every standard library.
class Gaussian {
 public:
  explicit Gaussian(uint64_t seed) : engine_(seed) {}
  double Next() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double scale = 1.0 / 18446744073709551616.0;  // 2^-64
    double u1 = (static_cast<double>(engine_()) + 0.5) * scale;
    double u2 = (static_cast<double>(engine_()) + 0.5) * scale;
    const double r = std::sqrt(-2 * std::log(u1));
    spare_ = r * std::sin(2 * M_PI * u2);
    has_spare_ = true;
    return r * std::cos(2 * M_PI * u2);
  }

 private:
  std::mt19937_64 engine_;
  bool has_spare_ = false;
  double spare_ = 0;
};

// Ground distance to a neighbouring pixel, or +inf when it sees another surface / nothing.
float NeighbourStep(const GBuffer& g, size_t k, size_t n) {
  if (g.iz[n] <= 0) return std::numeric_limits<float>::infinity();
  const float ratio = g.iz[n] / g.iz[k];
  if (ratio < 0.9f || ratio > 1.1f) return std::numeric_limits<float>::infinity();
  return std::hypot(g.x[n] - g.x[k], g.y[n] - g.y[k]);
}

}  // namespace

RenderedImage Render(const Scene& scene, const geometry::CameraModel& camera,
                     const geometry::Rigid3d& cam_from_world, const RenderSettings& settings) {
  const Heightfield& hf = scene.terrain;
  const int W = camera.width, H = camera.height;
  // Vertices far outside the image are dropped before distortion, whose polynomial folds
  // back beyond its valid range: limit at twice the corner's normalised radius.
  // The farthest image corner from the principal point, in pixels.
  const double corner_u = std::max(camera.cx, W - 1 - camera.cx);
  const double corner_v = std::max(camera.cy, H - 1 - camera.cy);
  const double xc = corner_u / camera.fx, yc = corner_v / camera.fy;
  const double r2_limit = 4 * (xc * xc + yc * yc);
  const Eigen::Matrix3d R = cam_from_world.RotationMatrix();
  const Eigen::Vector3d& t = cam_from_world.translation;
  const std::array<double, geometry::CameraModel::kNumParams> params = camera.Params();
  std::vector<Vertex> verts(static_cast<size_t>(hf.nx) * hf.ny);
  std::vector<float> enu(verts.size() * 3);
  for (int i = 0; i < hf.ny; ++i) {
    for (int j = 0; j < hf.nx; ++j) {
      const size_t k = static_cast<size_t>(i) * hf.nx + j;
      const double X = hf.X(j), Y = hf.Y(i), Z = hf.Z(i, j);
      enu[3 * k] = static_cast<float>(X);
      enu[3 * k + 1] = static_cast<float>(Y);
      enu[3 * k + 2] = static_cast<float>(Z);
      const Eigen::Vector3d pc = R * Eigen::Vector3d(X, Y, Z) + t;
      Vertex& vx = verts[k];
      if (pc[2] < settings.near_m) continue;
      const double xn = pc[0] / pc[2], yn = pc[1] / pc[2];
      if (xn * xn + yn * yn > r2_limit) continue;
      double u, v;
      geometry::ImageFromNormalised(params.data(), xn, yn, &u, &v);
      vx = {static_cast<float>(u), static_cast<float>(v), static_cast<float>(1.0 / pc[2]), true};
    }
  }
  GBuffer g(W, H);
  for (int i = 0; i + 1 < hf.ny; ++i) {
    for (int j = 0; j + 1 < hf.nx; ++j) {
      const size_t k00 = static_cast<size_t>(i) * hf.nx + j, k01 = k00 + 1, k10 = k00 + hf.nx,
                   k11 = k10 + 1;
      const Vertex &a = verts[k00], &b = verts[k01], &c = verts[k10], &d = verts[k11];
      if (!(a.ok && b.ok && c.ok && d.ok)) continue;
      // Whole cell off one side of the image: skip both triangles.
      if (std::max({a.u, b.u, c.u, d.u}) < -1 || std::min({a.u, b.u, c.u, d.u}) > W ||
          std::max({a.v, b.v, c.v, d.v}) < -1 || std::min({a.v, b.v, c.v, d.v}) > H) {
        continue;
      }
      DrawTriangle(a, b, d, &enu[3 * k00], &enu[3 * k01], &enu[3 * k11], &g);
      DrawTriangle(a, d, c, &enu[3 * k00], &enu[3 * k11], &enu[3 * k10], &g);
    }
  }

  RenderedImage out;
  out.width = W;
  out.height = H;
  out.rgb.resize(static_cast<size_t>(W) * H * 3);
  if (settings.keep_geometry) {
    out.depth_m.assign(static_cast<size_t>(W) * H, std::numeric_limits<float>::quiet_NaN());
    out.xyz_m.assign(static_cast<size_t>(W) * H * 3, std::numeric_limits<float>::quiet_NaN());
  }
  Gaussian noise(settings.noise_seed);
  const double corner2 = corner_u * corner_u + corner_v * corner_v;
  const float fallback_scale = static_cast<float>(1.0 / std::min(camera.fx, camera.fy));
  for (int v = 0; v < H; ++v) {
    for (int u = 0; u < W; ++u) {
      const size_t k = static_cast<size_t>(v) * W + u;
      std::array<float, 3> colour;
      if (g.iz[k] > 0) {
        ++out.covered_px;
        const float inf = std::numeric_limits<float>::infinity();
        const float du = std::min(u + 1 < W ? NeighbourStep(g, k, k + 1) : inf,
                                  u > 0 ? NeighbourStep(g, k, k - 1) : inf);
        const float dv = std::min(v + 1 < H ? NeighbourStep(g, k, k + W) : inf,
                                  v > 0 ? NeighbourStep(g, k, k - W) : inf);
        float footprint = std::max(std::isfinite(du) ? du : 0.f, std::isfinite(dv) ? dv : 0.f);
        if (footprint == 0) footprint = fallback_scale / g.iz[k];  // isolated pixel
        colour = scene.texture.Sample(g.x[k], g.y[k], footprint);
        if (settings.keep_geometry) {
          out.depth_m[k] = 1.f / g.iz[k];
          out.xyz_m[3 * k] = g.x[k];
          out.xyz_m[3 * k + 1] = g.y[k];
          out.xyz_m[3 * k + 2] = g.z[k];
        }
      } else {
        for (int c = 0; c < 3; ++c) colour[c] = static_cast<float>(scene.background_rgb[c]);
      }
      double gain = 1;
      if (settings.vignetting > 0) {
        const double r2 = (u - camera.cx) * (u - camera.cx) + (v - camera.cy) * (v - camera.cy);
        gain = 1 - settings.vignetting * r2 / corner2;
      }
      for (int c = 0; c < 3; ++c) {
        double value = colour[c] * gain;
        if (settings.noise_sigma > 0) value += settings.noise_sigma * noise.Next();
        out.rgb[3 * k + c] = static_cast<unsigned char>(std::clamp(std::lround(value), 0L, 255L));
      }
    }
  }
  return out;
}

}  // namespace mound::sim
