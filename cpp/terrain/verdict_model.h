// The verdict's decision: p(mound) of a site from the detector's measurements of its most
// prominent rise, by a logistic regression learned on a grid of simulated sites and
// calibrated on another (`mound recon train-verdict`), read from a `mound.verdict_model` v1
// file:
//   {"schema": "mound.verdict_model", "version": 1, "features": [the names of
//    VerdictFeatureNames(), each once, in any order: mean, std and weights follow it],
//    "mean": [...], "std": [...] (the standardisation),
//    "weights": [...], "bias": b, "threshold": t (label mound when p >= t),
//    "p_no_rise": p (a site with no rise above the relief threshold), ...}
//   s(rise) = b + w . phi(z), z_k = (f_k - mean_k) / std_k bounded to [-c, c] when the
//   file gives "z_clip": c (> 0; a hinge is linear beyond the training data, so a feature
//   far outside it would otherwise score on an extrapolation), phi the "basis": "linear"
//   (z), "hinge" (z, max(z - 1, 0), max(-z - 1, 0); 3 x the weights) or "hinge_products"
//   (the hinge's, then per pair [a, b] of "products" — two of the model's feature names —
//   z_a z_b, each factor bounded to [-q, q] with q the file's "product_clip" (> 0);
//   3 x the features + the pairs' weights);
//   p(site) = 1 / (1 + exp(-g(max over the judged rises of s))) (the Platt calibration of
//   the site's highest score folded into w and b), g the identity or, when the file gives
//   "calibration": {"method": "beta", "a": a, "b": b, "c": c} (a, b >= 0, a + b > 0), the
//   beta calibration of q = 1 / (1 + exp(-s)): g(s) = a ln q - b ln(1 - q) + c
//   = b softplus(s) - a softplus(-s) + c, increasing in s (Kull, Silva Filho and Flach
//   2017)
// and optionally "second_look": {"p_low": l, "threshold": t2, "scan_factor": k,
//   "combine": {"first": c1, "second": c2, "bias": c0}}: a site whose p lies in
//   [l, threshold) is undecided by its flight; flown again with a scan k x as wide, it is
//   decided by both flights, p = 1 / (1 + exp(-(c1 logit(p1) + c2 logit(p2) + c0))) with p1
//   and p2 this model's p of the first and the wider flight (c2 > 0), a mound when >= t2
//   (`SecondLookProbability`);
// and optionally "undecided": {"p_low": l, "p_high": h} (0 < l <= h < 1): three answers,
//   "no_mound" at p < l, "undecided" in [l, h), "mound" at p >= h (`Label`), the band chosen
//   by `mound recon train-verdict` on its sites' out-of-fold p; a site in it is advised a
//   second look (with "second_look") or a person. Without it the model gives two answers,
//   "mound" at p >= threshold, as the threshold always does for the paper's protocol. Its
//   optional "by_slope": [{"site_slope_rad": [low, high], "p_low", "p_high"}, ...] (2 to 8,
//   ascending, each from where the last ended, within [-pi/2, pi/2]): a band per measured
//   site slope (`BandFor`), the steep ground's p being less sure than the gentle's.
// and optionally "terrain_domain": {"ranges": {name: [low, high], ...}, "sites": n, ...}:
//   the ground the model was trained on, as the training sites' TerrainDescriptors (names
//   of TerrainDescriptorNames(), each at most once) ranged; a site whose ground lies
//   outside any range is ground the model never saw, and its verdict is "undecided" with
//   reason "terrain" whatever its p (`OutsideTerrain`; the paper's two answers, decide_at,
//   stay as they are). Its optional "neighbours": {"k" (1..50), "centre", "scale" (> 0; one
//   per descriptor), "points" (k to 100,000 training sites' standardised descriptors),
//   "max_distance" (>= 0)}: a site farther than that, on average, from its k nearest
//   training sites is outside too (TerrainNeighbours). Other fields (sites, grids, how
//   measured) travel as they are.
// and optionally "reasons": {"cut_roughness": a, "irregular_roughness": b} (0 < a <= b <
//   1000): ReasonThresholds.
// Two models ship in the repository and are compiled into the tool, learned on the same
// simulated sites judged on two clouds: data/verdict_model.json on the sparse cloud of
// `reconstruct` (the default), data/verdict_model_dense.json on the dense cloud of
// `densify` as the survey densifies (depth maps 320 px, 0.25 m voxels); --model picks one or
// reads another.
#pragma once

#include <cmath>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "terrain/mound_detector.h"

