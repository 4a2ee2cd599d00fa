#include "recon/verdict.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "common/error.h"
#include "common/json_util.h"
#include "common/stats.h"
#include "common/timing.h"

namespace mound::recon {
namespace {

nlohmann::json SimJson(const geometry::Sim3d& s) {
  const Eigen::Matrix3d R = s.rotation.toRotationMatrix();
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 3; ++r) rows.push_back({R(r, 0), R(r, 1), R(r, 2)});
  return {{"R", rows},
          {"t", {s.translation.x(), s.translation.y(), s.translation.z()}},
          {"scale", s.scale}};
}

// Mean, std, median, 90th percentile, max, a 20-bin histogram up to the 99th percentile,
// and the paper's N(mu, sigma) fitted to the distances below their 99th percentile (a
// sparse model's few stray points, tens of metres off, would otherwise make sigma).
nlohmann::json DistanceJson(const std::vector<double>& d) {
  const NormalFit all = FitNormal(d, 1.0), paper = FitNormal(d, 0.99);
  const double top = std::max(1e-9, Quantile(d, 0.99));
  std::vector<long long> counts(20, 0);
  long long above = 0;
  for (double x : d) {
    const int b = static_cast<int>(x / top * 20);
    if (b >= 20)
      ++above;
    else
      ++counts[std::max(0, b)];
  }
  return {
      {"mean", all.mu},
      {"std", all.sigma},
      {"median", Quantile(d, 0.5)},
      {"p90", Quantile(d, 0.9)},
      {"max", *std::max_element(d.begin(), d.end())},
      {"normal_fit", {{"mu", paper.mu}, {"sigma", paper.sigma}, {"below_quantile", 0.99}}},
      {"histogram", {{"bin_width_m", top / 20}, {"counts", counts}, {"above_last_bin", above}}}};
}

constexpr const char* kShapeNames[] = {"paraboloid", "cone", "drum"};

nlohmann::json RiseJson(const terrain::Detection& d, const terrain::Rise& t,
                        const terrain::VerdictModel& model) {
  nlohmann::json r = {{"centre_enu_m", {t.centre.x(), t.centre.y()}},
                      {"height_m", t.height_m},
                      {"base_diameter_m", t.base_diameter_m},
                      {"dome_height_m", t.dome_height_m},
                      {"dome_r2", t.dome_r2},
                      {"area_m2", t.area_m2},
                      {"volume_m3", t.volume_m3},
                      {"roundness", t.roundness},
                      {"symmetry", t.symmetry},
                      {"fill", t.fill},
                      {"flank_slope_rad", t.flank_slope_rad},
                      {"clipped", t.clipped},
                      {"outside", t.outside},
                      {"roughness", t.roughness},
                      {"flat_top", t.flat_top},
                      {"point_top", t.point_top},
                      {"point_spread", t.point_spread},
                      {"ring_high", t.ring_high},
                      {"ring_spread", t.ring_spread},
                      {"shape", kShapeNames[std::clamp(t.shape, 0, 2)]},
                      {"ground_slope_rad", t.ground_slope_rad},
                      {"ground_plane", {t.ground_plane[0], t.ground_plane[1], t.ground_plane[2]}},
                      {"ground", t.curved_ground ? "curved" : "plane"},
                      {"offset_m", t.offset_m},
                      {"extent_m", t.extent_m}};
  if (t.curved_ground)
    r["ground_curvature"] = {t.ground_curvature[0], t.ground_curvature[1], t.ground_curvature[2]};
  const std::vector<double> f = terrain::VerdictFeatures(d, t);
  nlohmann::json feats = nlohmann::json::object();
  for (size_t k = 0; k < f.size(); ++k) feats[terrain::VerdictFeatureNames()[k]] = f[k];
  r["features"] = feats;
  r["p_mound"] = model.Probability(f);
  return r;
}

}  // namespace

// ---- compare ---------------------------------------------------------------------------

