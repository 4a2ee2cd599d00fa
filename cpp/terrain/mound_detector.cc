#include "terrain/mound_detector.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <utility>

#include "common/error.h"
#include "common/stats.h"
#include "terrain/rise_fit.h"

namespace mound::terrain {
namespace {

using internal::Basis;
using internal::HeightGrid;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double SignedLog(double x) { return std::copysign(std::log1p(std::fabs(x)), x); }

// How far the quadratic q (Basis order, x and y in units of the radius) falls from the
// centre to the radius along its least and its most falling direction, m.
Eigen::Vector2d Fall(const Eigen::Matrix<double, 6, 1>& q) {
  Eigen::Matrix2d H;
  H << 2 * q[3], q[4], q[4], 2 * q[5];
  const Eigen::Vector2d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(H).eigenvalues();
  return {-ev[1] / 2, -ev[0] / 2};
}

}  // namespace

void DetectorOptions::Check() const {
  if (!(cell_m >= 0) || !std::isfinite(cell_m))
    throw InputError("detector.cell_m: must be >= 0 (0: from the point density)");
  if (ground_order != 1 && ground_order != 2)
    throw InputError("detector.ground_order: 1 (a plane) or 2 (a quadratic)");
  if (!(relief_threshold_m > 0) || !std::isfinite(relief_threshold_m))
    throw InputError("detector.relief_threshold_m: must be > 0");
}

const char* CandidatesName(DetectorOptions::Candidates c) {
  return c == DetectorOptions::Candidates::kLocalRelief ? "local_relief" : "site_ground";
}

std::optional<DetectorOptions::Candidates> CandidatesFromName(const std::string& name) {
  if (name == "site_ground") return DetectorOptions::Candidates::kSiteGround;
  if (name == "local_relief") return DetectorOptions::Candidates::kLocalRelief;
  return std::nullopt;
}

namespace {

// The site's points (x and y from its centre) binned into a grid of cells: each cell's
// median height, which cells lie within the site and which hold points.
HeightGrid GridOfSite(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector2d& centre,
                      double radius_m, const DetectorOptions& o, Detection* d) {
  std::vector<Eigen::Vector3d> site;
  for (const Eigen::Vector3d& p : points) {
    const Eigen::Vector2d dxy = p.head<2>() - centre;
    if (dxy.norm() <= radius_m) site.emplace_back(dxy.x(), dxy.y(), p.z());
  }
  if (site.size() < 100) {
    throw NoResultError("only " + std::to_string(site.size()) + " points within " +
                        std::to_string(radius_m) +
                        " m of the site centre; a terrain model needs at least 100");
  }
  const double area = M_PI * radius_m * radius_m;
  d->cell_m = o.cell_m > 0 ? o.cell_m
                           : std::clamp(std::sqrt(area / (site.size() / 4.0)), 0.25,
                                        std::max(0.25, radius_m / 25));
  HeightGrid g;
  g.radius = radius_m;
  g.cell = d->cell_m;
  g.w = g.h = 2 * static_cast<int>(std::ceil(radius_m / g.cell)) + 1;
  g.origin = -Eigen::Vector2d(g.w / 2, g.h / 2) * g.cell;
  d->grid_width = g.w;
  d->grid_height = g.h;
  std::vector<std::vector<double>> bins(static_cast<size_t>(g.w) * g.h);
  for (const Eigen::Vector3d& p : site) {
    const Eigen::Vector2d q = (p.head<2>() - g.origin) / g.cell;
    const int i = static_cast<int>(std::lround(q.x())), j = static_cast<int>(std::lround(q.y()));
    if (i >= 0 && j >= 0 && i < g.w && j < g.h)
      bins[static_cast<size_t>(j) * g.w + i].push_back(p.z());
  }
  g.points = std::move(site);
  g.z.assign(bins.size(), kNaN);
  // Which cells lie within the site, and which hold points (not filled): the grid's own.
  g.inside.assign(bins.size(), false);
  g.measured.assign(bins.size(), false);
  for (int j = 0; j < g.h; ++j)
    for (int i = 0; i < g.w; ++i) {
      const size_t k = static_cast<size_t>(j) * g.w + i;
      g.inside[k] = g.Centre(i, j).norm() <= radius_m;
      d->cells_inside += g.inside[k] ? 1 : 0;
      if (!bins[k].empty() && g.inside[k]) {
        g.z[k] = Median(bins[k]);
        g.measured[k] = true;
        ++d->cells_with_points;
      }
    }
  return g;
}

// Spikes (a few stray points in a cell) out: a cell whose height departs from the median
// of its measured 3 x 3 neighbours by more than 6 robust sigmas of that departure over
// the grid is treated as empty.
void RemoveSpikes(HeightGrid* grid, Detection* d) {
  HeightGrid& g = *grid;
  std::vector<double> dep(g.z.size(), kNaN), all;
  for (int j = 0; j < g.h; ++j)
    for (int i = 0; i < g.w; ++i) {
      const size_t k = static_cast<size_t>(j) * g.w + i;
      if (!g.measured[k]) continue;
      std::vector<double> nb;
      for (int b = std::max(0, j - 1); b <= std::min(g.h - 1, j + 1); ++b)
        for (int a = std::max(0, i - 1); a <= std::min(g.w - 1, i + 1); ++a)
          if ((a != i || b != j) && g.measured[static_cast<size_t>(b) * g.w + a])
            nb.push_back(g.z[g.Index(a, b)]);
      if (nb.size() < 3) continue;
      dep[k] = g.z[k] - Median(nb);
      all.push_back(std::fabs(dep[k]));
    }
  const double spread = 1.4826 * Median(all);
  for (size_t k = 0; k < g.z.size(); ++k)
    if (!std::isnan(dep[k]) && std::fabs(dep[k]) > 6 * spread) {
      g.z[k] = kNaN;
      g.measured[k] = false;
      --d->cells_with_points;
    }
}

// Fill the empty cells inside the site from their measured neighbours (repeated averaging).
void FillGaps(HeightGrid* grid) {
  HeightGrid& g = *grid;
  for (int pass = 0; pass < 2 * g.w; ++pass) {
    std::vector<double> next = g.z;
    int filled = 0, missing = 0;
    for (int j = 0; j < g.h; ++j)
      for (int i = 0; i < g.w; ++i) {
        const size_t k = static_cast<size_t>(j) * g.w + i;
        if (!g.inside[k] || !std::isnan(g.z[k])) continue;
        double s = 0;
        int n = 0;
        for (const auto& [di, dj] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
          const int a = i + di, b = j + dj;
          if (a < 0 || b < 0 || a >= g.w || b >= g.h || std::isnan(g.z[g.Index(a, b)])) continue;
          s += g.z[g.Index(a, b)];
          ++n;
        }
        if (n > 0) {
          next[k] = s / n;
          ++filled;
        } else {
          ++missing;
        }
      }
    g.z = std::move(next);
    if (missing == 0 || filled == 0) break;
  }
}

// A cell's centre in units of the site's radius (scaled for conditioning).
Eigen::Vector2d UnitXy(const HeightGrid& g, size_t k) {
  return g.Centre(static_cast<int>(k % g.w), static_cast<int>(k / g.w)) / g.radius;
}

// Ground: asymmetric IRLS quadratic (or plane, `order` 1) on the measured `cells`, its
// coefficients in Basis order of UnitXy; `sigma` the robust spread of its residuals.
Eigen::Matrix<double, 6, 1> FitGround(const HeightGrid& g, const std::vector<size_t>& cells,
                                      int order, double* sigma) {
  // Start from the lowest 30 % of the cells (a lower envelope: the ground around a rise),
  // then reweight: cells more than 2 sigma above or 4 below the surface are left out.
  const int nb = order >= 2 ? 6 : 3;
  std::vector<bool> use(cells.size(), false);
  {
    std::vector<double> zs;
    for (size_t k : cells) zs.push_back(g.z[k]);
    const double low = Quantile(zs, 0.3);
    for (size_t c = 0; c < cells.size(); ++c) use[c] = g.z[cells[c]] <= low;
  }
  Eigen::Matrix<double, 6, 1> coef = Eigen::Matrix<double, 6, 1>::Zero();
  *sigma = 0;
  for (int it = 0; it < 20; ++it) {
    Eigen::MatrixXd A = Eigen::MatrixXd::Zero(nb, nb);
    Eigen::VectorXd b = Eigen::VectorXd::Zero(nb);
    int n = 0;
    for (size_t c = 0; c < cells.size(); ++c) {
      if (!use[c]) continue;
      const Eigen::Vector2d p = UnitXy(g, cells[c]);
      const Eigen::VectorXd f = Basis(p.x(), p.y()).head(nb);
      A += f * f.transpose();
      b += f * g.z[cells[c]];
      ++n;
    }
    if (n < 2 * nb) break;
    coef.setZero();
    coef.head(nb) = A.ldlt().solve(b);
    std::vector<double> r;
    for (size_t c = 0; c < cells.size(); ++c)
      if (use[c]) {
        const Eigen::Vector2d p = UnitXy(g, cells[c]);
        r.push_back(g.z[cells[c]] - Basis(p.x(), p.y()).dot(coef));
      }
    const double med = Median(r);
    std::vector<double> dev;
    for (double x : r) dev.push_back(std::fabs(x - med));
    *sigma = std::max(1e-3, 1.4826 * Median(dev));
    bool changed = false;
    for (size_t c = 0; c < cells.size(); ++c) {
      const Eigen::Vector2d p = UnitXy(g, cells[c]);
      const double res = g.z[cells[c]] - Basis(p.x(), p.y()).dot(coef);
      const bool u = res <= 2 * *sigma && res >= -4 * *sigma;
      changed |= u != use[c];
      use[c] = u;
    }
    if (!changed) break;
  }
  return coef;
}

// The whole site's form (see the header): its quadratic's sag and ridge in units of the
// radius, the relief left over it, its plane's slope, the ground fit's sag.
void MeasureSiteForm(const HeightGrid& g, const std::vector<size_t>& cells,
                     const Eigen::Matrix<double, 6, 1>& coef, Detection* d) {
  Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> b = Eigen::Matrix<double, 6, 1>::Zero();
  for (size_t k : cells) {
    const Eigen::Vector2d p = UnitXy(g, k);
    const Eigen::Matrix<double, 6, 1> f = Basis(p.x(), p.y());
    A += f * f.transpose();
    b += f * g.z[k];
  }
  const Eigen::Matrix<double, 6, 1> q = A.ldlt().solve(b);
  if (q.allFinite()) {
    const Eigen::Vector2d fall = Fall(q);
    d->site_sag_m = fall[0];
    d->site_ridge_m = fall[1];
    std::vector<double> left;
    left.reserve(cells.size());
    for (size_t k : cells) {
      const Eigen::Vector2d p = UnitXy(g, k);
      left.push_back(g.z[k] - Basis(p.x(), p.y()).dot(q));
    }
    d->site_relief_m = Quantile(left, 0.99) - Quantile(left, 0.01);
  }
  // the plane: the top-left 3 x 3 of the quadratic's normal equations
  const Eigen::Vector3d plane = A.topLeftCorner<3, 3>().ldlt().solve(b.head<3>());
  if (plane.allFinite()) d->site_slope_rad = std::atan(plane.tail<2>().norm() / g.radius);
  if (coef.allFinite()) d->ground_sag_m = Fall(coef)[0];
}

// The components of the relief over the site's ground fit, the most prominent (height x
// area) first (at most kReliefCandidates kept; `d->rises` counts them all).
std::vector<internal::Candidate> ReliefCandidates(const HeightGrid& g,
                                                  const Eigen::Matrix<double, 6, 1>& coef,
                                                  double threshold_m, Detection* d) {
  std::vector<internal::Candidate> candidates;
  std::vector<double> relief(g.z.size(), kNaN);
  for (size_t k = 0; k < g.z.size(); ++k) {
    if (!g.inside[k] || std::isnan(g.z[k])) continue;
    const Eigen::Vector2d p = UnitXy(g, k);
    relief[k] = g.z[k] - Basis(p.x(), p.y()).dot(coef);
  }
  std::vector<char> seen(g.z.size(), 0);
  std::vector<std::pair<double, internal::Candidate>> comps;
  const auto above = [&](size_t k) { return relief[k] > threshold_m; };
  for (size_t k = 0; k < g.z.size(); ++k) {
    const std::vector<size_t> comp = internal::GrowRegion(g, k, &seen, above);
    if (comp.empty()) continue;
    double sum = 0, top = 0;
    Eigen::Vector2d c = Eigen::Vector2d::Zero();
    for (size_t q : comp) {
      sum += relief[q];
      top = std::max(top, relief[q]);
      c += relief[q] * g.Centre(q);
    }
    const size_t n = comp.size();
    const double area = n * g.cell * g.cell;
    comps.push_back({top * area, {c / sum, std::sqrt(area / M_PI)}});
    if (n < 4) comps.back().first = -1;  // a few cells: noise
  }
  std::sort(comps.begin(), comps.end(),
            [](const auto& a, const auto& b) { return a.first > b.first; });
  for (const auto& [prominence, c] : comps) {
    if (prominence < 0) break;
    ++d->rises;
    if (candidates.size() < kReliefCandidates) candidates.push_back(c);
  }
  return candidates;
}

// Each candidate fitted and measured over its own ground twice: over a plane, its radius
// free, and over a quadratic at its own scale (radius within kOwnScale of the
// candidate's), where that window fits within the site (CurvedGroundFits) — a tumulus on
// a hill's top or shoulder, or among the undulations of rough ground, stands on ground that
// bends, and over a plane its fit runs out to the larger dome of the hill or takes the
// ground's swell in with it. Of each kind, rises that converged to the same dome
// (centres within a sixth of the larger diameter, diameters within 35 %) kept once, the
// most prominent (height x area) first: every distinct rise is judged.
void JudgeCandidates(const HeightGrid& g, const std::vector<internal::Candidate>& candidates,
                     double threshold_m, Detection* d) {
  std::vector<Rise> flat, curved;
  for (const internal::Candidate& c : candidates) {
    Rise r;
    if (internal::MeasureRise(g, c, threshold_m, &r)) flat.push_back(r);
    if (internal::CurvedGroundFits(g, c) &&
        internal::MeasureRise(g, c, threshold_m, &r, /*curved_ground=*/true))
      curved.push_back(r);
  }
  for (std::vector<Rise>* rises : {&flat, &curved}) {
    std::stable_sort(rises->begin(), rises->end(), [](const Rise& a, const Rise& b) {
      return a.height_m * a.area_m2 > b.height_m * b.area_m2;
    });
    const size_t first = d->judged.size();
    for (const Rise& r : *rises) {
      const bool seen = std::any_of(d->judged.begin() + first, d->judged.end(), [&](const Rise& q) {
        const double big = std::max(q.base_diameter_m, r.base_diameter_m);
        const double small = std::min(q.base_diameter_m, r.base_diameter_m);
        return (q.centre - r.centre).norm() < big / 6 && big < 1.35 * small;
      });
      if (!seen) d->judged.push_back(r);
    }
  }
}

}  // namespace

Detection DetectMound(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector2d& centre,
                      double radius_m, const DetectorOptions& o) {
  o.Check();
  if (!(radius_m > 0)) throw InputError("site radius must be > 0");
  Detection d;
  d.radius_m = radius_m;
  d.candidates = o.candidates;
  HeightGrid g = GridOfSite(points, centre, radius_m, o, &d);
  RemoveSpikes(&g, &d);
  FillGaps(&g);
  std::vector<size_t> cells;  // the measured cells
  for (size_t k = 0; k < g.z.size(); ++k)
    if (g.measured[k]) cells.push_back(k);
  double sigma = 0;
  const Eigen::Matrix<double, 6, 1> coef = FitGround(g, cells, o.ground_order, &sigma);
  d.ground_noise_m = sigma;
  MeasureSiteForm(g, cells, coef, &d);
  // Coefficients in metres of x, y from the centre.
  const double s = radius_m;
  d.ground_coefficients = {coef[0],           coef[1] / s,       coef[2] / s,
                           coef[3] / (s * s), coef[4] / (s * s), coef[5] / (s * s)};
  // Candidates: the components of the relief over the site's ground fit, and the
  // scale-space peaks of the heights (rise_fit.h); with local_relief also the peaks of
  // the relief over each point's own neighbourhood — every one, though a site-ground
  // candidate lies near: on steep ground those converge on the landform, these on what
  // stands out of it.
  std::vector<internal::Candidate> candidates = ReliefCandidates(g, coef, o.relief_threshold_m, &d);
  const bool local = o.candidates == DetectorOptions::Candidates::kLocalRelief;
  for (const internal::Candidate& c : internal::ScaleSpaceCandidates(
           g, o.relief_threshold_m, kScaleSpaceCandidates, /*measured_only=*/local))
    candidates.push_back(c);
  if (local)
    for (const internal::Candidate& c :
         internal::LocalReliefCandidates(g, o.relief_threshold_m, kLocalReliefCandidates))
      candidates.push_back(c);
  JudgeCandidates(g, candidates, o.relief_threshold_m, &d);
  for (Rise& r : d.judged) r.centre += centre;
  return d;
}

const std::vector<std::string>& VerdictFeatureNames() {
  static const std::vector<std::string> names = {
      "log_height", "log_diameter", "log_aspect",  "dome_r2",     "roundness",
      "symmetry",   "fill",         "flank_slope", "clipped",     "outside",
      "offset",     "log_snr",      "coverage",    "log_rises",   "site_sag",
      "site_ridge", "roughness",    "ring_high",   "ring_spread", "ground_slope",
      "shape_cone", "shape_drum",   "flat_top",    "point_top",   "point_spread"};
  return names;
}

std::vector<double> VerdictFeatures(const Detection& d) {
  if (!d.Tallest()) throw InternalError("VerdictFeatures: no rise");
  return VerdictFeatures(d, *d.Tallest());
}

const std::vector<std::string>& TerrainDescriptorNames() {
  static const std::vector<std::string> names = {"site_slope_rad", "site_relief_m", "site_sag_m",
                                                 "site_ridge_m", "ground_noise_m"};
  return names;
}

std::vector<double> TerrainDescriptors(const Detection& d) {
  return {d.site_slope_rad, d.site_relief_m, d.site_sag_m, d.site_ridge_m, d.ground_noise_m};
}

std::vector<double> VerdictFeatures(const Detection& d, const Rise& t) {
  const double h = std::max(t.height_m, 0.05), dia = std::max(t.base_diameter_m, 0.5);
  return {std::log(h),
          std::log(dia),
          std::log(h / dia),
          std::clamp(t.dome_r2, -1.0, 1.0),
          t.roundness,
          std::clamp(t.symmetry, -1.0, 1.0),
          std::clamp(t.fill, 0.0, 4.0),
          t.flank_slope_rad,
          t.clipped,
          t.outside,
          t.offset_m / d.radius_m,
          std::log(h / std::max(d.ground_noise_m, 0.01)),
          d.cells_inside > 0 ? static_cast<double>(d.cells_with_points) / d.cells_inside : 0,
          std::log1p(static_cast<double>(d.rises)),
          SignedLog(d.site_sag_m),
          SignedLog(d.site_ridge_m),
          std::clamp(t.roughness, 0.0, 5.0),
          std::clamp(t.ring_high, -2.0, 2.0),
          std::clamp(t.ring_spread, 0.0, 4.0),
          t.ground_slope_rad,
          t.shape == 1 ? 1.0 : 0.0,
          t.shape == 2 ? 1.0 : 0.0,
          t.flat_top,
          std::clamp(t.point_top, 0.0, 5.0),
          std::clamp(t.point_spread, 0.0, 5.0)};
}

}  // namespace mound::terrain
