// Plane-sweep depth maps (see dense.h for the method and its sources).
#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "common/parallel.h"
#include "common/stats.h"
#include "mvs/dense.h"
#include "mvs/scaled_images.h"

namespace mound::mvs {
namespace {

constexpr double kPi = 3.14159265358979323846;

// The pixel of world point X in camera c at pose cam_from_world (the project's camera
// model, distortion included); false behind the camera.
bool Project(const geometry::CameraModel& c, const geometry::Rigid3d& cam_from_world,
             const Eigen::Vector3d& X, Eigen::Vector2d* uv) {
  return c.ImageFromCamera(cam_from_world * X, uv);
}

bool Inside(const Eigen::Vector2d& uv, int w, int h) {
  return uv.x() >= -0.5 && uv.y() >= -0.5 && uv.x() < w - 0.5 && uv.y() < h - 0.5;
}

// The ray of pixel (x, y) in the world, from the camera centre.
Eigen::Vector3d RayInWorld(const geometry::CameraModel& c, const geometry::Rigid3d& cam_from_world,
                           double x, double y) {
  return cam_from_world.rotation.conjugate() *
         Eigen::Vector3d((x - c.cx) / c.fx, (y - c.cy) / c.fy, 1.0);
}

}  // namespace

void DenseOptions::Check() const {
  if (max_image_size < 32) throw InputError("--max-image-size: must be >= 32");
  if (source_views < 1) throw InputError("--source-views: must be >= 1");
  if (best_views < 1 || best_views > source_views)
    throw InputError("--best-views: must be in [1, --source-views]");
  if (window < 3 || window % 2 == 0) throw InputError("--window: must be odd and >= 3");
  if (!(max_step_px > 0)) throw InputError("--max-step-px: must be > 0");
  if (min_planes < 2 || max_planes < min_planes)
    throw InputError("--max-planes: must be >= the minimum (2)");
  if (!(min_ncc >= -1 && min_ncc < 1)) throw InputError("--min-ncc: must be in [-1, 1)");
  if (min_consistent < 1) throw InputError("--min-consistent: must be >= 1");
  if (!(max_reprojection_px > 0)) throw InputError("--max-reprojection-px: must be > 0");
  if (!(max_relative_depth > 0)) throw InputError("--max-relative-depth: must be > 0");
  if (!(resolution_m >= 1e-3) || !std::isfinite(resolution_m))
    throw InputError("--resolution-m: must be >= 0.001 m");
  if (!(up.norm() > 0.5)) throw InputError("up: must be a unit vector");
  if (threads < 1) throw InputError("--threads: must be >= 1");
  if (image_cache_mb < 0) throw InputError("image_cache_mb: must be >= 0");
}

Eigen::Vector3d DepthMap::Unproject(double x, double y, double d) const {
  const Eigen::Vector3d p((x - camera.cx) / camera.fx * d, (y - camera.cy) / camera.fy * d, d);
  return world_from_cam * p;
}

std::vector<std::vector<int>> SelectSourceViews(const DenseInput& in, int count) {
  const int n = static_cast<int>(in.image_paths.size());
  // Which sparse points each image sees (projection inside the frame, in front).
  std::vector<std::vector<int>> sees(n);
  std::vector<Eigen::Vector3d> centre(n);
  for (int i = 0; i < n; ++i) {
    centre[i] = in.cam_from_world[i].Centre();
    for (int p = 0; p < static_cast<int>(in.sparse_points.size()); ++p) {
      Eigen::Vector2d uv;
      if (Project(in.camera, in.cam_from_world[i], in.sparse_points[p], &uv) &&
          Inside(uv, in.camera.width, in.camera.height)) {
        sees[i].push_back(p);
      }
    }
  }
  std::vector<std::vector<int>> out(n);
  for (int r = 0; r < n; ++r) {
    std::vector<char> mine(in.sparse_points.size(), 0);
    for (int p : sees[r]) mine[p] = 1;
    std::vector<std::pair<double, int>> scored;
    for (int j = 0; j < n; ++j) {
      if (j == r) continue;
      double score = 0;
      for (int p : sees[j]) {
        if (!mine[p]) continue;
        const Eigen::Vector3d a = centre[r] - in.sparse_points[p],
                              b = centre[j] - in.sparse_points[p];
        const double theta =
            std::acos(std::clamp(a.dot(b) / (a.norm() * b.norm()), -1.0, 1.0)) * 180 / kPi;
        const double sigma = theta <= 5 ? 1.0 : 10.0;  // MVSNet's G: theta0 5 deg, sigma 1 / 10
        score += std::exp(-(theta - 5) * (theta - 5) / (2 * sigma * sigma));
      }
      if (score > 0) scored.emplace_back(-score, j);
    }
    std::sort(scored.begin(), scored.end());
    for (int k = 0; k < std::min<int>(count, static_cast<int>(scored.size())); ++k)
      out[r].push_back(scored[k].second);
  }
  return out;
}

std::pair<double, double> SweptHeightRange(std::vector<double> heights, double camera_height) {
  std::sort(heights.begin(), heights.end());
  const double lo0 = Quantile(heights, 0.01), hi0 = Quantile(heights, 0.99);
  const double min_pad = 0.01 * std::fabs(camera_height - 0.5 * (lo0 + hi0));
  const double gap = 0.5 * (hi0 - lo0);
  double lo = lo0, hi = hi0;
  for (const double h : heights) {  // upwards from the 99th percentile, while continuous
    if (h <= hi) continue;
    if (h - hi > gap) break;
    hi = h;
  }
  for (auto it = heights.rbegin(); it != heights.rend(); ++it) {  // downwards likewise
    if (*it >= lo) continue;
    if (lo - *it > gap) break;
    lo = *it;
  }
  const double pad = std::max(0.1 * (hi0 - lo0), min_pad);
  return {lo - pad, hi + pad};
}

namespace {

// The sweep's inner loops run over flat arrays without branches (so that the compiler
// vectorises them): -2 marks "no score".
constexpr float kNone = -2.f;

// The number of planes: the shift of sample pixels between the lowest and highest plane in
// each source image (the 75th percentile over 8 x 6 samples of the largest over the
// sources), one plane per max_step_px of it, within min_planes .. max_planes.
int PlaneCount(const DenseInput& in, const ScaledImage& R, const geometry::Rigid3d& Tr,
               const std::vector<int>& sources,
               const std::vector<std::shared_ptr<const ScaledImage>>& S, const Eigen::Vector3d& up,
               double lo, double hi, const DenseOptions& o) {
  const int W = R.camera.width, H = R.camera.height;
  const Eigen::Vector3d Cr = Tr.Centre();
  std::vector<double> shifts;
  for (int sy = 0; sy < 6; ++sy)
    for (int sx = 0; sx < 8; ++sx) {
      const double x = (sx + 0.5) * W / 8.0, y = (sy + 0.5) * H / 6.0;
      const Eigen::Vector3d ray = RayInWorld(R.camera, Tr, x, y);
      const double ur = up.dot(ray);
      if (std::fabs(ur) < 1e-9) continue;
      const double l_lo = (lo - up.dot(Cr)) / ur, l_hi = (hi - up.dot(Cr)) / ur;
      if (l_lo <= 0 || l_hi <= 0) continue;
      double most = 0;
      for (size_t k = 0; k < S.size(); ++k) {
        Eigen::Vector2d a, b;
        if (Project(S[k]->camera, in.cam_from_world[sources[k]], Cr + l_lo * ray, &a) &&
            Project(S[k]->camera, in.cam_from_world[sources[k]], Cr + l_hi * ray, &b)) {
          most = std::max(most, (a - b).norm());
        }
      }
      if (most > 0) shifts.push_back(most);
    }
  const double shift = shifts.empty() ? 0.0 : Quantile(shifts, 0.75);
  return std::clamp(static_cast<int>(std::ceil(shift / o.max_step_px)) + 1, o.min_planes,
                    o.max_planes);
}

// The reference image's window statistics and each pixel's n_c . x^ (the plane's depth is
// d_c / it), as flat arrays.
struct RefWindows {
  cv::Mat mean_i;
  std::vector<float> nd, std_i, inv_std_i, nd_sign;
};

RefWindows ReferenceWindows(const ScaledImage& R, const Eigen::Vector3d& n_c, const cv::Size& win) {
  const int W = R.camera.width, H = R.camera.height;
  const size_t npx = static_cast<size_t>(W) * H;
  RefWindows rw;
  cv::Mat mean_ii, grey_sq;
  cv::boxFilter(R.grey, rw.mean_i, CV_32F, win);
  cv::multiply(R.grey, R.grey, grey_sq);
  cv::boxFilter(grey_sq, mean_ii, CV_32F, win);
  rw.nd.resize(npx);
  rw.std_i.resize(npx);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const size_t p = static_cast<size_t>(y) * W + x;
      rw.nd[p] = static_cast<float>(n_c.dot(
          Eigen::Vector3d((x - R.camera.cx) / R.camera.fx, (y - R.camera.cy) / R.camera.fy, 1.0)));
      const float mi = rw.mean_i.at<float>(y, x);
      rw.std_i[p] = std::sqrt(std::max(0.f, mean_ii.at<float>(y, x) - mi * mi));
    }
  rw.inv_std_i.resize(npx);
  rw.nd_sign.resize(npx);
  for (size_t p = 0; p < npx; ++p) {
    rw.inv_std_i[p] = rw.std_i[p] > 1e-4f ? 1.f / rw.std_i[p] : 0.f;
    rw.nd_sign[p] = rw.nd[p] > 0 ? 1.f : (rw.nd[p] < 0 ? -1.f : 0.f);
  }
  return rw;
}

// The images a plane's NCC is computed in, kept from one source and plane to the next.
struct NccScratch {
  cv::Mat warped, prod[3], boxed[3];
};

// One source's NCC with the reference on the plane n_c . X_cam = d_c (the source warped
// by the plane's homography): `ncc` per pixel, kNone where the source does not see it, the
// plane lies behind the camera or a window has no texture.
void SourceNcc(const ScaledImage& R, const ScaledImage& source, const geometry::Rigid3d& rel,
               const Eigen::Vector3d& n_c, double d_c, const RefWindows& rw, const cv::Size& win,
               NccScratch* sc, std::vector<float>* ncc) {
  const size_t npx = ncc->size();
  const float plane_sign = d_c > 0 ? 1.f : -1.f;
  const Eigen::Matrix3d Hm = source.camera.K() *
                             (rel.RotationMatrix() + rel.translation * n_c.transpose() / d_c) *
                             R.camera.K().inverse();
  cv::Mat Hcv(3, 3, CV_64F);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) Hcv.at<double>(r, c) = Hm(r, c);
  // Outside the source image reads -1 (grey values are 0..1): a pixel whose bilinear
  // sample touches it comes out negative and is skipped.
  cv::warpPerspective(source.grey, sc->warped, Hcv, R.grey.size(),
                      cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_CONSTANT, cv::Scalar(-1));
  const float* w = sc->warped.ptr<float>(0);
  const float* g = R.grey.ptr<float>(0);
  float* q1 = sc->prod[1].ptr<float>(0);
  float* q2 = sc->prod[2].ptr<float>(0);
  for (size_t p = 0; p < npx; ++p) {
    q1[p] = w[p] * w[p];
    q2[p] = g[p] * w[p];
  }
  // Box means of J, J^2 and I J (separate planes: contiguous loads below).
  cv::boxFilter(sc->warped, sc->boxed[0], CV_32F, win);
  cv::boxFilter(sc->prod[1], sc->boxed[1], CV_32F, win);
  cv::boxFilter(sc->prod[2], sc->boxed[2], CV_32F, win);
  const float* b0 = sc->boxed[0].ptr<float>(0);
  const float* b1 = sc->boxed[1].ptr<float>(0);
  const float* b2 = sc->boxed[2].ptr<float>(0);
  const float* mi = rw.mean_i.ptr<float>(0);  // continuous, row-major like p
  const float* inv_std_i = rw.inv_std_i.data();
  const float* nd_sign = rw.nd_sign.data();
  float* out = ncc->data();
  for (size_t p = 0; p < npx; ++p) {
    const float mean_j = b0[p], var_j = std::max(b1[p] - mean_j * mean_j, 0.f);
    const float inv = inv_std_i[p] / std::sqrt(var_j + 1e-12f);
    const float c = std::min(std::max((b2[p] - mi[p] * mean_j) * inv, -1.f), 1.f);
    // Inside the source, the plane in front of the camera, texture in both windows.
    const bool ok = (w[p] >= 0) & (nd_sign[p] == plane_sign) & (var_j > 1e-8f) & (inv_std_i[p] > 0);
    out[p] = ok ? c : kNone;
  }
}