Comparison Compare(const std::vector<Eigen::Vector3d>& cloud,
                   const std::vector<Eigen::Vector3d>& reference, const icp::Options& options) {
  Comparison c;
  auto t0 = Clock::now();
  c.fit = icp::Align(cloud, reference, options);
  c.icp_s = Since(t0);
  t0 = Clock::now();
  c.aligned.reserve(cloud.size());
  for (const Eigen::Vector3d& p : cloud) c.aligned.push_back(c.fit.reference_from_cloud * p);
  c.distance = icp::SurfaceDistances(c.aligned, reference);
  c.distances_s = Since(t0);
  return c;
}

NormalFit FitNormal(const std::vector<double>& d, double quantile) {
  if (d.empty()) throw InternalError("FitNormal: no distances");
  const double top = Quantile(d, quantile);
  double mean = 0, n = 0;
  for (double x : d)
    if (x <= top) {
      mean += x;
      ++n;
    }
  mean /= n;
  double var = 0;
  for (double x : d)
    if (x <= top) var += (x - mean) * (x - mean);
  return {mean, std::sqrt(var / n)};
}

nlohmann::json ComparisonJson(const Comparison& c) {
  return {{"init", NameOf(c.fit.init_used, icp::kInitNames)},
          {"reference_from_cloud", SimJson(c.fit.reference_from_cloud)},
          {"iterations", c.fit.iterations},
          {"coarse_iterations", c.fit.coarse_iterations},
          {"scale_fixed", c.fit.scale_fixed},
          {"frame_kept", c.fit.frame_kept},
          {"converged", c.fit.converged},
          {"rmse_m", c.fit.rmse_m},
          {"inlier_fraction", c.fit.inlier_fraction},
          {"distance_m", DistanceJson(c.distance)}};
}

// ---- the paper's test ------------------------------------------------------------------

void PaperTestOptions::Check() const {
  if (!(threshold_ratio > 0) || !std::isfinite(threshold_ratio))
    throw InputError("threshold_ratio: must be > 0");
  icp.Check();
}

PaperDecision PaperRule(double mu_m, double sigma_m, double relief_m, double threshold_ratio) {
  if (!(threshold_ratio > 0)) throw InputError("threshold_ratio: must be > 0");
  if (!(relief_m > 0)) throw NoResultError("the reference is flat (no relief to compare with)");
  PaperDecision d;
  d.mu_m = mu_m;
  d.sigma_m = sigma_m;
  d.relief_m = relief_m;
  d.threshold_m = threshold_ratio * relief_m;
  d.mound = mu_m <= d.threshold_m;
  d.confidence = std::min(1.0, std::fabs(mu_m - d.threshold_m) / d.threshold_m);
  return d;
}

double Relief(const std::vector<Eigen::Vector3d>& reference) {
  std::vector<double> z;
  z.reserve(reference.size());
  for (const auto& p : reference) z.push_back(p.z());
  return Quantile(z, 0.99) - Quantile(z, 0.01);
}

PaperVerdict PaperTest(const std::vector<Eigen::Vector3d>& cloud,
                       const std::vector<Eigen::Vector3d>& reference,
                       const PaperTestOptions& options) {
  options.Check();
  PaperVerdict v;
  v.comparison = Compare(cloud, reference, options.icp);
  const NormalFit fit = FitNormal(v.comparison.distance, 0.99);
  v.decision = PaperRule(fit.mu, fit.sigma, Relief(reference), options.threshold_ratio);
  return v;
}

