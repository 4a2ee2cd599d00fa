// The compare and verdict pipelines of mound_recon as library functions (COLMAP's RunX ->
// library call): the CLI maps flags to these option structs, reads the files and writes
// what these functions return. Contract of compare.json and verdict.json:
// ../shared/INTERFACES.md.
//
// Two verdicts:
// - the paper's test (Section IV): ICP with scale of the site's cloud onto a reference
//   cloud, the distances fitted by N(mu, sigma); a mound when mu <= threshold_ratio x the
//   reference's relief (PaperRule);
// - reference-free (the survey's): the site's terrain (cpp/terrain's detector), each
//   prominent rise scored by the calibrated verdict model, the site's p the highest
//   (JudgeSite), with the coverage of the scan (JudgeCoverage).
#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "icp/icp.h"
#include "terrain/mound_detector.h"
#include "terrain/verdict_model.h"

namespace mound::recon {

// ---- compare ---------------------------------------------------------------------------

struct Comparison {
  icp::Result fit;
  std::vector<Eigen::Vector3d> aligned;  // the cloud in the reference's frame
  std::vector<double> distance;          // of each aligned point to the reference surface, m
  double icp_s = 0, distances_s = 0;
};

// ICP (icp::Align) and the surface distances of every aligned point. NoResultError when
// the clouds do not overlap.
Comparison Compare(const std::vector<Eigen::Vector3d>& cloud,
                   const std::vector<Eigen::Vector3d>& reference, const icp::Options& options);

// Mean and standard deviation (the maximum-likelihood N(mu, sigma)) of the distances up
// to their `quantile` (1: all).
struct NormalFit {
  double mu = 0, sigma = 0;
};
NormalFit FitNormal(const std::vector<double>& distances, double quantile);

// The fields compare.json and the paper's verdict share: init, reference_from_cloud,
// iterations, convergence, rmse_m, inlier_fraction, distance_m (statistics, the paper's
// N(mu, sigma) below the 99th percentile, a 20-bin histogram).
nlohmann::json ComparisonJson(const Comparison& c);

// ---- the paper's test ------------------------------------------------------------------

struct PaperTestOptions {
  double threshold_ratio = 0.05;  // of the reference's relief
  icp::Options icp;
  void Check() const;  // InputError naming the field
};

struct PaperDecision {
  bool mound = false;
  double mu_m = 0, sigma_m = 0, relief_m = 0, threshold_m = 0;
  // How far mu lies from the threshold, in units of the threshold (1 at 0 or 2x).
  double confidence = 0;
};

// The rule itself: a mound when mu <= threshold_ratio x relief.
PaperDecision PaperRule(double mu_m, double sigma_m, double relief_m, double threshold_ratio);

// The reference's relief: the 1st to the 99th percentile of its heights, m.
double Relief(const std::vector<Eigen::Vector3d>& reference);

struct PaperVerdict {
  Comparison comparison;
  PaperDecision decision;
};
PaperVerdict PaperTest(const std::vector<Eigen::Vector3d>& cloud,
                       const std::vector<Eigen::Vector3d>& reference,
                       const PaperTestOptions& options);

// verdict.json's method, label, confidence, measurements and reason for the paper's test.
nlohmann::json PaperVerdictJson(const PaperVerdict& v, double threshold_ratio);

// ---- the reference-free verdict --------------------------------------------------------

struct SiteVerdictOptions {
  // The site's radius; unset: the 80th percentile of the points' horizontal distance from
  // the site centre.
  std::optional<double> radius_m;
  // The registered cameras' centres (ENU, m). Given, and the radius not: a cloud whose
  // radius exceeds what they could see (CameraReach over the median height of the points
  // under their track) is a torn reconstruction — points strewn hundreds of metres off —
  // and is not judged (NoResultError): its rises lie beyond anything the model learned from.
  std::vector<Eigen::Vector3d> cameras;
  // Set: the cloud is a second look (a flight with a scan second_look.scan_factor x as wide
  // over a site the first left undecided), this the first flight's p_mound; the site is
  // decided by both (VerdictModel::SecondLookProbability), a mound at
  // second_look.threshold. The model must have a second_look (InputError otherwise).
  std::optional<double> first_look_p;
  // Set: two answers, "mound" at p_mound >= this (the paper's protocol, whatever the
  // model's undecided band); unset: the model's answers (VerdictModel::Label).
  std::optional<double> decide_at;
  terrain::DetectorOptions detector;
  void Check() const;  // InputError naming the field
};

// Whether the scan saw the judged rise whole: "whole", "no_rise", or "clipped" (the rise
// runs off the cloud's edge: > 10 % of its footprint's outline there or > 10 % of its
// fitted base outside the site; or the whole site is domed, a mound wider than the scan)
// with the scan diameter that would see it whole.
struct Coverage {
  std::string status;
  double scan_needed_m = 0;  // clipped only: rounded up to 10 m
  std::string message;       // clipped only
  double rise_clipped = 0, rise_outside = 0, site_sag_m = 0;
};
Coverage JudgeCoverage(const terrain::Detection& d, const terrain::Rise* judged, double radius_m);

struct SiteVerdict {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();  // ENU metres
  double radius_m = 0;
  terrain::Detection detection;
  double p_mound = 0;               // calibrated: the highest of the judged rises' p
  bool mound = false;               // p_mound >= threshold (the two answers)
  double threshold = 0.5;           // decide_at, else the second look's or the model's
  std::string label;                // "mound", "no_mound" or "undecided" (see decide_at)
  bool second_look = false;         // a second look: p_mound of both flights, its threshold
  double model_p = 0;               // the model's p of this flight alone
  double first_p = 0;               // a second look: the first flight's p_mound
  std::optional<double> decide_at;  // SiteVerdictOptions::decide_at
  std::optional<size_t> judged;     // the rise that decided, in detection.judged
  Coverage coverage;
  // The site's ground outside the model's terrain domain (VerdictModel::OutsideTerrain):
  // the label is then "undecided" whatever p says (not with decide_at), for the field team.
  std::vector<terrain::TerrainExcess> terrain;
  // The site was measured with candidate rises other than those the model was trained on
  // (SiteVerdictOptions::detector.candidates against VerdictModel::candidates): the label is
  // then "undecided" (not with decide_at), reason "model".
  bool other_candidates = false;
};

// Why a site is undecided, read from its measurements (they describe the doubt, they do not
// decide, save "model" and "terrain"): "model" (measured with candidate rises other than the
// model's training sites were), "terrain" (its ground lies outside the model's terrain domain:
// ground the model never saw), "clipped" (the rise runs off the scan), "sparse_cloud" (< 70 % of
// the site's cells hold points), "no_rise" (nothing above the relief threshold), "masked" (the
// ground around the rise stands >= half its height in some direction: relief of its own size),
// "cut" (the dome fit's residual >= 25 % of the height, or the footprint fills < half its
// disc: a looters' trench or pit, or damage; with the model's learned `reasons`: "cut" from
// its cut_roughness, "irregular" — as natural rises are — from its irregular_roughness),
// "low" (< 1 m high); "weak" when none of these.
// Each with a sentence for the field team.
std::vector<std::pair<std::string, std::string>> UndecidedReasons(
    const SiteVerdict& v, const terrain::VerdictModel& model);

// NoResultError when too few points lie on the site for a terrain model.
SiteVerdict JudgeSite(const std::vector<Eigen::Vector3d>& cloud, const Eigen::Vector2d& centre,
                      const SiteVerdictOptions& options, const terrain::VerdictModel& model);

// verdict.json's method, p_mound, label, confidence, coverage, measurements (every judged
// rise with its features and p), reason and model for the reference-free verdict.
nlohmann::json SiteVerdictJson(const SiteVerdict& v, const terrain::VerdictModel& model,
                               const std::string& model_file,
                               const terrain::DetectorOptions& detector);

// The centres of the registered cameras of a recon.json (ENU, m). InputError naming the
// field.
std::vector<Eigen::Vector3d> CameraCentres(const nlohmann::json& recon, const std::string& path);
// Their horizontal centre (the flight is centred on the candidate site); nothing when no
// image is registered.
std::optional<Eigen::Vector2d> CameraCentre(const nlohmann::json& recon, const std::string& path);
// The farthest from `centre` that the cameras could see of ground at height `ground_z`:
// over the cameras, the horizontal distance plus twice the height above that ground (a
// lens up to 127 degrees across, looking straight down; 0 without a camera).
double CameraReach(const std::vector<Eigen::Vector3d>& cameras, const Eigen::Vector2d& centre,
                   double ground_z);

}  // namespace mound::recon
