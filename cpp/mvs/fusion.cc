// Depth-map fusion (see dense.h): forward-backward consistency, then a voxel merge.
#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <unordered_map>

#include "common/parallel.h"
#include "mvs/dense.h"

namespace mound::mvs {
namespace {

struct Fused {
  Eigen::Vector3d xyz, normal;
  std::array<uint8_t, 3> rgb;
};

// Pixel of a world point in a depth map's image, and its depth; false when behind.
bool ProjectInto(const DepthMap& m, const Eigen::Vector3d& X, double* x, double* y, double* depth) {
  const Eigen::Vector3d p = m.cam_from_world * X;
  if (p.z() <= 0) return false;
  *x = m.camera.fx * p.x() / p.z() + m.camera.cx;
  *y = m.camera.fy * p.y() / p.z() + m.camera.cy;
  *depth = p.z();
  return true;
}

// The depth map's point at the nearest pixel to (x, y); false outside or without depth.
bool PointAt(const DepthMap& m, double x, double y, Eigen::Vector3d* X) {
  const int ix = static_cast<int>(std::lround(x)), iy = static_cast<int>(std::lround(y));
  if (ix < 0 || iy < 0 || ix >= m.width || iy >= m.height) return false;
  const float d = m.At(ix, iy);
  if (!(d > 0)) return false;
  *X = m.Unproject(ix, iy, d);
  return true;
}

std::vector<Fused> FuseOne(const std::vector<DepthMap>& maps, int r, const DenseOptions& o) {
  const DepthMap& m = maps[r];
  std::vector<Fused> out;
  const Eigen::Vector3d centre = m.cam_from_world.Centre();
  for (int y = 1; y + 1 < m.height; ++y)
    for (int x = 1; x + 1 < m.width; ++x) {
      const float d = m.At(x, y);
      if (!(d > 0)) continue;
      const Eigen::Vector3d X = m.Unproject(x, y, d);
      Eigen::Vector3d sum = X;
      int agree = 0;
      for (int j : m.sources) {
        const DepthMap& s = maps[j];
        double sx, sy, sd, bx, by, bd;
        Eigen::Vector3d Xs;
        if (!ProjectInto(s, X, &sx, &sy, &sd) || !PointAt(s, sx, sy, &Xs)) continue;
        if (!ProjectInto(m, Xs, &bx, &by, &bd)) continue;
        if (std::hypot(bx - x, by - y) > o.max_reprojection_px) continue;
        if (std::fabs(bd - d) > o.max_relative_depth * d) continue;
        sum += Xs;
        ++agree;
      }
      if (agree < o.min_consistent) continue;
      // The normal from the depth map's central differences, facing the camera.
      const float dl = m.At(x - 1, y), dr = m.At(x + 1, y), du = m.At(x, y - 1),
                  dd = m.At(x, y + 1);
      Eigen::Vector3d n = Eigen::Vector3d::Zero();
      if (dl > 0 && dr > 0 && du > 0 && dd > 0) {
        const Eigen::Vector3d gx = m.Unproject(x + 1, y, dr) - m.Unproject(x - 1, y, dl);
        const Eigen::Vector3d gy = m.Unproject(x, y + 1, dd) - m.Unproject(x, y - 1, du);
        n = gx.cross(gy);
        if (n.norm() > 0) n.normalize();
        if (n.dot(centre - X) < 0) n = -n;
      }
      out.push_back({sum / (agree + 1), n, m.rgb[static_cast<size_t>(y) * m.width + x]});
    }
  return out;
}

}  // namespace

DenseCloud FuseDepthMaps(const std::vector<DepthMap>& maps, const DenseOptions& o) {
  const int n = static_cast<int>(maps.size());
  std::vector<std::vector<Fused>> per(n);
  DenseCloud cloud;
  ParallelFor(n, o.threads, [&](int r) { per[r] = FuseOne(maps, r, o); });
  for (const auto& points : per) cloud.consistent_pixels.push_back(static_cast<int>(points.size()));

  // Voxel merge: the mean position, normal and colour of the points in each voxel.
  struct Acc {
    Eigen::Vector3d xyz = Eigen::Vector3d::Zero(), normal = Eigen::Vector3d::Zero(),
                    rgb = Eigen::Vector3d::Zero();
    int count = 0;
  };
  struct Voxel {
    int64_t x, y, z;
    bool operator==(const Voxel& o) const { return x == o.x && y == o.y && z == o.z; }
  };
  struct VoxelHash {
    size_t operator()(const Voxel& v) const {
      return static_cast<size_t>(v.x * 73856093) ^ static_cast<size_t>(v.y * 19349663) ^
             static_cast<size_t>(v.z * 83492791);
    }
  };
  std::unordered_map<Voxel, int, VoxelHash> index;
  std::vector<Acc> acc;
  const double inv = 1.0 / o.resolution_m;
  for (const auto& points : per)
    for (const Fused& f : points) {
      const Voxel key{static_cast<int64_t>(std::floor(f.xyz.x() * inv)),
                      static_cast<int64_t>(std::floor(f.xyz.y() * inv)),
                      static_cast<int64_t>(std::floor(f.xyz.z() * inv))};
      auto [it, fresh] = index.emplace(key, static_cast<int>(acc.size()));
      if (fresh) acc.emplace_back();
      Acc& a = acc[it->second];
      a.xyz += f.xyz;
      a.normal += f.normal;
      a.rgb += Eigen::Vector3d(f.rgb[0], f.rgb[1], f.rgb[2]);
      ++a.count;
    }
  for (const Acc& a : acc) {
    cloud.xyz.push_back(a.xyz / a.count);
    const Eigen::Vector3d nn =
        a.normal.norm() > 0 ? Eigen::Vector3d(a.normal.normalized()) : Eigen::Vector3d::Zero();
    cloud.normal.push_back(nn);
    const Eigen::Vector3d c = a.rgb / a.count;
    cloud.rgb.push_back({static_cast<uint8_t>(std::lround(c.x())),
                         static_cast<uint8_t>(std::lround(c.y())),
                         static_cast<uint8_t>(std::lround(c.z()))});
    cloud.support.push_back(a.count);
  }
  return cloud;
}

}  // namespace mound::mvs