nlohmann::json PaperVerdictJson(const PaperVerdict& v, double threshold_ratio) {
  const PaperDecision& d = v.decision;
  nlohmann::json doc;
  doc["method"] = "paper_normal_fit";
  doc["label"] = d.mound ? "mound" : "no_mound";
  doc["confidence"] = d.confidence;
  doc["measurements"] = {{"mu_m", d.mu_m},
                         {"sigma_m", d.sigma_m},
                         {"reference_relief_m", d.relief_m},
                         {"threshold_m", d.threshold_m},
                         {"threshold_ratio", threshold_ratio},
                         {"compare", ComparisonJson(v.comparison)}};
  doc["reason"] = std::string("distances to the reference N(") + std::to_string(d.mu_m) + ", " +
                  std::to_string(d.sigma_m) + ") m; mu " + (d.mound ? "<=" : ">") + " threshold " +
                  std::to_string(d.threshold_m) + " m";
  return doc;
}

// ---- the reference-free verdict --------------------------------------------------------

void SiteVerdictOptions::Check() const {
  if (radius_m && (!(*radius_m > 0) || !std::isfinite(*radius_m)))
    throw InputError("radius_m: must be > 0");
  if (first_look_p && !(*first_look_p >= 0 && *first_look_p <= 1))
    throw InputError("first_look_p: must be in [0, 1]");
  if (decide_at && !(*decide_at > 0 && *decide_at < 1))
    throw InputError("decide_at: must be in (0, 1)");
  detector.Check();
}

Coverage JudgeCoverage(const terrain::Detection& d, const terrain::Rise* judged, double radius_m) {
  Coverage c;
  c.rise_clipped = judged ? judged->clipped : 0.0;
  c.rise_outside = judged ? judged->outside : 0.0;
  c.site_sag_m = d.site_sag_m;
  // A rise cut by the edge of the cloud, or a site domed all over (a mound wider than the
  // scan: no ground in sight): the scan did not see the whole rise. Domed means the site
  // falls >= 1 m from its centre in every direction and the ground fit bends with it
  // (>= 0.5 m): a tumulus inside the scan domes the site too, but the ground around it
  // keeps the ground fit level. A plane ground fit cannot bend: the site's fall decides.
  const bool cut = judged && (judged->clipped > 0.1 || judged->outside > 0.1);
  const bool quadratic_ground = d.ground_coefficients.size() == 6 &&
                                (d.ground_coefficients[3] != 0 || d.ground_coefficients[4] != 0 ||
                                 d.ground_coefficients[5] != 0);
  const bool domed = d.site_sag_m >= 1.0 && (!quadratic_ground || d.ground_sag_m >= 0.5);
  if (!cut && !domed) {
    c.status = judged ? "whole" : "no_rise";
    return c;
  }
  c.status = "clipped";
  const double extent = judged ? judged->extent_m : radius_m;
  c.scan_needed_m =
      10 * std::ceil((domed ? std::max(4 * radius_m, 2.5 * extent) : 2.5 * extent) / 10);
  std::ostringstream w;
  w.precision(3);
  if (cut) {
    w << "the rise runs off the scanned site (" << 100 * judged->clipped
      << " % of its outline on the edge of the " << 2 * radius_m << " m site, "
      << 100 * judged->outside << " % of its fitted base beyond it)";
  } else {
    w << "the whole " << 2 * radius_m << " m site is domed (it falls " << d.site_sag_m
      << " m or more from its centre to its edge in every direction): no ground around the "
         "rise was seen";
  }
  w << "; a scan " << (domed ? "at least " : "about ") << c.scan_needed_m
    << " m across would see it whole";
  c.message = w.str();
  return c;
}

