// The reference-free verdict: is there a mound in this site's cloud? Read the way an
// archaeologist reads a terrain model: a dome-shaped rise above the surrounding ground.
//
//   1. Grid: the georeferenced cloud (ENU metres, z up) around the site centre, binned into
//      square cells (median height per cell; empty cells filled from their neighbours).
//   2. Ground: a quadratic surface (or a plane) fitted first to the lowest 30 % of the
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
//      Also: its radial symmetry (R^2 of a free radial profile about its centroid), fill
//      (area over the disc of its base diameter), flank slope (90th percentile of the
//      relief's gradient, radians), clipping (the share of its outline on the edge of the
//      site: a rise cut by the edge of the cloud is clipped, not elongated), offset from the
//      site centre, and the extent a scan would need to see it whole.
//   5. Decision (verdict_model.h): each of the most prominent rises scored by a logistic
//      regression on its VerdictFeatures(), learned on a grid of simulated sites
//      (`mound recon train-verdict`); the site's p(mound) the highest, calibrated on the
//      sites; a site without a rise gets the model's p_no_rise.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace mound::terrain {

struct DetectorOptions {
  double cell_m = 0;  // 0: about 4 points per cell, within [0.25 m, radius / 25]
  // 2: a quadratic surface (the default: real ground curves, and on the training grid it
  // separated mounds from ground better, out-of-fold AUC 0.94 against 0.91 for a plane on
  // the sites without the DEM); 1: a plane. A quadratic bends into the dome of a mound
  // wider than the scan: the site's own curvature (site_sag_m) tells that case.
  int ground_order = 2;
  double relief_threshold_m = 0.3;

  // InputError naming the field ("detector.ground_order: ...") when out of range.
  void Check() const;
};

struct Rise {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();  // ENU metres
  double height_m = 0, base_diameter_m = 0, dome_height_m = 0, dome_r2 = 0;
  double area_m2 = 0, volume_m3 = 0, roundness = 0;
  double symmetry = 0;         // R^2 of the relief about its radial mean profile
  double fill = 0;             // area / (pi (base diameter / 2)^2)
  double flank_slope_rad = 0;  // 90th percentile of |grad relief| over the rise, as an angle
  double clipped = 0;          // share of the outline's cells on the site's edge
  double offset_m = 0;         // centroid's distance from the site centre
  double extent_m = 0;         // farthest cell of the rise from the site centre
  int cells = 0;
};

// The rises judged (the most prominent first): a scan of real ground holds natural rises
// too, often larger than the tumulus, so each is scored and the site's p is the highest.
inline constexpr size_t kMaxJudgedRises = 8;

struct Detection {
  std::vector<Rise> judged;  // the kMaxJudgedRises most prominent (height x area), in order
  // The most prominent rise, or nullptr when none rose above the relief threshold.
  const Rise* Tallest() const { return judged.empty() ? nullptr : &judged.front(); }
  int rises = 0;  // components above the relief threshold
  double cell_m = 0;
  int grid_width = 0, grid_height = 0, cells_with_points = 0, cells_inside = 0;
  double radius_m = 0;
  double ground_noise_m = 0;  // robust sigma of the ground cells' relief
  // A quadratic fitted to the whole site (every cell, not only the ground): how far it
  // falls from the centre to the site's edge along its least and most curved directions
  // (m; positive: falling). A site on a mound wider than the scan sees no ground: the
  // ground fit then runs along the mound's flanks, but the site is domed (both > 0); a
  // ridge falls one way only; a valley or flat ground does not fall.
  double site_sag_m = 0, site_ridge_m = 0;
  // The same fall (least falling direction) of the ground fit alone: > 0 when the ground
  // itself is domed (it follows a mound wider than the scan), ~0 on ground around a tumulus.
  double ground_sag_m = 0;
  std::vector<double> ground_coefficients;  // z = c0 + c1 x + c2 y + c3 x^2 + c4 x y + c5 y^2 (x, y
                                            // from the centre)
};

// The features the verdict model reads, in this order (names: VerdictFeatureNames()): of
// one rise of the detection (its shape and position) and of the site (ground noise,
// coverage, how many rises, how the whole site curves); the first form: the most prominent.
const std::vector<std::string>& VerdictFeatureNames();
std::vector<double> VerdictFeatures(const Detection& d);
std::vector<double> VerdictFeatures(const Detection& d, const Rise& rise);

// `points` in a metric frame with z up; `centre` and `radius_m` the site (horizontal).
// Throws NoResultError when fewer than 100 points fall within the site.
Detection DetectMound(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector2d& centre,
                      double radius_m, const DetectorOptions& options);

}  // namespace mound::terrain
