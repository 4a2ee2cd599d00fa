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
//   3. Candidate rises: the components of the relief over that ground (cells higher than
//      `relief_threshold_m`), and the scale-space peaks of the heights themselves, which
//      see a tumulus where one ground surface for the whole site bends under it.
//   4. Each candidate fitted over its own ground (rise_fit.h): a plane plus a dome
//      (paraboloid, cone or drum) of height H and base radius R within 1.5 R of its
//      centre, centre and R searched; then over that local plane its height (99th
//      percentile of the relief), footprint (area, volume, roundness, fill), radial
//      symmetry, flank slope, the fit's roughness, the relief of the frame around it by
//      sector (a ridge or a terrace runs on through it; a tumulus's foot is level all
//      round), the cloud's own points over the dome (their top and their spread about
//      it: the cells' medians smooth a haystack or a crown into a low dome, its points do
//      not lie on one), clipping (the share of the footprint's outline on the edge of the site,
//      and of the base disc outside it: a rise cut by the edge of the cloud is clipped, not
//      elongated), offset from the site centre, and the extent a scan would need to see it
//      whole.
//   5. Decision (verdict_model.h): each of the most prominent rises scored by a logistic
//      regression on its VerdictFeatures(), learned on a grid of simulated sites
//      (`mound recon train-verdict`); the site's p(mound) the highest, calibrated on the
//      sites; a site without a rise gets the model's p_no_rise.
#pragma once

#include <Eigen/Core>
#include <optional>
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
  // The candidate rises: kSiteGround those of the relief over the site's ground and of the
  // heights' scale space (as the built-in models were trained); kLocalRelief those and the
  // blobs of the local relief at every scale (LocalReliefCandidates in rise_fit.h: a rise
  // measured against the landform around it, so a tumulus on a steep slope, a ridge or
  // beside a larger landform is a candidate of its own). A verdict model names the set it
  // was trained on (its `detector.candidates`).
  enum class Candidates { kSiteGround, kLocalRelief };
  Candidates candidates = Candidates::kSiteGround;

  // InputError naming the field ("detector.ground_order: ...") when out of range.
  void Check() const;
};

struct Rise {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();  // ENU metres
  // From the local fit (rise_fit.h): the dome's base diameter 2 R, height H, the share of
  // the window's departure from a plane it explains (dome_r2), its shape (0 paraboloid,
  // 1 cone, 2 drum), the slope of the local ground plane.
  double base_diameter_m = 0, dome_height_m = 0, dome_r2 = 0;
  int shape = 0;
  double ground_slope_rad = 0;
  // The local ground plane z = g0 + g1 (x - centre x) + g2 (y - centre y), the cloud's z
  // (over a curved ground its tangent plane at the centre).
  Eigen::Vector3d ground_plane = Eigen::Vector3d::Zero();
  // Measured over a quadratic local ground at its candidate's own scale (a tumulus on a
  // hill, measured apart from the hill; see DetectMound):
  // the ground is then ground_plane + d (x - cx)^2 + e (x - cx)(y - cy) + f (y - cy)^2,
  // ground_curvature = (d, e, f) in 1/m; zero over a plane.
  bool curved_ground = false;
  Eigen::Vector3d ground_curvature = Eigen::Vector3d::Zero();
  // Over the local ground (plane or quadratic): height (99th percentile of the relief within R);
  // the footprint (relief above max(threshold, height / 4), grown from the peak within 3 R): its
  // area, volume, roundness (square root of the ratio of its second moments' eigenvalues: 1 for a
  // disc) and fill (area / pi R^2).
  double height_m = 0, area_m2 = 0, volume_m3 = 0, roundness = 0, fill = 0;
  double symmetry = 0;         // R^2 of the relief about its radial mean profile (r <= 1.5 R)
  double flank_slope_rad = 0;  // 90th percentile of the outward downhill slope of the relief
                               // over the footprint, as an angle
  double clipped = 0;          // share of the footprint's outline on the site's edge
  double outside = 0;          // share of the base disc outside the site
  double roughness = 0;        // RMS of the fit's residual within R, over H
  // The share of the footprint within 15 % of the height from the top: a roof is flat
  // (~1), a dome's top is small (a spherical cap 0.45 x as high as wide: ~0.2).
  double flat_top = 0;
  // The frame R < r <= 1.5 R in 8 sectors: the highest sector's mean relief and the spread
  // between the highest and the lowest, over the height (~0 around a tumulus, high along a
  // ridge, a terrace or a hillock's long axis).
  double ring_high = 0, ring_spread = 0;
  // From the cloud's points rather than the grid's cell medians: the 95th percentile of the
  // points' relief within R / 2, over the height (~1 on a dome; a haystack's or a tree's
  // top stands far above the median of its cells: 3-4), and the robust spread (1.4826 x
  // MAD) of the points' residual about the fitted dome within R, over the height (< 0.15
  // on an earthen dome; a roof above ground, a canopy, a terrace's two levels: 0.2-0.5).
  // From the cells within R when fewer than 3 (top) or 5 (spread) points fall there.
  double point_top = 1, point_spread = 0;
  double offset_m = 0;  // centre's distance from the site centre
  double extent_m = 0;  // farthest point of the rise (footprint or base disc) from the centre
  int cells = 0;
};