// Each pixel's best plane so far, the scores of the planes either side of it (for the
// sub-plane refinement) and the last plane's score.
struct BestPlanes {
  std::vector<float> prev, best, s_minus, s_plus, best_k;  // best_k float: no mixed types
  explicit BestPlanes(size_t npx)
      : prev(npx, kNone),
        best(npx, kNone),
        s_minus(npx, kNone),
        s_plus(npx, kNone),
        best_k(npx, -1.f) {}
};

// Plane k's score per pixel, the mean of its best kb NCCs in `top` (none when fewer views
// saw it), kept where it beats the pixel's best. `sums`: scratch.
void KeepBest(const std::vector<std::vector<float>>& top, int k, std::vector<float>* sums,
              BestPlanes* b) {
  const int kb = static_cast<int>(top.size());
  const size_t npx = sums->size();
  std::vector<float>& ncc = *sums;
  std::copy(top[0].begin(), top[0].end(), ncc.begin());
  for (int i = 1; i < kb; ++i)
    for (size_t p = 0; p < npx; ++p) ncc[p] += top[i][p];
  const float* last = top[kb - 1].data();
  const float inv_kb = 1.f / kb, kf = static_cast<float>(k);
  for (size_t p = 0; p < npx; ++p) {
    const float s = last[p] > kNone ? ncc[p] * inv_kb : kNone;
    const bool better = s > b->best[p];
    b->s_plus[p] = better ? kNone : (b->best_k[p] == kf - 1 ? s : b->s_plus[p]);
    b->s_minus[p] = better ? b->prev[p] : b->s_minus[p];
    b->best_k[p] = better ? kf : b->best_k[p];
    b->best[p] = better ? s : b->best[p];
    b->prev[p] = s;
  }
}