namespace mound::terrain {

// The second look of a site its flight left undecided (see above).
struct SecondLook {
  double p_low = 0, threshold = 0.5, scan_factor = 2;
  double first = 0, second = 1, bias = 0;  // "combine"
};

// The band of p that leaves a site undecided (see above).
struct UndecidedBand {
  double p_low = 0, p_high = 1;
};

// undecided.by_slope's band: the band of the sites whose measured slope lies in
// [slope_low, slope_high) radians (the bands ascend, each from where the last ended).
struct SlopeBand {
  double slope_low = 0, slope_high = 0;
  UndecidedBand band;
};

// How the clouds a model was trained on were made (the file's optional `cloud_settings`):
// `cloud` "dense" (mound_recon densify's dense.ply) or "sparse" (reconstruct's points.ply),
// and for a dense model the densify options that shape the cloud (dense.json's `options`
// of the training sites: max_image_size, resolution_m, ...). A cloud made otherwise is not
// one the model has seen: `mound_recon verdict` refuses it (CheckCloudSettings).
struct CloudSettings {
  std::string cloud;
  std::vector<std::pair<std::string, double>> options;  // name, value
};

// Nothing when the cloud (its densify `options`, empty for a sparse cloud) was made as the
// model's training clouds were; else InputError naming `where`, the setting, both values and
// the flag that makes a cloud like the model's.
void CheckCloudSettings(const CloudSettings& model, const std::string& cloud,
                        const nlohmann::json& options, const std::string& where);

// One descriptor of a site's ground outside the model's terrain domain (see above).
struct TerrainExcess {
  std::string name;
  double value = 0, low = 0, high = 0;
};

// terrain_domain.neighbours: the training sites' ground, each of TerrainDescriptors()
// less `centre` over `scale`; a site whose mean distance to its `k` nearest lies beyond
// `max_distance` is ground unlike the training sites' (named "training_distance").
struct TerrainNeighbours {
  int k = 5;
  std::vector<double> centre, scale;
  std::vector<std::vector<double>> points;
  double max_distance = 0;
  double Distance(const std::vector<double>& descriptors) const;
};

// The optional "reasons": the rise's roughness (the dome fit's residual over its height)
// that names an undecided site's cause: "cut" (a looters' trench or pit) from
// cut_roughness, "irregular" (as natural rises are) from irregular_roughness, both learned
// by train-verdict from its sites' truth. Without it the reasons' fixed rule holds.
struct ReasonThresholds {
  double cut_roughness = 0.25, irregular_roughness = 1e9;
};

struct VerdictModel {
  std::vector<std::string> features;
  std::vector<double> mean, std, weights;
  std::vector<size_t> index;  // the detector's position of each of the model's features
  bool hinge = false;
  double z_clip = 0;  // 0: z unbounded
  // hinge_products: the model's positions of each pair's two features, and their bound
  std::vector<std::pair<size_t, size_t>> products;
  double product_clip = 0;
  double bias = 0, threshold = 0.5, p_no_rise = 0;
  bool beta = false;  // "calibration" (see above): g(s); else the identity
  double beta_a = 1, beta_b = 1, beta_c = 0;
  std::optional<SecondLook> second_look;
  std::optional<UndecidedBand> undecided;
  std::vector<SlopeBand> slope_bands;  // undecided.by_slope (empty: one band for all)
  std::optional<CloudSettings> cloud_settings;
  // terrain_domain's ranges, by TerrainDescriptorNames() position (empty: no domain)
  std::vector<std::pair<size_t, std::pair<double, double>>> terrain_ranges;
  std::optional<TerrainNeighbours> terrain_neighbours;  // terrain_domain.neighbours
  std::optional<ReasonThresholds> reasons;
  // The candidate rises the model was trained on (`detector.candidates`; without it the
  // site-ground set the built-in models were trained on): a site measured with another set
  // is undecided (reason "model"), its p not the model's to give.
  DetectorOptions::Candidates candidates = DetectorOptions::Candidates::kSiteGround;
  nlohmann::json doc;  // the whole file (its figures travel into verdict.json)

  double Score(const std::vector<double>& f) const;  // s of one rise's features
  double Calibrated(double s) const;                 // g(s): the logit of p
  double Probability(const std::vector<double>& f) const;
  // p(mound) of a detection: the highest over its judged rises, or p_no_rise without one;
  // `best` (if given) the index in d.judged of the rise that gave it.
  double Probability(const Detection& d, size_t* best = nullptr) const;
  // The undecided band of a site whose ground slopes `slope_rad` (measured, the
  // detector's site_slope_rad): its by_slope band (beyond the first or last, the nearest),
  // or the one band without them or for a NaN slope. Requires `undecided`.
  UndecidedBand BandFor(double slope_rad) const;
  // "mound", "no_mound" or "undecided" for p: by the undecided band (BandFor the site's
  // slope), or (without one) "mound" at p >= `two_answer_at`.
  std::string Label(double p, double two_answer_at, double slope_rad = std::nan("")) const;
  // Whether a first look's p advises a second look: the model has a second_look and p lies
  // in the undecided band, or (without one) in [second_look.p_low, threshold).
  bool SecondLookAdvised(double p, double slope_rad = std::nan("")) const;
  // The second look's calibrated p from this model's p of the first flight and of the
  // wider one (requires second_look).
  double SecondLookProbability(double p_first, double p_second) const;
  // The descriptors of the site's ground outside the terrain domain (none without one).
  std::vector<TerrainExcess> OutsideTerrain(const Detection& d) const;
};

// The first flight's p_mound from its verdict.json (`path` names it in errors; what
// `mound_recon verdict --second-look` reads): a reference-free first look that was judged;
// InputError naming the field otherwise (a field absent or not of its type included).
double FirstLookP(const nlohmann::json& verdict, const std::string& path);

// Throws InputError naming `source` and the field: a wrong schema or version, missing or
// non-finite numbers, arrays of the wrong length, std <= 0, or features other than the
// detector's (a model made for another detector).
VerdictModel ParseVerdictModel(const nlohmann::json& doc, const std::string& source);
VerdictModel LoadVerdictModel(const std::string& path);
const VerdictModel& DefaultVerdictModel();  // the sparse cloud's
const VerdictModel& DenseVerdictModel();    // the dense cloud's
// The built-in model called `name` ("sparse": DefaultVerdictModel, "dense":
// DenseVerdictModel), or nullptr for any other name.
const VerdictModel* BuiltInVerdictModel(const std::string& name);

}  // namespace mound::terrain