std::vector<std::pair<std::string, std::string>> UndecidedReasons(
    const SiteVerdict& v, const terrain::VerdictModel& model) {
  std::vector<std::pair<std::string, std::string>> out;
  auto say = [&](const std::string& code, const std::ostringstream& text) {
    out.emplace_back(code, text.str());
  };
  std::ostringstream s;
  s.precision(2);
  const terrain::Detection& d = v.detection;
  if (v.other_candidates) {
    std::ostringstream t;
    t << "measured with " << terrain::CandidatesName(d.candidates)
      << " candidate rises; the model was trained on " << terrain::CandidatesName(model.candidates)
      << " ones (judge the site with the model's: omit --candidates)";
    say("model", t);
  }
  if (!v.terrain.empty()) {
    std::ostringstream t;
    t.precision(3);
    t << "terrain unlike the model's training sites:";
    for (size_t k = 0; k < v.terrain.size(); ++k) {
      const terrain::TerrainExcess& e = v.terrain[k];
      if (e.name == "training_distance") {  // every descriptor in range, but not together
        t << (k ? ";" : "") << " its ground " << e.value
          << " from its nearest training sites' (standardised; at most " << e.high << ")";
        continue;
      }
      const bool angle = e.name == "site_slope_rad";  // said in degrees
      const double f = angle ? 180 / M_PI : 1;
      t << (k ? ";" : "") << " " << (angle ? "site slope" : e.name) << " " << f * e.value
        << (angle ? " deg" : "") << " outside its training sites' [" << f * e.low << ", "
        << f * e.high << "]";
    }
    say("terrain", t);
  }
  if (v.coverage.status == "clipped") {
    s << "clipped by the scan: " << v.coverage.message;
    say("clipped", s);
  }
  if (d.cells_inside > 0 && d.cells_with_points < 0.7 * d.cells_inside) {
    std::ostringstream t;
    t << "sparse cloud: " << std::lround(100.0 * d.cells_with_points / d.cells_inside)
      << " % of the site's cells hold points";
    say("sparse_cloud", t);
  }
  if (!v.judged) {
    std::ostringstream t;
    t << "no rise stands above the relief threshold";
    say("no_rise", t);
    return out;
  }
  const terrain::Rise& r = d.judged[*v.judged];
  if (r.ring_high >= 0.5) {
    std::ostringstream t;
    t.precision(2);
    t << "masked by relief of its own size: the ground around the " << r.height_m
      << " m rise stands " << r.ring_high << " of its height in one direction";
    say("masked", t);
  }
  if (model.reasons) {  // learned: a cut tumulus's roughness, and a natural rise's beyond it
    const terrain::ReasonThresholds& l = *model.reasons;
    std::ostringstream t;
    t.precision(2);
    if (r.roughness >= l.irregular_roughness) {
      t << "irregular, as natural rises are: the dome fit leaves " << r.roughness
        << " of the height (from " << l.irregular_roughness << " more often a natural rise)";
      say("irregular", t);
    } else if (r.roughness >= l.cut_roughness) {
      t << "cut (a looters' trench or pit, or damage): the dome fit leaves " << r.roughness
        << " of the height (from " << l.cut_roughness << " more often a cut tumulus)";
      say("cut", t);
    }
  } else if (r.roughness >= 0.25 || r.fill < 0.5) {
    std::ostringstream t;
    t.precision(2);
    t << "cut or irregular (a looters' trench or pit, or damage): the dome fit leaves "
      << r.roughness << " of the height, the footprint fills " << r.fill << " of its disc";
    say("cut", t);
  }
  if (r.height_m < 1) {
    std::ostringstream t;
    t.precision(2);
    t << "low: " << r.height_m << " m high, " << r.base_diameter_m << " m across";
    say("low", t);
  }
  if (out.empty()) {
    std::ostringstream t;
    t.precision(3);
    t << "weak evidence: p(mound) " << v.p_mound << " with no single cause measured";
    say("weak", t);
  }
  return out;
}