DepthMap Sweep(const DenseInput& in, int ref, const std::vector<int>& sources,
               const DenseOptions& o, const ScaledImages& images) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::shared_ptr<const ScaledImage> ref_image = images.Get(ref);
  const ScaledImage& R = *ref_image;
  const int W = R.camera.width, H = R.camera.height;
  const size_t npx = static_cast<size_t>(W) * H;
  DepthMap m;
  m.width = W;
  m.height = H;
  m.camera = R.camera;
  m.cam_from_world = in.cam_from_world[ref];
  m.world_from_cam = m.cam_from_world.Inverse();
  m.sources = sources;
  m.depth.assign(npx, 0.f);
  m.rgb.resize(npx);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const cv::Vec3b c = R.colour.at<cv::Vec3b>(y, x);
      m.rgb[static_cast<size_t>(y) * W + x] = {c[2], c[1], c[0]};
    }
  const Eigen::Vector3d up = o.up.normalized();
  const geometry::Rigid3d& Tr = in.cam_from_world[ref];

  // The swept heights: those of the sparse points this image sees.
  std::vector<double> heights;
  for (const Eigen::Vector3d& X : in.sparse_points) {
    Eigen::Vector2d uv;
    if (Project(R.camera, Tr, X, &uv) && Inside(uv, W, H)) heights.push_back(up.dot(X));
  }
  const int min_sources = std::min<int>(o.best_views, static_cast<int>(sources.size()));
  if (heights.size() < 10 || sources.empty()) {
    m.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return m;
  }
  const auto [lo, hi] = SweptHeightRange(heights, up.dot(Tr.Centre()));
  std::vector<std::shared_ptr<const ScaledImage>> S;
  std::vector<geometry::Rigid3d> rel;  // source_from_ref
  for (int j : sources) {
    S.push_back(images.Get(j));
    rel.push_back(in.cam_from_world[j] * Tr.Inverse());
  }
  const int planes = PlaneCount(in, R, Tr, sources, S, up, lo, hi, o);
  const double step = (hi - lo) / (planes - 1);
  m.height_min = lo;
  m.height_max = hi;
  m.planes = planes;

  const cv::Size win(o.window, o.window);
  const Eigen::Vector3d n_c = Tr.rotation * up;  // the planes' normal in the reference camera
  const RefWindows rw = ReferenceWindows(R, n_c, win);
  const int kb = min_sources;
  std::vector<float> ncc(npx);
  std::vector<std::vector<float>> top(kb, std::vector<float>(npx));  // the best kb NCCs, descending
  BestPlanes b(npx);
  NccScratch sc;
  sc.prod[1] = cv::Mat(H, W, CV_32F);
  sc.prod[2] = cv::Mat(H, W, CV_32F);
  for (int k = 0; k < planes; ++k) {
    const double h = lo + k * step;
    const double d_c = h + n_c.dot(Tr.translation);  // plane n_c . X_cam = d_c
    if (std::fabs(d_c) < 1e-9) continue;
    for (auto& t : top) std::fill(t.begin(), t.end(), kNone);
    for (size_t j = 0; j < S.size(); ++j) {
      SourceNcc(R, *S[j], rel[j], n_c, d_c, rw, win, &sc, &ncc);
      for (int i = 0; i < kb; ++i) {
        float* t = top[i].data();
        for (size_t p = 0; p < npx; ++p) {
          const float hi_ = std::max(t[p], ncc[p]), lo_ = std::min(t[p], ncc[p]);
          t[p] = hi_;
          ncc[p] = lo_;
        }
      }
    }
    KeepBest(top, k, &ncc, &b);  // ncc now holds the sums
  }
  // Each pixel's depth: its best plane, refined by the parabola through its neighbours.
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const size_t p = static_cast<size_t>(y) * W + x;
      if (b.best[p] < o.min_ncc || rw.std_i[p] < o.min_texture || b.best_k[p] <= 0 ||
          b.best_k[p] >= planes - 1)
        continue;
      double delta = 0;
      if (b.s_minus[p] > kNone && b.s_plus[p] > kNone) {
        const double den = b.s_minus[p] - 2.0 * b.best[p] + b.s_plus[p];
        if (den < 0) delta = std::clamp(0.5 * (b.s_minus[p] - b.s_plus[p]) / den, -0.5, 0.5);
      }
      const double hgt = lo + (b.best_k[p] + delta) * step;
      const double depth = (hgt + n_c.dot(Tr.translation)) / rw.nd[p];
      if (depth > 0) {
        m.depth[p] = static_cast<float>(depth);
        ++m.valid;
      }
    }
  m.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return m;
}

}  // namespace

DepthMap PlaneSweepDepthMap(const DenseInput& in, int ref, const std::vector<int>& sources,
                            const DenseOptions& o) {
  return Sweep(in, ref, sources, o, ScaledImages(in, o.max_image_size, 0));
}

std::vector<DepthMap> ComputeDepthMaps(const DenseInput& in,
                                       const std::vector<std::vector<int>>& sources,
                                       const DenseOptions& o, int* images_read) {
  std::vector<DepthMap> maps(in.image_paths.size());
  const ScaledImages images(in, o.max_image_size,
                            static_cast<size_t>(std::max(0, o.image_cache_mb)) << 20);
  const int cv_threads = cv::getNumThreads();
  cv::setNumThreads(1);  // one image per thread already
  try {
    ParallelFor(static_cast<int>(maps.size()), o.threads,
                [&](int i) { maps[i] = Sweep(in, i, sources[i], o, images); });
  } catch (...) {
    cv::setNumThreads(cv_threads);
    throw;
  }
  cv::setNumThreads(cv_threads);
  if (images_read) *images_read = images.reads();
  return maps;
}

}  // namespace mound::mvs
