// The rises of a site, each measured against its own ground (internal to the detector).
//
// A rise is found twice over, so that neither way's blind spot loses it:
//   - scale-space candidates: the centre-surround contrast of the height grid (the mean of
//     a box of half-width R/2 less the mean of the frame between boxes of half-width R and
//     1.5 R, from summed-area tables), at radii R from 2.5 m to the site's radius in steps
//     of 1.3; local maxima over position and radius (the blob detector of scale-space
//     theory, with boxes in place of Gaussians). It sees a tumulus on undulating or curved
//     ground, where a single ground surface for the whole site bends under it;
//   - the components of the relief over the whole site's ground fit (centroid, equivalent
//     radius).
// Each candidate is then fitted locally: within rho = max(1.5 R, R + 3 cells) of a centre
// c, the heights are a plane plus a dome of height H and base radius R,
//   z = a + b x + c y + H phi(|p - c| / R),
// phi a paraboloid (1 - t^2), a cone (1 - t) or a flat-topped drum (min(1, 2 (1 - t))), all
// zero beyond R; linear least squares for (a, b, c, H) at each (c, R, phi), searched over c
// and R by coordinate descent, keeping the fit whose dome explains most of the window's
// departure from a plane (q = 1 - SSE(plane + dome) / SSE(plane), with H > 0).
// Over a curved ground the ground is a quadratic (a + b x + c y + d x^2 + e x y + f y^2)
// within rho = max(2 R, R + 4 cells), q its share explained likewise, and R held within
// kOwnScale of the candidate's own: a tumulus on a hill, measured with the hill as its
// ground.
// The measurements then use the relief over that local ground (see Rise in
// mound_detector.h).
#pragma once

#include <Eigen/Core>
#include <utility>
#include <vector>

#include "terrain/mound_detector.h"

namespace mound::terrain::internal {

struct HeightGrid {
  int w = 0, h = 0;
  double cell = 0;
  double radius = 0;           // the site's radius, m
  Eigen::Vector2d origin;      // centre of cell (0, 0) relative to the site centre
  std::vector<double> z;       // NaN: outside the site or no data even after filling
  std::vector<bool> measured;  // the cell holds points (not filled)
  std::vector<bool> inside;    // the cell's centre lies within the site
  // The site's points themselves (x, y relative to the site centre): the cells hold their
  // medians, which smooth a narrow tall object (a haystack's roof over a few cells of
  // ground) into a low dome; the points keep its roof apart from its ground.
  std::vector<Eigen::Vector3d> points;
  size_t Index(int i, int j) const { return static_cast<size_t>(j) * w + i; }
  Eigen::Vector2d Centre(int i, int j) const { return origin + cell * Eigen::Vector2d(i, j); }
  Eigen::Vector2d Centre(size_t k) const {
    return Centre(static_cast<int>(k % w), static_cast<int>(k / w));
  }
};

// The 4-connected cells reachable from `seed` through cells that `accept(k)` admits, the
// seed first (nothing when it is not admitted), each marked in `visited` (w x h, cells
// already marked are not entered), in the order a depth-first stack takes them.
template <class Accept>
std::vector<size_t> GrowRegion(const HeightGrid& g, size_t seed, std::vector<char>* visited,
                               Accept accept) {
  std::vector<size_t> region, stack;
  std::vector<char>& in = *visited;
  if (in[seed] || !accept(seed)) return region;
  in[seed] = 1;
  stack.push_back(seed);
  while (!stack.empty()) {
    const size_t k = stack.back();
    stack.pop_back();
    region.push_back(k);
    const int i = static_cast<int>(k % g.w), j = static_cast<int>(k / g.w);
    for (const auto& [di, dj] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
      const int a = i + di, b = j + dj;
      if (a < 0 || b < 0 || a >= g.w || b >= g.h) continue;
      const size_t n = g.Index(a, b);
      if (in[n] || !accept(n)) continue;
      in[n] = 1;
      stack.push_back(n);
    }
  }
  return region;
}

// The quadratic basis [1, x, y, x^2, x y, y^2] (its first 3 terms: a plane), shared by the
// site's ground fit and each rise's local ground.
inline Eigen::Matrix<double, 6, 1> Basis(double x, double y) {
  Eigen::Matrix<double, 6, 1> b;
  b << 1, x, y, x * x, x * y, y * y;
  return b;
}

struct Candidate {
  Eigen::Vector2d centre;  // relative to the site centre, m
  double radius_m = 0;
};

// Scale-space candidates (the strongest `max_count` local maxima with a contrast above
// `min_contrast_m`, by contrast x radius, one per blob: a weaker maximum near a stronger
// one at a like scale is left out). `measured_only`: over the cells that hold points alone
// (the cells filled from their neighbours across a gap in the cloud make plateaus of their
// own: on a steep slope, blobs stronger than any tumulus).
std::vector<Candidate> ScaleSpaceCandidates(const HeightGrid& g, double min_contrast_m,
                                            size_t max_count, bool measured_only = false);

// Local-relief candidates (DetectorOptions::candidates = kLocalRelief): the same blob
// search on a response that measures a rise against the landform around it, not the
// site's: the mean of a box of half-width R/2 less the ground that each of the four axes
// through it gives (the line through two boxes of that size 1.25 R away on either side,
// at the inner box's centroid: exact on a plane, however steep, and whatever the site's
// edge clips), the least of the four (the inner box at least half measured, each side box a
// quarter: a gap in the cloud beside a tumulus leaves it its axes). A tumulus stands above
// its ground along every axis; a ridge, a terrace's edge or a valley's side runs on along
// one, and a slope along all.
std::vector<Candidate> LocalReliefCandidates(const HeightGrid& g, double min_contrast_m,
                                             size_t max_count);

// Over a curved ground a candidate's radius is held within this factor of its own (over a
// plane it is free, up to 1.25 x the site's radius).
constexpr double kOwnScale = 1.4;

// Whether a candidate may be fitted over a curved ground: the quadratic's window (2 R) at
// the largest radius it may take there (kOwnScale x the candidate's) lies within the site,
// so that the frame beyond the dome pins the ground's curvature.
inline bool CurvedGroundFits(const HeightGrid& g, const Candidate& c) {
  return 2 * kOwnScale * c.radius_m <= g.radius;
}

// The rise a candidate converges to, measured (Rise's fields, centre relative to the site
// centre), or false when no dome with H > 0 fits there. `relief_threshold_m` the lowest
// relief that counts as the rise's footprint; `curved_ground`: the local ground a quadratic
// (within 2 R, the radius near the candidate's own) instead of a plane (within 1.5 R).
bool MeasureRise(const HeightGrid& g, const Candidate& start, double relief_threshold_m, Rise* out,
                 bool curved_ground = false);

}  // namespace mound::terrain::internal
