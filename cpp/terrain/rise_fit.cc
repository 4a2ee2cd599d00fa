#include "terrain/rise_fit.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "common/stats.h"

namespace mound::terrain::internal {
namespace {

constexpr int kShapes = 3;  // paraboloid, cone, drum
// The scale space's radii: from 2.5 m (or 2 cells) up to the site's radius in this factor.
constexpr double kScaleStep = 1.3;
// The local relief's side boxes count where at least this share of their cells hold points
// (their centroid, not their centre, is where their mean lies).
constexpr double kSideFill = 0.25;

double Phi(int shape, double t) {
  if (t >= 1) return 0;
  if (shape == 0) return 1 - t * t;
  if (shape == 1) return 1 - t;
  return std::min(1.0, 2 * (1 - t));
}

// Summed-area tables of the site's heights and of its valid cells (and of the valid cells'
// column and row indices: their centroid); `measured_only`: the cells that hold points, not
// those filled from their neighbours.
struct Tables {
  int w = 0, h = 0;
  std::vector<double> sum, count, si, sj;  // (w + 1) x (h + 1)
  explicit Tables(const HeightGrid& g, bool measured_only = false) : w(g.w), h(g.h) {
    sum.assign(static_cast<size_t>(w + 1) * (h + 1), 0.0);
    count = si = sj = sum;
    for (int j = 0; j < h; ++j)
      for (int i = 0; i < w; ++i) {
        const double z = g.z[g.Index(i, j)];
        const bool ok = g.inside[g.Index(i, j)] && !std::isnan(z) &&
                        (!measured_only || g.measured[g.Index(i, j)]);
        const size_t a = At(i + 1, j + 1);
        auto add = [&](std::vector<double>& t, double v) {
          t[a] = v + t[At(i, j + 1)] + t[At(i + 1, j)] - t[At(i, j)];
        };
        add(sum, ok ? z : 0);
        add(count, ok ? 1 : 0);
        add(si, ok ? i : 0);
        add(sj, ok ? j : 0);
      }
  }
  size_t At(int i, int j) const { return static_cast<size_t>(j) * (w + 1) + i; }
  struct Sums {
    double z = 0, n = 0, i = 0, j = 0;
  };
  // The sums over the cells within half-width b of (i, j), clipped to the grid.
  Sums Of(int i, int j, int b) const {
    const int i0 = std::max(0, i - b), j0 = std::max(0, j - b);
    const int i1 = std::min(w, i + b + 1), j1 = std::min(h, j + b + 1);
    if (i0 >= i1 || j0 >= j1) return {};
    auto s = [&](const std::vector<double>& t) {
      return t[At(i1, j1)] - t[At(i0, j1)] - t[At(i1, j0)] + t[At(i0, j0)];
    };
    return {s(sum), s(count), s(si), s(sj)};
  }
  // Sum and count over the cells within half-width b of (i, j), clipped to the grid.
  std::pair<double, double> Box(int i, int j, int b) const {
    const Sums s = Of(i, j, b);
    return {s.z, s.n};
  }
};

struct Fit {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double radius = 0, window = 0, q = -std::numeric_limits<double>::infinity(), H = 0;
  int shape = 0;
  // The local ground over Basis(x, y), x, y from the centre (m): z = a + b x + c y + d x^2
  // + e x y + f y^2; d = e = f = 0 over a plane. Summed term by term in this order, as the
  // shipped models were measured (Basis(..).dot sums otherwise, and the last bits move a
  // few rises' centre searches).
  Eigen::Matrix<double, 6, 1> ground = Eigen::Matrix<double, 6, 1>::Zero();
  double Ground(const Eigen::Vector2d& d) const {
    return ground[0] + ground[1] * d.x() + ground[2] * d.y() + ground[3] * d.x() * d.x() +
           ground[4] * d.x() * d.y() + ground[5] * d.y() * d.y();
  }
};

// The best shape's ground + dome fit at (c, R); q = -inf when too few cells or H <= 0.
// The ground a plane (P = 3) within rho = max(1.5 R, R + 3 cells), or a quadratic (P = 6)
// within rho = max(2 R, R + 4 cells): the frame beyond the dome must pin its curvature.
template <int P>
Fit FitAt(const HeightGrid& g, const Eigen::Vector2d& c, double R) {
  using VecP = Eigen::Matrix<double, P, 1>;
  using MatP = Eigen::Matrix<double, P, P>;
  using VecQ = Eigen::Matrix<double, P + 1, 1>;
  using MatQ = Eigen::Matrix<double, P + 1, P + 1>;
  Fit best;
  best.centre = c;
  best.radius = R;
  const double rho = P == 3 ? std::max(1.5 * R, R + 3 * g.cell) : std::max(2.0 * R, R + 4 * g.cell);
  best.window = rho;
  const int stride = std::max(1, static_cast<int>(rho / (g.cell * 35)));
  const Eigen::Vector2d q = (c - g.origin) / g.cell;
  const int reach = static_cast<int>(std::ceil(rho / g.cell));
  const int ci = static_cast<int>(std::lround(q.x())), cj = static_cast<int>(std::lround(q.y()));
  // Normal equations of the ground's basis and of each shape's phi.
  MatP A = MatP::Zero();
  VecP b = VecP::Zero();
  std::array<VecP, kShapes> ap{};
  std::array<double, kShapes> pp{}, pz{};
  for (auto& v : ap) v.setZero();
  double zz = 0, z0 = std::numeric_limits<double>::quiet_NaN();
  int n = 0, in_disc = 0;
  for (int j = std::max(0, cj - reach); j <= std::min(g.h - 1, cj + reach); j += stride)
    for (int i = std::max(0, ci - reach); i <= std::min(g.w - 1, ci + reach); i += stride) {
      const size_t k = g.Index(i, j);
      if (!g.measured[k] || !g.inside[k]) continue;
      const Eigen::Vector2d d = g.Centre(i, j) - c;
      const double r = d.norm();
      if (r > rho) continue;
      if (std::isnan(z0)) z0 = g.z[k];
      const double z = g.z[k] - z0;
      const VecP f = Basis(d.x() / rho, d.y() / rho).template head<P>();
      A += f * f.transpose();
      b += f * z;
      zz += z * z;
      for (int s = 0; s < kShapes; ++s) {
        const double p = Phi(s, r / R);
        ap[s] += f * p;
        pp[s] += p * p;
        pz[s] += p * z;
      }
      ++n;
      in_disc += r <= R ? 1 : 0;
    }
  if (n < 16 + 4 * (P - 3) || in_disc < 6) return best;
  const Eigen::LDLT<MatP> ground(A);
  const VecP xg = ground.solve(b);
  const double sse_ground = zz - b.dot(xg);
  if (!xg.allFinite() || !(sse_ground > 1e-12 * (zz + 1))) return best;
  for (int s = 0; s < kShapes; ++s) {
    MatQ M;
    M.template topLeftCorner<P, P>() = A;
    M.template topRightCorner<P, 1>() = ap[s];
    M.template bottomLeftCorner<1, P>() = ap[s].transpose();
    M(P, P) = pp[s];
    VecQ v;
    v << b, pz[s];
    const VecQ x = M.ldlt().solve(v);
    if (!x.allFinite() || !(x[P] > 0)) continue;
    const double qs = 1 - (zz - v.dot(x)) / sse_ground;
    if (qs > best.q) {
      best.q = qs;
      best.H = x[P];
      best.shape = s;
      best.ground.setZero();
      best.ground[0] = x[0] + z0;
      best.ground[1] = x[1] / rho;
      best.ground[2] = x[2] / rho;
      if constexpr (P == 6) {
        best.ground[3] = x[3] / (rho * rho);
        best.ground[4] = x[4] / (rho * rho);
        best.ground[5] = x[5] / (rho * rho);
      }
    }
  }
  return best;
}

Fit FitAt(const HeightGrid& g, const Eigen::Vector2d& c, double R, bool curved) {
  return curved ? FitAt<6>(g, c, R) : FitAt<3>(g, c, R);
}

// Coordinate descent over the radius (factors of 1.15) and the centre (a 5 x 5 lattice,
// halved each round).
Fit Refine(const HeightGrid& g, const Candidate& start, bool curved) {
  double r_min = std::max(2.0 * g.cell, 2.0), r_max = 1.25 * g.radius;
  if (curved) {  // held near the candidate's own scale
    r_min = std::max(r_min, start.radius_m / kOwnScale);
    r_max = std::min(r_max, std::max(r_min, start.radius_m * kOwnScale));
  }
  Fit best = FitAt(g, start.centre, std::clamp(start.radius_m, r_min, r_max), curved);
  double step = std::max(g.cell, best.radius / 8);
  for (int round = 0; round < 4; ++round) {
    const Fit at = best;
    for (int m = -4; m <= 4; ++m) {
      const double R = std::clamp(at.radius * std::pow(1.15, m), r_min, r_max);
      const Fit f = FitAt(g, at.centre, R, curved);
      if (f.q > best.q) best = f;
    }
    const Fit mid = best;
    for (int b = -2; b <= 2; ++b)
      for (int a = -2; a <= 2; ++a) {
        Eigen::Vector2d c = mid.centre + step * Eigen::Vector2d(a, b);
        if (c.norm() > g.radius) c *= g.radius / c.norm();
        const Fit f = FitAt(g, c, mid.radius, curved);
        if (f.q > best.q) best = f;
      }
    step = std::max(g.cell / 2, step / 2);
  }
  return best;
}

}  // namespace

namespace {

// Whether candidate c is a blob already kept: within half the larger radius of one, at a
// scale within two steps of it.
bool SameBlob(const std::vector<Candidate>& kept, const Candidate& c) {
  return std::any_of(kept.begin(), kept.end(), [&](const Candidate& q) {
    const double big = std::max(q.radius_m, c.radius_m);
    const double small = std::min(q.radius_m, c.radius_m);
    return (q.centre - c.centre).norm() < big / 2 &&
           big < kScaleStep * kScaleStep * small * 1.001;  // 1.001: two steps exactly
  });
}

// The blobs of a scale space: `resp` (radii x cells) the response at each radius and cell;
// its local maxima over position and radius above `min_contrast_m`, the strongest
// `max_count` by contrast x radius, one per blob (see ScaleSpaceCandidates).
std::vector<Candidate> Blobs(const HeightGrid& g, const std::vector<double>& radii,
                             const std::vector<double>& resp, double min_contrast_m,
                             size_t max_count) {
  const size_t nc = g.z.size();
  struct Peak {
    double score;
    Candidate c;
  };
  std::vector<Peak> peaks;
  for (size_t s = 0; s < radii.size(); ++s)
    for (int j = 0; j < g.h; ++j)
      for (int i = 0; i < g.w; ++i) {
        const double v = resp[s * nc + g.Index(i, j)];
        if (!(v > min_contrast_m)) continue;
        bool top = true;
        for (int ds = -1; ds <= 1 && top; ++ds) {
          const long ss = static_cast<long>(s) + ds;
          if (ss < 0 || ss >= static_cast<long>(radii.size())) continue;
          for (int dj = -1; dj <= 1 && top; ++dj)
            for (int di = -1; di <= 1 && top; ++di) {
              if (!ds && !di && !dj) continue;
              const int a = i + di, b = j + dj;
              if (a < 0 || b < 0 || a >= g.w || b >= g.h) continue;
              if (resp[ss * nc + g.Index(a, b)] > v) top = false;
            }
        }
        if (top) peaks.push_back({v * radii[s], {g.Centre(i, j), radii[s]}});
      }
  std::sort(peaks.begin(), peaks.end(),
            [](const Peak& a, const Peak& b) { return a.score > b.score; });
  // One candidate per blob: a peak within half the larger radius of a stronger one kept,
  // at a scale within two steps of it (kScaleStep^2), is the same blob (the ties of a plateau,
  // the maxima strung along the edge of the valid frame at the largest scales) and is
  // left out; a small rise on a large one keeps its own.
  std::vector<Candidate> out;
  for (const Peak& p : peaks) {
    if (out.size() >= max_count) break;
    if (!SameBlob(out, p.c)) out.push_back(p.c);
  }
  return out;
}

}  // namespace

std::vector<Candidate> ScaleSpaceCandidates(const HeightGrid& g, double min_contrast_m,
                                            size_t max_count, bool measured_only) {
  const Tables t(g, measured_only);
  std::vector<double> radii;
  for (double R = std::max(2.5, 2 * g.cell); R <= g.radius; R *= kScaleStep) radii.push_back(R);
  const size_t nc = g.z.size();
  std::vector<double> resp(radii.size() * nc, -std::numeric_limits<double>::infinity());
  for (size_t s = 0; s < radii.size(); ++s) {
    const int a = std::max(1, static_cast<int>(std::lround(0.5 * radii[s] / g.cell)));
    const int b1 = std::max(a + 1, static_cast<int>(std::lround(radii[s] / g.cell)));
    const int b2 = std::max(b1 + 1, static_cast<int>(std::lround(1.5 * radii[s] / g.cell)));
    const double full_in = (2.0 * a + 1) * (2.0 * a + 1);
    const double full_ring = (2.0 * b2 + 1) * (2.0 * b2 + 1) - (2.0 * b1 + 1) * (2.0 * b1 + 1);
    for (int j = 0; j < g.h; ++j)
      for (int i = 0; i < g.w; ++i) {
        if (!g.inside[g.Index(i, j)]) continue;
        const auto [si, ni] = t.Box(i, j, a);
        const auto [s1, n1] = t.Box(i, j, b1);
        const auto [s2, n2] = t.Box(i, j, b2);
        if (ni < 0.5 * full_in || n2 - n1 < 0.2 * full_ring) continue;
        resp[s * nc + g.Index(i, j)] = si / ni - (s2 - s1) / (n2 - n1);
      }
  }
  return Blobs(g, radii, resp, min_contrast_m, max_count);
}

std::vector<Candidate> LocalReliefCandidates(const HeightGrid& g, double min_contrast_m,
                                             size_t max_count) {
  const Tables t(g, /*measured_only=*/true);
  std::vector<double> radii;
  for (double R = std::max(2.5, 2 * g.cell); R <= g.radius / 1.25; R *= kScaleStep)
    radii.push_back(R);
  const size_t nc = g.z.size();
  std::vector<double> resp(radii.size() * nc, -std::numeric_limits<double>::infinity());
  // The four axes through a cell (E-W, N-S and the diagonals), as unit steps.
  const std::array<Eigen::Vector2d, 4> axes = {Eigen::Vector2d(1, 0), Eigen::Vector2d(0, 1),
                                               Eigen::Vector2d(M_SQRT1_2, M_SQRT1_2),
                                               Eigen::Vector2d(M_SQRT1_2, -M_SQRT1_2)};
  for (size_t s = 0; s < radii.size(); ++s) {
    const int a = std::max(1, static_cast<int>(std::lround(0.5 * radii[s] / g.cell)));
    const double full = (2.0 * a + 1) * (2.0 * a + 1);
    const double reach = std::max(2.0 * a + 1, 1.25 * radii[s] / g.cell);  // cells
    for (int j = 0; j < g.h; ++j)
      for (int i = 0; i < g.w; ++i) {
        if (!g.inside[g.Index(i, j)]) continue;
        const Tables::Sums in = t.Of(i, j, a);
        if (in.n < 0.5 * full) continue;
        const Eigen::Vector2d c(in.i / in.n, in.j / in.n);  // the inner box's centroid
        const double mean = in.z / in.n;
        double low = std::numeric_limits<double>::infinity();
        size_t pairs = 0;
        for (const Eigen::Vector2d& u : axes) {
          const int di = static_cast<int>(std::lround(reach * u.x()));
          const int dj = static_cast<int>(std::lround(reach * u.y()));
          const Tables::Sums p = t.Of(i + di, j + dj, a), m = t.Of(i - di, j - dj, a);
          if (p.n < kSideFill * full || m.n < kSideFill * full) continue;
          // The two side boxes' line, at the inner centroid's projection on it: the ground a
          // plane through them would give there (exact on a plane, whatever the clipping).
          const Eigen::Vector2d cp(p.i / p.n, p.j / p.n), cm(m.i / m.n, m.j / m.n);
          const Eigen::Vector2d span = cp - cm;
          const double len2 = span.squaredNorm();
          if (!(len2 > 0)) continue;
          const double f = (c - cm).dot(span) / len2;
          const double ground = m.z / m.n + f * (p.z / p.n - m.z / m.n);
          low = std::min(low, mean - ground);
          ++pairs;
        }
        // every axis: the one a ridge runs along is the one that says it is no blob
        if (pairs == axes.size()) resp[s * nc + g.Index(i, j)] = low;
      }
  }
  return Blobs(g, radii, resp, min_contrast_m, max_count);
}

namespace {

// The points' own relief over the rise's ground and their residual from its dome, within
// its base (Rise::point_top, point_spread; the cells' `disc` and `resid` where too few).
void PointFigures(const HeightGrid& g, const Fit& f, const std::vector<double>& disc,
                  const std::vector<double>& resid, double h, Rise* r) {
  const Eigen::Vector2d c = f.centre;
  const double R = f.radius;
  std::vector<double> core, point_resid;
  for (const Eigen::Vector3d& p : g.points) {
    const Eigen::Vector2d d = p.head<2>() - c;
    const double rad = d.norm();
    if (rad > R) continue;
    const double rel = p.z() - f.Ground(d);
    point_resid.push_back(rel - f.H * Phi(f.shape, rad / R));
    if (rad <= R / 2) core.push_back(rel);
  }
  if (core.size() < 3) core = disc;
  r->point_top = Quantile(core, 0.95) / h;
  if (point_resid.size() < 5) point_resid = resid;
  const double med = Median(point_resid);
  for (double& e : point_resid) e = std::fabs(e - med);
  r->point_spread = 1.4826 * Median(point_resid) / h;
}

// How much of the relief's variance in the window the radial profile explains (the rings'
// means): 1 for a rise symmetric about its centre.
double Symmetry(const std::vector<std::pair<size_t, double>>& window,
                const std::vector<double>& rsum, const std::vector<double>& rcnt) {
  double mean = 0;
  for (const auto& [b, rel] : window) mean += rel;
  mean /= window.size();
  double tot = 0, sse = 0;
  for (const auto& [b, rel] : window) {
    tot += (rel - mean) * (rel - mean);
    sse += (rel - rsum[b] / rcnt[b]) * (rel - rsum[b] / rcnt[b]);
  }
  return tot > 0 ? 1 - sse / tot : 0;
}

// The share of the base disc (centre c, radius R) outside the site (on a lattice of the
// disc).
double OutsideShare(const Eigen::Vector2d& c, double R, double site_radius) {
  int all = 0, off = 0;
  for (int b = -12; b <= 12; ++b)
    for (int a = -12; a <= 12; ++a) {
      const Eigen::Vector2d p = c + R * Eigen::Vector2d(a, b) / 12;
      if ((p - c).norm() > R) continue;
      ++all;
      off += p.norm() > site_radius ? 1 : 0;
    }
  return all ? static_cast<double>(off) / all : 0;
}

// The footprint's figures (its cells `comp`, `in` marking them): volume, roundness, flank
// slope, flat top, the share of its outline on the site's edge, its extent.
template <class Relief>
void FootprintFigures(const HeightGrid& g, const std::vector<size_t>& comp,
                      const std::vector<char>& in, const Relief& relief, const Eigen::Vector2d& c,
                      Rise* rise) {
  Rise& r = *rise;
  const double cell_area = g.cell * g.cell;
  Eigen::Vector2d m = Eigen::Vector2d::Zero();
  for (size_t k : comp) m += g.Centre(k);
  m /= comp.size();
  Eigen::Matrix2d M = Eigen::Matrix2d::Zero();
  std::vector<double> slopes;
  int outline = 0, on_edge = 0;
  int top = 0;
  for (size_t k : comp) {
    const double rel = relief(k);
    r.volume_m3 += rel * cell_area;
    top += rel >= 0.85 * r.height_m ? 1 : 0;
    const Eigen::Vector2d p = g.Centre(k) - m;
    M += p * p.transpose();
    const int i = static_cast<int>(k % g.w), j = static_cast<int>(k / g.w);
    auto at = [&](int a, int b) {
      if (a < 0 || b < 0 || a >= g.w || b >= g.h) return std::numeric_limits<double>::quiet_NaN();
      const size_t n = g.Index(a, b);
      return g.inside[n] && !std::isnan(g.z[n]) ? relief(n)
                                                : std::numeric_limits<double>::quiet_NaN();
    };
    // The flank's slope is the outward, downhill component of the gradient: a flank
    // falls away from the centre, while the walls of a looters' trench through the top
    // (or of a pit's far side) face across or inwards and would make a trenched tumulus
    // as steep as a building.
    const double gx = (at(i + 1, j) - at(i - 1, j)) / (2 * g.cell);
    const double gy = (at(i, j + 1) - at(i, j - 1)) / (2 * g.cell);
    const Eigen::Vector2d out_dir = g.Centre(k) - c;
    if (std::isfinite(gx) && std::isfinite(gy) && out_dir.norm() >= g.cell)
      slopes.push_back(std::max(0.0, -Eigen::Vector2d(gx, gy).dot(out_dir.normalized())));
    bool boundary = false, edge = false;
    for (const auto& [di, dj] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
      const int a = i + di, b = j + dj;
      const bool off = a < 0 || b < 0 || a >= g.w || b >= g.h || !g.inside[g.Index(a, b)];
      if (off || !in[g.Index(a, b)]) boundary = true;
      if (off) edge = true;
    }
    outline += boundary ? 1 : 0;
    on_edge += edge ? 1 : 0;
    r.extent_m = std::max(r.extent_m, g.Centre(k).norm());
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(M / comp.size());
  r.roundness = es.eigenvalues()[1] > 0
                    ? std::sqrt(std::max(0.0, es.eigenvalues()[0]) / es.eigenvalues()[1])
                    : 0;
  r.flank_slope_rad = slopes.empty() ? 0 : std::atan(Quantile(slopes, 0.9));
  r.flat_top = static_cast<double>(top) / comp.size();
  r.clipped = outline > 0 ? static_cast<double>(on_edge) / outline : 0;
}

}  // namespace

bool MeasureRise(const HeightGrid& g, const Candidate& start, double relief_threshold_m, Rise* out,
                 bool curved_ground) {
  const Fit f = Refine(g, start, curved_ground);
  if (!std::isfinite(f.q) || !(f.H > 0)) return false;
  const Eigen::Vector2d c = f.centre;
  const double R = f.radius, rho = f.window;
  auto relief = [&](size_t k) { return g.z[k] - f.Ground(g.Centre(k) - c); };
  Rise r;
  r.centre = c;
  r.base_diameter_m = 2 * R;
  r.dome_height_m = f.H;
  r.dome_r2 = f.q;
  r.shape = f.shape;
  r.ground_slope_rad = std::atan(std::hypot(f.ground[1], f.ground[2]));
  r.ground_plane = f.ground.head<3>();  // over a curved ground: its tangent at the centre
  r.curved_ground = curved_ground;
  r.ground_curvature = f.ground.tail<3>();
  // Within the base: the height (99th percentile of the relief), the fit's residual, and
  // the peak cell the footprint grows from.
  std::vector<double> disc, resid;
  size_t peak = g.z.size();
  double peak_rel = -std::numeric_limits<double>::infinity();
  // Rings (radial profile, symmetry) and the 8 sectors of the frame R < r <= rho.
  const double ring_w = std::max(g.cell, R / 20);
  const size_t bins = static_cast<size_t>(rho / ring_w) + 2;
  std::vector<double> rsum(bins, 0.0), rcnt(bins, 0.0);
  std::array<double, 8> sec_sum{}, sec_cnt{};
  std::vector<std::pair<size_t, double>> window;  // (ring, relief) of measured cells
  for (size_t k = 0; k < g.z.size(); ++k) {
    if (!g.inside[k] || std::isnan(g.z[k])) continue;
    const Eigen::Vector2d d = g.Centre(k) - c;
    const double rad = d.norm();
    if (rad > rho) continue;
    const double rel = relief(k);
    if (rad <= std::max(R / 2, g.cell) && rel > peak_rel) {
      peak_rel = rel;
      peak = k;
    }
    if (!g.measured[k]) continue;
    if (rad <= R) {
      disc.push_back(rel);
      resid.push_back(rel - f.H * Phi(f.shape, rad / R));
    } else {
      const int s = static_cast<int>(std::floor((std::atan2(d.y(), d.x()) + M_PI) / (M_PI / 4)));
      sec_sum[std::clamp(s, 0, 7)] += rel;
      sec_cnt[std::clamp(s, 0, 7)] += 1;
    }
    const size_t b = std::min(bins - 1, static_cast<size_t>(rad / ring_w));
    rsum[b] += rel;
    rcnt[b] += 1;
    window.emplace_back(b, rel);
  }
  if (disc.empty() || peak == g.z.size()) return false;
  r.height_m = Quantile(disc, 0.99);
  const double h = std::max(r.height_m, 0.05);
  double ss = 0;
  for (double e : resid) ss += e * e;
  r.roughness = std::sqrt(ss / resid.size()) / std::max(f.H, 0.05);
  PointFigures(g, f, disc, resid, h, &r);
  r.symmetry = Symmetry(window, rsum, rcnt);
  double hi = -std::numeric_limits<double>::infinity(), lo = -hi;
  for (int s = 0; s < 8; ++s)
    if (sec_cnt[s] > 0) {
      hi = std::max(hi, sec_sum[s] / sec_cnt[s]);
      lo = std::min(lo, sec_sum[s] / sec_cnt[s]);
    }
  r.ring_high = std::isfinite(hi) ? hi / h : 0;
  r.ring_spread = std::isfinite(hi) ? (hi - lo) / h : 0;
  r.outside = OutsideShare(c, R, g.radius);
  // The footprint: the 4-connected cells of relief above max(threshold, a quarter of the
  // height) grown from the peak, within 3 R of the centre (a ridge runs on; a tumulus
  // ends at its foot).
  const double level = std::max(relief_threshold_m, 0.25 * r.height_m);
  const double reach = std::max(3 * R, rho);
  std::vector<char> in(g.z.size(), 0);
  const std::vector<size_t> comp = GrowRegion(g, peak, &in, [&](size_t n) {
    return g.inside[n] && !std::isnan(g.z[n]) && (g.Centre(n) - c).norm() <= reach &&
           relief(n) > level;
  });
  const double cell_area = g.cell * g.cell;
  r.cells = static_cast<int>(comp.size());
  r.area_m2 = comp.size() * cell_area;
  r.fill = r.area_m2 / (M_PI * R * R);
  if (!comp.empty()) FootprintFigures(g, comp, in, relief, c, &r);
  r.extent_m = std::max(r.extent_m, c.norm() + R);
  r.offset_m = c.norm();
  *out = r;
  return true;
}

}  // namespace mound::terrain::internal
