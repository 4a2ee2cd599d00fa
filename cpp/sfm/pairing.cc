#include "sfm/pairing.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>

namespace mound::sfm {

double FootprintOverlap(double h1, double h2, double d, double focal_px, int width_px,
                        int height_px) {
  const double half_diag_px = 0.5 * std::hypot(width_px, height_px);
  const double r1 = h1 * half_diag_px / focal_px, r2 = h2 * half_diag_px / focal_px;
  const double small = std::min(r1, r2), big = std::max(r1, r2);
  if (d >= r1 + r2) return 0.0;
  if (d <= big - small) return 1.0;  // the smaller disc lies inside the larger
  // The lens-shaped intersection of two discs.
  const double a1 = std::acos(std::clamp((d * d + r1 * r1 - r2 * r2) / (2 * d * r1), -1.0, 1.0));
  const double a2 = std::acos(std::clamp((d * d + r2 * r2 - r1 * r1) / (2 * d * r2), -1.0, 1.0));
  const double area = r1 * r1 * (a1 - std::sin(2 * a1) / 2) + r2 * r2 * (a2 - std::sin(2 * a2) / 2);
  return area / (M_PI * small * small);
}

namespace {

int Located(const std::vector<std::optional<Eigen::Vector3d>>& positions) {
  return static_cast<int>(std::count_if(positions.begin(), positions.end(),
                                        [](const auto& p) { return p.has_value(); }));
}

// Every pair: an unlocated set this small.
bool Exhaustive(int located, int n, const PairingOptions& o) {
  return located < 2 && n <= o.exhaustive_up_to;
}

}  // namespace

bool PairsByAppearance(const std::vector<std::optional<Eigen::Vector3d>>& positions,
                       const PairingOptions& o) {
  const int n = static_cast<int>(positions.size()), located = Located(positions);
  return o.retrieval_neighbours > 0 && located < n && !Exhaustive(located, n, o);
}

PairSelection SelectPairs(const std::vector<std::optional<Eigen::Vector3d>>& positions,
                          const PairingOptions& o, const std::vector<std::vector<int>>* similar) {
  const int n = static_cast<int>(positions.size());
  PairSelection out;
  out.located = Located(positions);
  std::set<std::pair<int, int>> pairs;
  auto add = [&](int i, int j) {
    if (i != j) pairs.insert({std::min(i, j), std::max(i, j)});
  };
  if (Exhaustive(out.located, n, o)) {
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j) add(i, j);
    out.method = "exhaustive";
  } else {
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j <= std::min(n - 1, i + o.sequence_window); ++j) add(i, j);
    out.method = "sequential";
    const bool footprints = o.ground_z && o.focal_px > 0 && o.width_px > 0 && o.height_px > 0;
    if (out.located >= 2) {
      out.method = footprints ? "spatial+footprint" : "spatial";
      out.max_distance_m = o.max_distance_m;
      if (out.max_distance_m <= 0 && o.max_distance_factor > 0) {
        std::vector<double> nearest;
        for (int i = 0; i < n; ++i) {
          if (!positions[i]) continue;
          double best = std::numeric_limits<double>::infinity();
          for (int j = 0; j < n; ++j)
            if (j != i && positions[j])
              best = std::min(best, (*positions[i] - *positions[j]).norm());
          nearest.push_back(best);
        }
        std::nth_element(nearest.begin(), nearest.begin() + nearest.size() / 2, nearest.end());
        out.max_distance_m = o.max_distance_factor * std::max(nearest[nearest.size() / 2], 1e-3);
      }
      for (int i = 0; i < n; ++i) {
        if (!positions[i]) continue;
        std::vector<std::pair<double, int>> near;
        for (int j = 0; j < n; ++j) {
          if (j == i || !positions[j]) continue;
          const Eigen::Vector3d& a = *positions[i];
          const Eigen::Vector3d& b = *positions[j];
          const double d3 = (a - b).norm();
          if (out.max_distance_m > 0 && d3 > out.max_distance_m) continue;
          if (footprints) {
            const double hi = a.z() - *o.ground_z, hj = b.z() - *o.ground_z;
            if (hi <= 0 || hj <= 0) continue;
            const double overlap = FootprintOverlap(hi, hj, (a - b).head<2>().norm(), o.focal_px,
                                                    o.width_px, o.height_px);
            if (overlap < o.min_overlap) continue;
            near.emplace_back(-overlap, j);  // the largest overlaps first
          } else {
            near.emplace_back(d3, j);
          }
        }
        std::sort(near.begin(), near.end());
        const size_t k =
            std::min<size_t>(static_cast<size_t>(std::max(0, o.spatial_neighbours)), near.size());
        for (size_t m = 0; m < k; ++m) add(i, near[m].second);
      }
    }
    if (similar && PairsByAppearance(positions, o)) {
      if (static_cast<int>(similar->size()) != n)
        throw std::invalid_argument("SelectPairs: one similar list per image");
      for (int i = 0; i < n; ++i) {
        if (positions[i]) continue;
        const auto& s = (*similar)[i];
        const size_t k =
            std::min(s.size(), static_cast<size_t>(std::max(0, o.retrieval_neighbours)));
        for (size_t m = 0; m < k; ++m) {
          if (s[m] >= 0 && s[m] < n) add(i, s[m]);
        }
      }
      out.method += "+retrieval";
    }
  }
  out.pairs.assign(pairs.begin(), pairs.end());
  return out;
}

}  // namespace mound::sfm
