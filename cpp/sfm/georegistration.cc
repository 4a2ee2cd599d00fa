#include "sfm/georegistration.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <complex>
#include <random>

#include "common/stats.h"

namespace mound::sfm {

std::optional<GeoFit> FitSim3Robust(const std::vector<Eigen::Vector3d>& model,
                                    const std::vector<Eigen::Vector3d>& world, uint64_t seed,
                                    double min_threshold_m, const std::vector<double>* weights) {
  const int n = static_cast<int>(std::min(model.size(), world.size()));
  if (n < 3) return std::nullopt;
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<int> pick(0, n - 1);
  auto residuals = [&](const geometry::Sim3d& s) {
    std::vector<double> r(n);
    for (int i = 0; i < n; ++i) r[i] = (s * model[i] - world[i]).norm();
    return r;
  };
  std::optional<geometry::Sim3d> best;
  double best_med = std::numeric_limits<double>::infinity();
  const int iterations = n <= 12 ? 400 : 1000;
  for (int it = 0; it < iterations; ++it) {
    const int a = pick(rng), b = pick(rng), c = pick(rng);
    if (a == b || b == c || a == c) continue;
    const auto s =
        geometry::EstimateSim3d({model[a], model[b], model[c]}, {world[a], world[b], world[c]});
    if (!s) continue;
    const double med = Median(residuals(*s));
    if (med < best_med) {
      best_med = med;
      best = s;
    }
  }
  if (!best) best = geometry::EstimateSim3d(model, world);
  if (!best) return std::nullopt;
  // Inliers within 2.5 robust sigmas (1.4826 * median), then refit on them.
  GeoFit fit;
  const double threshold = std::max(min_threshold_m, 2.5 * 1.4826 * Median(residuals(*best)));
  std::vector<Eigen::Vector3d> src, dst;
  std::vector<double> w;
  std::vector<double> r = residuals(*best);
  fit.inlier.assign(n, false);
  for (int i = 0; i < n; ++i)
    if (r[i] <= threshold) {
      fit.inlier[i] = true;
      src.push_back(model[i]);
      dst.push_back(world[i]);
      if (weights && static_cast<int>(weights->size()) == n) w.push_back((*weights)[i]);
    }
  const auto refit = w.size() == src.size() && !w.empty() ? geometry::EstimateSim3d(src, dst, w)
                                                          : geometry::EstimateSim3d(src, dst);
  fit.world_from_model = refit ? *refit : *best;
  r = residuals(fit.world_from_model);
  double s2 = 0, h2 = 0, v2 = 0;
  for (int i = 0; i < n; ++i) {
    if (!fit.inlier[i]) continue;
    const Eigen::Vector3d d = fit.world_from_model * model[i] - world[i];
    s2 += d.squaredNorm();
    h2 += d.head<2>().squaredNorm();
    v2 += d.z() * d.z();
    ++fit.inliers;
  }
  fit.rmse_m = std::sqrt(s2 / fit.inliers);
  fit.rmse_horizontal_m = std::sqrt(h2 / fit.inliers);
  fit.rmse_vertical_m = std::sqrt(v2 / fit.inliers);
  return fit;
}

std::optional<GeoFit> FitLevelledSim3Robust(const std::vector<Eigen::Vector3d>& model,
                                            const std::vector<Eigen::Vector3d>& world,
                                            const Eigen::Vector3d& down_in_model, uint64_t seed,
                                            double min_threshold_m) {
  const int n = static_cast<int>(std::min(model.size(), world.size()));
  if (n < 3 || !(down_in_model.norm() > 0)) return std::nullopt;
  const Eigen::Quaterniond level =
      Eigen::Quaterniond::FromTwoVectors(down_in_model.normalized(), Eigen::Vector3d(0, 0, -1));
  std::vector<Eigen::Vector3d> m(n);
  for (int i = 0; i < n; ++i) m[i] = level * model[i];
  // 2-D similarity (scale s, heading theta, shift) from two pairs, as complex numbers:
  // w = a m + b with a = s e^{i theta}.
  using C = std::complex<double>;
  auto fit2 = [&](const std::vector<int>& idx, C* a, C* b) {
    C mm(0, 0), mw(0, 0);
    for (int i : idx) {
      mm += C(m[i].x(), m[i].y());
      mw += C(world[i].x(), world[i].y());
    }
    mm /= double(idx.size());
    mw /= double(idx.size());
    C num(0, 0);
    double den = 0;
    for (int i : idx) {
      const C dm = C(m[i].x(), m[i].y()) - mm, dw = C(world[i].x(), world[i].y()) - mw;
      num += dw * std::conj(dm);
      den += std::norm(dm);
    }
    if (!(den > 0)) return false;
    *a = num / den;
    *b = mw - *a * mm;
    return std::abs(*a) > 0;
  };
  auto horizontal = [&](C a, C b) {
    std::vector<double> r(n);
    for (int i = 0; i < n; ++i)
      r[i] = std::abs(a * C(m[i].x(), m[i].y()) + b - C(world[i].x(), world[i].y()));
    return r;
  };
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<int> pick(0, n - 1);
  C best_a, best_b;
  double best_med = std::numeric_limits<double>::infinity();
  for (int it = 0; it < 1000; ++it) {
    const int i = pick(rng), j = pick(rng);
    if (i == j) continue;
    C a, b;
    if (!fit2({i, j}, &a, &b)) continue;
    const double med = Median(horizontal(a, b));
    if (med < best_med) {
      best_med = med;
      best_a = a;
      best_b = b;
    }
  }
  if (!std::isfinite(best_med)) return std::nullopt;
  GeoFit fit;
  const double threshold = std::max(min_threshold_m, 2.5 * 1.4826 * best_med);
  std::vector<double> r = horizontal(best_a, best_b);
  std::vector<int> in;
  fit.inlier.assign(n, false);
  for (int i = 0; i < n; ++i)
    if (r[i] <= threshold) {
      fit.inlier[i] = true;
      in.push_back(i);
    }
  C a = best_a, b = best_b;
  if (in.size() >= 2) fit2(in, &a, &b);
  const double scale = std::abs(a);
  std::vector<double> dz;
  for (int i : in) dz.push_back(world[i].z() - scale * m[i].z());
  const double z0 = dz.empty() ? 0 : Median(dz);
  geometry::Sim3d s;
  s.scale = scale;
  s.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(std::arg(a), Eigen::Vector3d::UnitZ())) * level;
  s.translation = {b.real(), b.imag(), z0};
  fit.world_from_model = s;
  double s2 = 0, h2 = 0, v2 = 0;
  for (int i : in) {
    const Eigen::Vector3d d = s * model[i] - world[i];
    s2 += d.squaredNorm();
    h2 += d.head<2>().squaredNorm();
    v2 += d.z() * d.z();
  }
  fit.inliers = static_cast<int>(in.size());
  if (fit.inliers > 0) {
    fit.rmse_m = std::sqrt(s2 / fit.inliers);
    fit.rmse_horizontal_m = std::sqrt(h2 / fit.inliers);
    fit.rmse_vertical_m = std::sqrt(v2 / fit.inliers);
  }
  return fit;
}

void Transform(const geometry::Sim3d& s, Reconstruction* r) {
  // X' = s R X + t; a camera frame scaled by s stays rigid: cam'_from_world' maps X' to
  // s X_cam = R_c R^T (X' - t) + s t_c.
  const Eigen::Quaterniond inv = s.rotation.conjugate();
  for (size_t i = 0; i < r->cam_from_world.size(); ++i) {
    if (!r->registered[i]) continue;
    const geometry::Rigid3d& c = r->cam_from_world[i];
    const Eigen::Quaterniond q = c.rotation * inv;
    r->cam_from_world[i] = {q, s.scale * c.translation - (q * s.translation)};
  }
  for (Point3D& p : r->points) p.xyz = s * p.xyz;
}

}  // namespace mound::sfm