SiteVerdict JudgeSite(const std::vector<Eigen::Vector3d>& cloud, const Eigen::Vector2d& centre,
                      const SiteVerdictOptions& options, const terrain::VerdictModel& model) {
  options.Check();
  if (options.first_look_p && !model.second_look)
    throw InputError(
        "--second-look: the model has no second_look (train it on a grid flown with "
        "mound sim grid --second-look)");
  SiteVerdict v;
  v.centre = centre;
  if (options.radius_m) {
    v.radius_m = *options.radius_m;
  } else {
    if (cloud.empty()) throw NoResultError("the cloud has no points");
    std::vector<double> r;
    r.reserve(cloud.size());
    for (const auto& p : cloud) r.push_back((p.head<2>() - centre).norm());
    v.radius_m = Quantile(r, 0.8);
    if (!options.cameras.empty()) {
      // the ground: the points' median height under the cameras' track (all of them when
      // none lies there)
      double track = 0;
      for (const Eigen::Vector3d& p : options.cameras)
        track = std::max(track, (p.head<2>() - centre).norm());
      std::vector<double> under, all;
      for (size_t k = 0; k < cloud.size(); ++k) {
        all.push_back(cloud[k].z());
        if (r[k] <= track) under.push_back(cloud[k].z());  // r: the distances above
      }
      const double reach =
          CameraReach(options.cameras, centre, Median(under.empty() ? all : under));
      if (v.radius_m > reach) {
        std::ostringstream why;
        why.precision(3);
        why << "a torn reconstruction: 20 % of the cloud lies more than " << v.radius_m
            << " m from the scan's centre, beyond the " << reach
            << " m its cameras could see; not judged (reconstruct the site again)";
        throw NoResultError(why.str());
      }
    }
  }
  v.detection = terrain::DetectMound(cloud, centre, v.radius_m, options.detector);
  size_t best = 0;
  v.model_p = v.p_mound = model.Probability(v.detection, &best);
  if (options.first_look_p) {
    v.second_look = true;
    v.first_p = *options.first_look_p;
    v.p_mound = model.SecondLookProbability(v.first_p, v.model_p);
  }
  v.decide_at = options.decide_at;
  v.threshold = options.decide_at ? *options.decide_at
                : v.second_look   ? model.second_look->threshold
                                  : model.threshold;
  v.mound = v.p_mound >= v.threshold;
  v.label = options.decide_at ? (v.mound ? "mound" : "no_mound")
                              : model.Label(v.p_mound, v.threshold, v.detection.site_slope_rad);
  if (!v.detection.judged.empty()) v.judged = best;
  v.terrain = model.OutsideTerrain(v.detection);
  if (!v.terrain.empty() && !options.decide_at) v.label = "undecided";
  v.other_candidates = options.detector.candidates != model.candidates;
  if (v.other_candidates && !options.decide_at) v.label = "undecided";
  v.coverage =
      JudgeCoverage(v.detection, v.judged ? &v.detection.judged[*v.judged] : nullptr, v.radius_m);
  return v;
}

