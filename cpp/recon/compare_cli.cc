#include "recon/compare_cli.h"

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <numeric>
#include <optional>
#include <sstream>

#include "common/atomic_file.h"
#include "common/cli_args.h"
#include "common/error.h"
#include "common/json_util.h"
#include "common/stats.h"
#include "common/timing.h"
#include "geometry/ply.h"
#include "icp/icp.h"
#include "recon/recon_io.h"
#include "terrain/mound_detector.h"
#include "terrain/verdict_model.h"

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

// Mean and std (the maximum-likelihood N(mu, sigma)) of the distances up to `quantile`.
std::pair<double, double> NormalFit(const std::vector<double>& d, double quantile) {
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

// Mean, std, median, 90th percentile, max, a 20-bin histogram up to the 99th percentile,
// and the paper's N(mu, sigma) fitted to the distances below their 99th percentile (a
// sparse model's few stray points, tens of metres off, would otherwise make sigma).
nlohmann::json DistanceJson(const std::vector<double>& d) {
  const auto [mean, sd] = NormalFit(d, 1.0);
  const auto [mu, sigma] = NormalFit(d, 0.99);
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
      {"mean", mean},
      {"std", sd},
      {"median", Quantile(d, 0.5)},
      {"p90", Quantile(d, 0.9)},
      {"max", *std::max_element(d.begin(), d.end())},
      {"normal_fit", {{"mu", mu}, {"sigma", sigma}, {"below_quantile", 0.99}}},
      {"histogram", {{"bin_width_m", top / 20}, {"counts", counts}, {"above_last_bin", above}}}};
}

struct Comparison {
  icp::Result fit;
  std::vector<Eigen::Vector3d> aligned;
  std::vector<double> distance;
  nlohmann::json timings;
};

Comparison Compare(const PlyCloud& cloud, const PlyCloud& reference, const icp::Options& io) {
  Comparison c;
  auto t0 = Clock::now();
  c.fit = icp::Align(cloud.xyz, reference.xyz, io);
  c.timings["icp_s"] = Since(t0);
  t0 = Clock::now();
  for (const Eigen::Vector3d& p : cloud.xyz) c.aligned.push_back(c.fit.reference_from_cloud * p);
  c.distance = icp::SurfaceDistances(c.aligned, reference.xyz);
  c.timings["distances_s"] = Since(t0);
  return c;
}

