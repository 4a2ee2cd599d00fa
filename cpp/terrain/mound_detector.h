// The reference-free verdict: is there a mound in this site's cloud? Read the way an
// archaeologist reads a terrain model: a dome-shaped rise above the surrounding ground.
//
//   1. Grid: the georeferenced cloud (ENU metres, z up) around the site centre, binned into
//      square cells (median height per cell; empty cells filled from their neighbours).
//   2. Ground: a plane (or a quadratic surface) fitted first to the lowest 30 % of the
//      cells, then by iteratively reweighted least squares with an asymmetric window —
//      cells more than 2 robust sigmas above the surface or 4 below it are left out of the
//      next fit — so that a rise (or a pit) does not pull the ground up (the idea of
//      progressive ground filters, with a low-order surface in place of the morphological
//      one).
//   3. Relief: cell height minus ground; rises: 4-connected components of cells higher than
//      `relief_threshold_m`.
//   4. Each rise: its height (99th percentile of the relief), a radially symmetric dome
//      h(r) = H (1 - r^2 / R^2) fitted around its centroid (base diameter 2R, and R^2 of the
//      fit), its volume (sum of relief x cell area), its roundness (square root of the ratio
//      of the second moments' eigenvalues: 1 for a disc).
//   5. Decision: the tallest rise is a mound when height >= min_height_m, base diameter >=
//      min_diameter_m, roundness >= min_roundness and dome R^2 >= min_dome_r2. Confidence:
//      the product of logistic margins on those four (for `mound`), or one minus it.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

namespace mound::terrain {

struct DetectorOptions {
  double cell_m = 0;               // 0: about 4 points per cell, within [0.25 m, radius / 25]
  // 1: a plane (the default: a site's flight sees little ground around a large mound, and
  // a quadratic there bends into the mound's dome); 2: a quadratic surface.
  int ground_order = 1;
  double relief_threshold_m = 0.3;
  double min_height_m = 1.0;
  double min_diameter_m = 8.0;
  double min_roundness = 0.6;
  double min_dome_r2 = 0.6;
};

struct Rise {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();  // ENU metres
  double height_m = 0, base_diameter_m = 0, dome_height_m = 0, dome_r2 = 0;
  double area_m2 = 0, volume_m3 = 0, roundness = 0;
  int cells = 0;
};

struct Detection {
  bool mound = false;
  double confidence = 0;
  std::optional<Rise> tallest;  // the rise the decision is about
  int rises = 0;                // components above the relief threshold
  double cell_m = 0;
  int grid_width = 0, grid_height = 0, cells_with_points = 0;
  double ground_noise_m = 0;    // robust sigma of the ground cells' relief
  std::vector<double> ground_coefficients;  // z = c0 + c1 x + c2 y + c3 x^2 + c4 x y + c5 y^2 (x, y from the centre)
  std::string reason;           // the decision in words
};

// `points` in a metric frame with z up; `centre` and `radius_m` the site (horizontal).
// Throws NoResultError when fewer than 100 points fall within the site.
Detection DetectMound(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector2d& centre, double radius_m,
                      const DetectorOptions& options);

}  // namespace mound::terrain