nlohmann::json SiteVerdictJson(const SiteVerdict& v, const terrain::VerdictModel& model,
                               const std::string& model_file,
                               const terrain::DetectorOptions& detector) {
  const terrain::Detection& d = v.detection;
  const terrain::Rise* judged = v.judged ? &d.judged[*v.judged] : nullptr;
  // the site's undecided band (by its slope when the model has bands by slope)
  const bool banded = model.undecided.has_value();
  const terrain::UndecidedBand band =
      banded ? model.BandFor(d.site_slope_rad) : terrain::UndecidedBand{};
  nlohmann::json doc;
  doc["method"] = "reference_free_model";
  doc["p_mound"] = v.p_mound;
  doc["label"] = v.label;
  // the two answers beside it (the paper's protocol: its epsilon_MD and epsilon_FA)
  doc["two_answer"] = {{"label", v.mound ? "mound" : "no_mound"}, {"threshold", v.threshold}};
  if (v.decide_at) {
    doc["decision"] = {{"rule", "decide_at"}, {"p", *v.decide_at}};
  } else if (banded) {
    doc["decision"] = {{"rule", "undecided_band"}, {"p_low", band.p_low}, {"p_high", band.p_high}};
    if (!model.slope_bands.empty()) doc["decision"]["site_slope_rad"] = d.site_slope_rad;
  } else {
    doc["decision"] = {{"rule", "threshold"}, {"p", v.threshold}};
  }
  doc["confidence"] = v.mound ? v.p_mound : 1 - v.p_mound;
  nlohmann::json m = {{"site_centre_enu_m", {v.centre.x(), v.centre.y()}},
                      {"site_radius_m", v.radius_m},
                      {"cell_m", d.cell_m},
                      {"grid", {d.grid_width, d.grid_height}},
                      {"cells_with_points", d.cells_with_points},
                      {"cells_inside", d.cells_inside},
                      {"ground_noise_m", d.ground_noise_m},
                      {"ground_coefficients", d.ground_coefficients},
                      {"rises", d.rises},
                      {"site_sag_m", d.site_sag_m},
                      {"site_ridge_m", d.site_ridge_m},
                      {"ground_sag_m", d.ground_sag_m},
                      {"candidates", terrain::CandidatesName(d.candidates)}};
  {  // the ground the site stands on, and the model's domain of it
    nlohmann::json t = nlohmann::json::object();
    const std::vector<double> values = terrain::TerrainDescriptors(d);
    for (size_t k = 0; k < values.size(); ++k) t[terrain::TerrainDescriptorNames()[k]] = values[k];
    m["terrain"] = t;
    nlohmann::json outside = nlohmann::json::array();
    for (const terrain::TerrainExcess& e : v.terrain)
      outside.push_back({{"name", e.name}, {"value", e.value}, {"range", {e.low, e.high}}});
    doc["terrain"] = {{"status", model.terrain_ranges.empty() ? "unchecked"
                                 : v.terrain.empty()          ? "inside"
                                                              : "outside"},
                      {"outside", outside}};
  }
  // Every judged rise (the training data of `mound recon train-verdict`), the one that
  // decided the site as `rise` with its `features`.
  nlohmann::json all = nlohmann::json::array();
  for (const terrain::Rise& r : d.judged) all.push_back(RiseJson(d, r, model));
  m["judged_rises"] = all;
  std::ostringstream why;
  why.precision(3);
  if (judged) {
    const terrain::Rise& t = *judged;
    m["rise"] = all[*v.judged];
    m["features"] = m["rise"]["features"];
    why << "the rise judged most likely a mound (of " << d.judged.size() << "): height "
        << t.height_m << " m, base diameter " << t.base_diameter_m << " m, roundness "
        << t.roundness << ", dome fit R^2 " << t.dome_r2 << ", flank slope "
        << t.flank_slope_rad * 180 / M_PI << " deg, " << 100 * t.clipped
        << " % of its outline on the scan's edge";
  } else {
    why << "no rise above " << detector.relief_threshold_m << " m over the ground";
  }
  const Coverage& c = v.coverage;
  if (c.status == "clipped") {
    doc["coverage"] = {{"status", c.status},
                       {"scan_needed_m", c.scan_needed_m},
                       {"message", c.message},
                       {"rise_clipped", c.rise_clipped},
                       {"rise_outside", c.rise_outside},
                       {"site_sag_m", c.site_sag_m}};
  } else {
    doc["coverage"] = {{"status", c.status},
                       {"rise_clipped", c.rise_clipped},
                       {"rise_outside", c.rise_outside},
                       {"site_sag_m", c.site_sag_m}};
  }
  const double threshold = v.threshold;
  if (v.second_look) {
    why << "; a second look: the model's p " << v.model_p << " of this flight, " << v.first_p
        << " of the first; both together p(mound) " << v.p_mound << " (threshold " << threshold
        << ")";
    doc["look"] = "second";
    doc["model_p_mound"] = v.model_p;
    doc["first_look_p_mound"] = v.first_p;
  } else {
    if (banded && !v.decide_at) {
      // where p lies against the band: below it no_mound, in it undecided, from its top mound
      const double lo = band.p_low, hi = band.p_high;
      why << "; p(mound) " << v.p_mound
          << (v.p_mound < lo   ? " (below the undecided band ["
              : v.p_mound < hi ? " (in the undecided band ["
                               : " (above the undecided band [")
          << lo << ", " << hi << "))";
    } else
      why << "; p(mound) " << v.p_mound << " (threshold " << threshold << ")";
    doc["look"] = "first";
  }
  if (model.second_look && !v.second_look) {
    const terrain::SecondLook& l = *model.second_look;
    // a wider look at ground the model never saw would not be judged on it either
    const bool advised = model.SecondLookAdvised(v.p_mound, d.site_slope_rad) &&
                         v.terrain.empty() && !v.other_candidates;
    doc["second_look"] = {{"advised", advised}, {"p_low", l.p_low}, {"scan_factor", l.scan_factor}};
    if (advised) {
      std::ostringstream say;
      say.precision(3);
      const double lo = banded ? band.p_low : l.p_low;
      const double hi = banded ? band.p_high : model.threshold;
      say << "undecided (p " << v.p_mound << " in [" << lo << ", " << hi
          << ")): fly the site again with a scan " << l.scan_factor
          << " x as wide and judge that flight with --second-look";
      doc["second_look"]["message"] = say.str();
      why << "; " << say.str();
    }
  }
  if (v.label == "undecided") {
    nlohmann::json reasons = nlohmann::json::array();
    for (const auto& [code, text] : UndecidedReasons(v, model))
      reasons.push_back({{"code", code}, {"text", text}});
    const bool second = doc.contains("second_look") && doc["second_look"].value("advised", false);
    doc["undecided"] = {{"reasons", reasons}, {"next", second ? "second_look" : "field_team"}};
    why << "; undecided: " << reasons[0]["text"].get<std::string>()
        << (second ? "" : "; for the field team");
  }
  doc["reason"] = why.str();
  doc["measurements"] = m;
  doc["model"] = {{"file", model_file},
                  {"threshold", threshold},
                  {"relief_threshold_m", detector.relief_threshold_m},
                  {"candidates", terrain::CandidatesName(model.candidates)}};
  if (model.doc.contains("trained")) doc["model"]["trained"] = model.doc["trained"];
  return doc;
}