nlohmann::json ComparisonJson(const Comparison& c) {
  return {{"init", c.fit.init_used},
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

icp::Options IcpOptions(const Args& a) {
  icp::Options o;
  o.estimate_scale = !a.Has("--no-scale");
  if (a.Has("--init")) o.init = a.options.at("--init");
  if (o.init != "auto" && o.init != "none" && o.init != "pca")
    throw InputError("--init: expected auto, none or pca, got '" + o.init + "'");
  if (a.Has("--max-points"))
    o.max_source_points =
        static_cast<int>(ParseInt(a.options.at("--max-points"), "--max-points", 100, 100000000));
  if (a.Has("--seed"))
    o.seed = static_cast<uint64_t>(ParseInt(a.options.at("--seed"), "--seed", 0, 1LL << 62));
  return o;
}

// The horizontal centre of the registered cameras (validated fields).
std::optional<Eigen::Vector2d> CameraCentre(const nlohmann::json& recon, const std::string& path) {
  const nlohmann::json& images = RequireField(recon, "images", "");
  if (!images.is_array()) throw InputError(path + ": images: expected an array");
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  int n = 0;
  for (size_t k = 0; k < images.size(); ++k) {
    const std::string at = "images[" + std::to_string(k) + "]";
    if (!images[k].is_object() || !images[k].value("registered", false)) continue;
    const nlohmann::json& centre = RequireField(images[k], "centre", at);
    if (!centre.is_array() || centre.size() != 3 || !centre[0].is_number() ||
        !centre[1].is_number()) {
      throw InputError(path + ": " + at + ".centre: expected [x, y, z]");
    }
    c += Eigen::Vector2d(centre[0].get<double>(), centre[1].get<double>());
    ++n;
  }
  if (n == 0) return std::nullopt;
  return c / n;
}

}  // namespace

int RunCompare(const std::vector<std::string>& args) {
  const Args a = ParseArgs(args, 1, {"--out", "--init", "--max-points", "--seed"}, {"--no-scale"});
  if (a.positional.size() != 2)
    throw InputError("compare: expected CLOUD.ply REFERENCE.ply (see --help)");
  if (!a.Has("--out")) throw InputError("--out: the output directory is required");
  const std::string out = a.options.at("--out");
  const icp::Options io = IcpOptions(a);
  auto t0 = Clock::now();
  const PlyCloud cloud = ReadCloud(a.positional[0], "CLOUD"),
                 reference = ReadCloud(a.positional[1], "REFERENCE");
  const double read_s = Since(t0);
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec) throw InputError("--out: cannot create " + out + ": " + ec.message());
  nlohmann::json doc = {
      {"schema", "mound.compare"},
      {"version", 1},
      {"tool", "mound_recon compare"},
      {"status", "ok"},
      {"cloud", a.positional[0]},
      {"reference", a.positional[1]},
      {"points", {{"cloud", cloud.xyz.size()}, {"reference", reference.xyz.size()}}},
      {"estimate_scale", io.estimate_scale}};
  Comparison c;
  try {
    c = Compare(cloud, reference, io);
  } catch (const NoResultError& e) {
    doc["status"] = "failed";
    doc["reason"] = e.what();
    WriteFileAtomic(out + "/compare.json", doc.dump(1) + "\n");
    throw;
  }
  doc.update(ComparisonJson(c));
  t0 = Clock::now();
  PlyCloud aligned;
  aligned.xyz = c.aligned;
  aligned.rgb = cloud.rgb;
  aligned.scalars["distance"] = c.distance;
  aligned.comments = {
      "mound.aligned v1: the cloud in the reference's frame; distance: metres to the reference "
      "surface"};
  WritePly(out + "/aligned.ply", aligned);
  c.timings["read_s"] = read_s;
  c.timings["write_s"] = Since(t0);
  doc["timings_s"] = c.timings;
  WriteFileAtomic(out + "/compare.json", doc.dump(1) + "\n");
  const auto& dm = doc["distance_m"];
  std::cerr << "mound_recon compare: scale " << c.fit.reference_from_cloud.scale << ", "
            << c.fit.iterations << " iterations" << (c.fit.converged ? "" : " (not converged)")
            << ", distance mean " << dm["mean"].get<double>() << " m, std "
            << dm["std"].get<double>() << " m\n";
  return kExitOk;
}