// The candidate rises (the centres and radii the rise fit starts from): the most
// prominent components of the relief over the site's ground, then the strongest peaks of
// the heights' scale space.
inline constexpr size_t kReliefCandidates = 8;
inline constexpr size_t kScaleSpaceCandidates = 24;
inline constexpr size_t kLocalReliefCandidates = 24;

// The name of a candidate set in files and flags ("site_ground", "local_relief"), and back
// (nullopt: no such set).
const char* CandidatesName(DetectorOptions::Candidates c);
std::optional<DetectorOptions::Candidates> CandidatesFromName(const std::string& name);

struct Detection {
  // Every distinct rise measured (a scan of real ground holds natural rises too, often
  // larger and more prominent than the tumulus, so each is judged and the site's p is the
  // highest): those over a plane, most prominent (height x area) first, then those over a
  // curved ground (Rise::curved_ground), in order.
  std::vector<Rise> judged;
  // The most prominent rise, or nullptr when none rose above the relief threshold.
  const Rise* Tallest() const { return judged.empty() ? nullptr : &judged.front(); }
  int rises = 0;  // components above the relief threshold
  DetectorOptions::Candidates candidates = DetectorOptions::Candidates::kSiteGround;  // the set
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
  // The ground the site stands on, for the verdict model's terrain domain (how far a site
  // lies from the ground the model was trained on): the slope of the least-squares plane
  // through every cell (rad), and the relief the whole site's quadratic leaves (the 1st to
  // the 99th percentile of the cells' residuals, m: ridges, valleys, terraces, knolls and
  // the tumulus itself).
  double site_slope_rad = 0, site_relief_m = 0;
  std::vector<double> ground_coefficients;  // z = c0 + c1 x + c2 y + c3 x^2 + c4 x y + c5 y^2 (x, y
                                            // from the centre)
};

// The features the verdict model reads, in this order (names: VerdictFeatureNames()): of
// one rise of the detection (its shape and position) and of the site (ground noise,
// coverage, how many rises, how the whole site curves); the first form: the most prominent.
const std::vector<std::string>& VerdictFeatureNames();
std::vector<double> VerdictFeatures(const Detection& d);
std::vector<double> VerdictFeatures(const Detection& d, const Rise& rise);

// The ground a site stands on, as the verdict model's terrain domain reads it (names:
// TerrainDescriptorNames(): site_slope_rad, site_relief_m, site_sag_m, site_ridge_m,
// ground_noise_m; the Detection's fields of those names).
const std::vector<std::string>& TerrainDescriptorNames();
std::vector<double> TerrainDescriptors(const Detection& d);

// `points` in a metric frame with z up; `centre` and `radius_m` the site (horizontal).
// Throws NoResultError when fewer than 100 points fall within the site.
Detection DetectMound(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector2d& centre,
                      double radius_m, const DetectorOptions& options);

}  // namespace mound::terrain