std::vector<Eigen::Vector3d> CameraCentres(const nlohmann::json& recon, const std::string& path) {
  const nlohmann::json& images = RequireField(recon, "images", "");
  if (!images.is_array()) throw InputError(path + ": images: expected an array");
  std::vector<Eigen::Vector3d> out;
  for (size_t k = 0; k < images.size(); ++k) {
    const std::string at = "images[" + std::to_string(k) + "]";
    if (!images[k].is_object() || !images[k].value("registered", false)) continue;
    const nlohmann::json& centre = RequireField(images[k], "centre", at);
    if (!centre.is_array() || centre.size() != 3 || !centre[0].is_number() ||
        !centre[1].is_number() || !centre[2].is_number()) {
      throw InputError(path + ": " + at + ".centre: expected [x, y, z]");
    }
    const Eigen::Vector3d c(centre[0].get<double>(), centre[1].get<double>(),
                            centre[2].get<double>());
    if (!c.allFinite()) throw InputError(path + ": " + at + ".centre: expected finite numbers");
    out.push_back(c);
  }
  return out;
}

std::optional<Eigen::Vector2d> CameraCentre(const nlohmann::json& recon, const std::string& path) {
  const std::vector<Eigen::Vector3d> cameras = CameraCentres(recon, path);
  if (cameras.empty()) return std::nullopt;
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  for (const Eigen::Vector3d& p : cameras) c += p.head<2>();
  return c / static_cast<double>(cameras.size());
}

double CameraReach(const std::vector<Eigen::Vector3d>& cameras, const Eigen::Vector2d& centre,
                   double ground_z) {
  double reach = 0;
  for (const Eigen::Vector3d& p : cameras)
    reach = std::max(reach, (p.head<2>() - centre).norm() + 2 * std::max(p.z() - ground_z, 0.0));
  return reach;
}

}  // namespace mound::recon