int RunVerdict(const std::vector<std::string>& args) {
  const Args a = ParseArgs(
      args, 1,
      {"--out", "--reference", "--radius", "--threshold-ratio", "--model", "--ground-order",
       "--relief-threshold", "--init", "--max-points", "--seed", "--cloud"},
      {"--no-scale"});
  if (a.positional.size() != 1)
    throw InputError("verdict: expected exactly one RECON_DIR (see --help)");
  if (!a.Has("--out")) throw InputError("--out: the verdict file is required");
  const std::string dir = a.positional[0], out = a.options.at("--out");
  const nlohmann::json recon = LoadRecon(dir + "/recon.json");
  nlohmann::json doc = {{"schema", "mound.verdict"},
                        {"version", 1},
                        {"tool", "mound_recon verdict"},
                        {"recon_dir", dir},
                        {"status", "ok"}};
  auto fail = [&](const std::string& why) {
    doc["status"] = "failed";
    doc["reason"] = why;
    WriteFileAtomic(out, doc.dump(1) + "\n");
    throw NoResultError(why);
  };
  if (!recon.contains("status") || !recon["status"].is_string())
    throw InputError(dir + "/recon.json: status: missing");
  if (recon["status"] != "ok")
    fail("the reconstruction failed: " + recon.value("reason", std::string("?")));
  // The sparse cloud, or another cloud of the same model (densify's dense.ply).
  const std::string cloud_path = a.Has("--cloud") ? a.options.at("--cloud") : dir + "/points.ply";
  const PlyCloud cloud =
      ReadCloud(cloud_path, a.Has("--cloud") ? "--cloud" : "RECON_DIR/points.ply");
  doc["cloud"] = cloud_path;
  if (a.Has("--reference")) {
    // The paper's test: ICP with scale onto the reference, the distances fitted by N(mu,
    // sigma), mound when mu <= threshold_ratio x the reference's relief.
    const PlyCloud reference = ReadCloud(a.options.at("--reference"), "--reference");
    const double ratio = a.Has("--threshold-ratio")
                             ? ParseNumber(a.options.at("--threshold-ratio"), "--threshold-ratio")
                             : 0.05;
    if (!(ratio > 0)) throw InputError("--threshold-ratio: must be > 0");
    Comparison c;
    try {
      c = Compare(cloud, reference, IcpOptions(a));
    } catch (const NoResultError& e) {
      fail(e.what());
    }
    std::vector<double> z;
    for (const auto& p : reference.xyz) z.push_back(p.z());
    const double relief = Quantile(z, 0.99) - Quantile(z, 0.01);
    const nlohmann::json cmp = ComparisonJson(c);
    const double mu = cmp["distance_m"]["normal_fit"]["mu"],
                 sigma = cmp["distance_m"]["normal_fit"]["sigma"];
    const double threshold = ratio * relief;
    const bool mound = mu <= threshold;
    doc["method"] = "paper_normal_fit";
    doc["label"] = mound ? "mound" : "no_mound";
    // How far mu lies from the threshold, in units of the threshold (1 at 0 or 2x).
    doc["confidence"] = std::min(1.0, std::fabs(mu - threshold) / threshold);
    doc["measurements"] = {{"mu_m", mu},
                           {"sigma_m", sigma},
                           {"reference_relief_m", relief},
                           {"threshold_m", threshold},
                           {"threshold_ratio", ratio},
                           {"compare", cmp}};
    doc["reason"] = std::string("distances to the reference N(") + std::to_string(mu) + ", " +
                    std::to_string(sigma) + ") m; mu " + (mound ? "<=" : ">") + " threshold " +
                    std::to_string(threshold) + " m";
  } else {
    if (!recon.contains("frame") || recon["frame"] != "enu" || !recon.contains("scale") ||
        recon["scale"] != "metric") {
      fail(
          "the reference-free verdict needs a georeferenced model (frame enu, metric scale: run "
          "reconstruct with --gps)");
    }
    // The site: centred on the cameras (the flight is centred on the candidate site); its
    // radius the 80th percentile of the points' horizontal distance from there.
    const std::optional<Eigen::Vector2d> cam = CameraCentre(recon, dir + "/recon.json");
    if (!cam) fail("no registered image");
    const Eigen::Vector2d centre = *cam;
    double radius;
    if (a.Has("--radius")) {
      radius = ParseNumber(a.options.at("--radius"), "--radius");
      if (!(radius > 0)) throw InputError("--radius: must be > 0");
    } else {
      std::vector<double> r;
      for (const auto& p : cloud.xyz) r.push_back((p.head<2>() - centre).norm());
      radius = Quantile(r, 0.8);
    }
    terrain::DetectorOptions o;
    if (a.Has("--relief-threshold"))
      o.relief_threshold_m = ParseNumber(a.options.at("--relief-threshold"), "--relief-threshold");
    if (a.Has("--ground-order")) {
      const double g = ParseNumber(a.options.at("--ground-order"), "--ground-order");
      if (g != 1 && g != 2) throw InputError("--ground-order: 1 (a plane) or 2 (a quadratic)");
      o.ground_order = static_cast<int>(g);
    }
    const terrain::VerdictModel model = a.Has("--model")
                                            ? terrain::LoadVerdictModel(a.options.at("--model"))
                                            : terrain::DefaultVerdictModel();
    terrain::Detection d;
    try {
      d = terrain::DetectMound(cloud.xyz, centre, radius, o);
    } catch (const NoResultError& e) {
      fail(e.what());
    }
    size_t best = 0;
    const double p = model.Probability(d, &best);
    const bool mound = p >= model.threshold;
    const terrain::Rise* judged = d.judged.empty() ? nullptr : &d.judged[best];
    doc["method"] = "reference_free_model";
    doc["p_mound"] = p;
    doc["label"] = mound ? "mound" : "no_mound";
    doc["confidence"] = mound ? p : 1 - p;
    std::ostringstream why;
    why.precision(3);
    nlohmann::json m = {{"site_centre_enu_m", {centre.x(), centre.y()}},
                        {"site_radius_m", radius},
                        {"cell_m", d.cell_m},
                        {"grid", {d.grid_width, d.grid_height}},
                        {"cells_with_points", d.cells_with_points},
                        {"cells_inside", d.cells_inside},
                        {"ground_noise_m", d.ground_noise_m},
                        {"ground_coefficients", d.ground_coefficients},
                        {"rises", d.rises},
                        {"site_sag_m", d.site_sag_m},
                        {"site_ridge_m", d.site_ridge_m}};
    auto rise_json = [&](const terrain::Rise& t) {
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
                          {"offset_m", t.offset_m},
                          {"extent_m", t.extent_m}};
      const std::vector<double> f = terrain::VerdictFeatures(d, t);
      nlohmann::json feats = nlohmann::json::object();
      for (size_t k = 0; k < f.size(); ++k) feats[terrain::VerdictFeatureNames()[k]] = f[k];
      r["features"] = feats;
      r["p_mound"] = model.Probability(f);
      return r;
    };
    // Every judged rise (the training data of `mound recon train-verdict`), the one that
    // decided the site as `rise` with its `features`.
    nlohmann::json all = nlohmann::json::array();
    for (const terrain::Rise& r : d.judged) all.push_back(rise_json(r));
    m["judged_rises"] = all;
    if (judged) {
      const terrain::Rise& t = *judged;
      m["rise"] = rise_json(t);
      m["features"] = m["rise"]["features"];
      why << "the rise judged most likely a mound (of " << d.judged.size() << "): height "
          << t.height_m << " m, base diameter " << t.base_diameter_m << " m, roundness "
          << t.roundness << ", dome fit R^2 " << t.dome_r2 << ", flank slope "
          << t.flank_slope_rad * 180 / M_PI << " deg, " << 100 * t.clipped
          << " % of its outline on the scan's edge";
    } else {
      why << "no rise above " << o.relief_threshold_m << " m over the ground";
    }
    // A rise cut by the edge of the cloud, or a site domed all over (a mound wider than the
    // scan: no ground in sight): the scan did not see the whole rise.
    const bool cut = judged && judged->clipped > 0.1;
    const bool domed = d.site_sag_m >= 1.0;
    if (cut || domed) {
      const double extent = judged ? judged->extent_m : radius;
      const double need =
          10 * std::ceil((domed ? std::max(4 * radius, 2.5 * extent) : 2.5 * extent) / 10);
      std::ostringstream w;
      w.precision(3);
      if (cut) {
        w << "the rise runs off the scanned site (" << 100 * judged->clipped
          << " % of its outline on the edge of the " << 2 * radius << " m site)";
      } else {
        w << "the whole " << 2 * radius << " m site is domed (it falls " << d.site_sag_m
          << " m or more from its centre to its edge in every direction): no ground around the "
             "rise was seen";
      }
      w << "; a scan " << (domed ? "at least " : "about ") << need
        << " m across would see it whole";
      doc["coverage"] = {{"status", "clipped"},
                         {"scan_needed_m", need},
                         {"message", w.str()},
                         {"rise_clipped", judged ? judged->clipped : 0.0},
                         {"site_sag_m", d.site_sag_m}};
    } else {
      doc["coverage"] = {{"status", judged ? "whole" : "no_rise"},
                         {"rise_clipped", judged ? judged->clipped : 0.0},
                         {"site_sag_m", d.site_sag_m}};
    }
    why << "; p(mound) " << p << " (threshold " << model.threshold << ")";
    doc["reason"] = why.str();
    doc["measurements"] = m;
    doc["model"] = {{"file", a.Has("--model") ? a.options.at("--model")
                                              : std::string("default (data/verdict_model.json)")},
                    {"threshold", model.threshold},
                    {"relief_threshold_m", o.relief_threshold_m}};
    if (model.doc.contains("trained")) doc["model"]["trained"] = model.doc["trained"];
  }
  WriteFileAtomic(out, doc.dump(1) + "\n");
  std::cerr << "mound_recon verdict: " << doc["label"].get<std::string>() << " (confidence "
            << doc["confidence"].get<double>() << "): " << doc["reason"].get<std::string>() << "\n";
  return kExitOk;
}

}  // namespace mound::recon
