#include "recon/compare_cli.h"

#include <filesystem>
#include <iostream>
#include <optional>

#include "common/atomic_file.h"
#include "common/cli_args.h"
#include "common/error.h"
#include "common/json_util.h"
#include "common/timing.h"
#include "geometry/ply.h"
#include "icp/icp.h"
#include "recon/recon_io.h"
#include "recon/verdict.h"
#include "terrain/verdict_model.h"

namespace mound::recon {
namespace {

icp::Options IcpOptions(const Args& a) {
  icp::Options o;
  o.estimate_scale = !a.Has("--no-scale");
  if (a.Has("--init")) {
    o.init = ParseEnum(a, "--init", icp::kInitNames);
  }
  if (a.Has("--max-points"))
    o.max_source_points =
        static_cast<int>(ParseInt(a.options.at("--max-points"), "--max-points", 100, 100000000));
  if (a.Has("--seed"))
    o.seed = static_cast<uint64_t>(ParseInt(a.options.at("--seed"), "--seed", 0, 1LL << 62));
  o.Check();
  return o;
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
  const geometry::PlyCloud cloud = ReadCloud(a.positional[0], "CLOUD"),
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
    c = Compare(cloud.xyz, reference.xyz, io);
  } catch (const NoResultError& e) {
    doc["status"] = "failed";
    doc["reason"] = e.what();
    WriteFileAtomic(out + "/compare.json", doc.dump(1) + "\n");
    throw;
  }
  doc.update(ComparisonJson(c));
  t0 = Clock::now();
  geometry::PlyCloud aligned;
  aligned.xyz = c.aligned;
  aligned.rgb = cloud.rgb;
  aligned.scalars["distance"] = c.distance;
  aligned.comments = {
      "mound.aligned v1: the cloud in the reference's frame; distance: metres to the reference "
      "surface"};
  geometry::WritePly(out + "/aligned.ply", aligned);
  doc["timings_s"] = {{"icp_s", c.icp_s},
                      {"distances_s", c.distances_s},
                      {"read_s", read_s},
                      {"write_s", Since(t0)}};
  WriteFileAtomic(out + "/compare.json", doc.dump(1) + "\n");
  const auto& dm = doc["distance_m"];
  std::cerr << "mound_recon compare: scale " << c.fit.reference_from_cloud.scale << ", "
            << c.fit.iterations << " iterations" << (c.fit.converged ? "" : " (not converged)")
            << ", distance mean " << dm["mean"].get<double>() << " m, std "
            << dm["std"].get<double>() << " m\n";
  return kExitOk;
}

namespace {

// The reference-free verdict's options from its flags, checked.
SiteVerdictOptions SiteOptions(const Args& a) {
  SiteVerdictOptions site;
  if (a.Has("--radius")) {
    site.radius_m = ParseNumber(a.options.at("--radius"), "--radius");
    if (!(*site.radius_m > 0)) throw InputError("--radius: must be > 0");
  }
  if (a.Has("--relief-threshold")) {
    site.detector.relief_threshold_m =
        ParseNumber(a.options.at("--relief-threshold"), "--relief-threshold");
    if (!(site.detector.relief_threshold_m > 0))
      throw InputError("--relief-threshold: must be > 0");
  }
  if (a.Has("--ground-order")) {
    const double g = ParseNumber(a.options.at("--ground-order"), "--ground-order");
    if (g != 1 && g != 2) throw InputError("--ground-order: 1 (a plane) or 2 (a quadratic)");
    site.detector.ground_order = static_cast<int>(g);
  }
  if (a.Has("--candidates")) {
    const auto c = terrain::CandidatesFromName(a.options.at("--candidates"));
    if (!c) throw InputError("--candidates: site_ground or local_relief");
    site.detector.candidates = *c;
  }
  if (a.Has("--second-look")) {
    const std::string first = a.options.at("--second-look"), at = "--second-look: " + first;
    std::string text;
    try {
      text = ReadFile(first);
    } catch (const InputError& e) {
      throw InputError(std::string("--second-look: ") + e.what());
    }
    site.first_look_p = terrain::FirstLookP(ParseJson(text, at), at);
  }
  if (a.Has("--decide-at")) {
    site.decide_at = ParseNumber(a.options.at("--decide-at"), "--decide-at");
    if (!(*site.decide_at > 0 && *site.decide_at < 1))
      throw InputError("--decide-at: must be in (0, 1)");
  }
  site.Check();
  return site;
}

// Only a cloud made as the model's training clouds were is judged: densify's options travel
// in the dense.json beside its dense.ply (--cloud); the sparse cloud has none.
void CheckCloudMadeAsTrained(const terrain::CloudSettings& trained, const Args& a,
                             const std::string& cloud_path) {
  if (a.Has("--cloud")) {
    const std::string meta =
        (std::filesystem::path(cloud_path).parent_path() / "dense.json").string();
    if (!std::filesystem::is_regular_file(meta))
      throw InputError("--cloud: no dense.json beside " + cloud_path +
                       ": cannot tell whether the cloud was made as the model's training "
                       "clouds were (judge mound_recon densify's output)");
    const nlohmann::json made = ParseJson(ReadFile(meta), meta);
    terrain::CheckCloudSettings(
        trained, "dense",
        made.is_object() ? made.value("options", nlohmann::json()) : nlohmann::json(), meta);
  } else {
    terrain::CheckCloudSettings(trained, "sparse", nlohmann::json::object(), cloud_path);
  }
}

}  // namespace

int RunVerdict(const std::vector<std::string>& args) {
  const Args a = ParseArgs(args, 1,
                           {"--out", "--reference", "--radius", "--threshold-ratio", "--model",
                            "--ground-order", "--relief-threshold", "--candidates", "--init",
                            "--max-points", "--seed", "--cloud", "--second-look", "--decide-at"},
                           {"--no-scale"});
  if (a.positional.size() != 1)
    throw InputError("verdict: expected exactly one RECON_DIR (see --help)");
  if (a.Has("--second-look") && a.Has("--reference"))
    throw InputError("--second-look: only for the reference-free verdict, not --reference");
  if (a.Has("--decide-at") && a.Has("--reference"))
    throw InputError("--decide-at: only for the reference-free verdict, not --reference");
  if (!a.Has("--out")) throw InputError("--out: the verdict file is required");
  const std::string dir = a.positional[0], out = a.options.at("--out");
  // Flags to options, checked before anything is read.
  PaperTestOptions paper;
  SiteVerdictOptions site;
  if (a.Has("--reference")) {
    paper.icp = IcpOptions(a);
    if (a.Has("--threshold-ratio")) {
      paper.threshold_ratio = ParseNumber(a.options.at("--threshold-ratio"), "--threshold-ratio");
      if (!(paper.threshold_ratio > 0)) throw InputError("--threshold-ratio: must be > 0");
    }
    paper.Check();
  } else {
    site = SiteOptions(a);
  }
  // --model sparse | dense | FILE; by default the built-in model of the cloud judged: the
  // sparse one for points.ply, the dense one for --cloud (densify's dense.ply). A file is
  // read and checked here, with the other options, before the reconstruction.
  const std::string model_arg =
      a.Has("--model") ? a.options.at("--model") : (a.Has("--cloud") ? "dense" : "sparse");
  const terrain::VerdictModel* built_in = terrain::BuiltInVerdictModel(model_arg);
  std::optional<terrain::VerdictModel> model_read;
  if (!built_in && !a.Has("--reference")) model_read = terrain::LoadVerdictModel(model_arg);
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
  const geometry::PlyCloud cloud =
      ReadCloud(cloud_path, a.Has("--cloud") ? "--cloud" : "RECON_DIR/points.ply");
  doc["cloud"] = cloud_path;
  if (a.Has("--reference")) {
    const geometry::PlyCloud reference = ReadCloud(a.options.at("--reference"), "--reference");
    try {
      doc.update(
          PaperVerdictJson(PaperTest(cloud.xyz, reference.xyz, paper), paper.threshold_ratio));
    } catch (const NoResultError& e) {
      fail(e.what());
    }
  } else {
    if (!recon.contains("frame") || recon["frame"] != "enu" || !recon.contains("scale") ||
        recon["scale"] != "metric") {
      fail(
          "the reference-free verdict needs a georeferenced model (frame enu, metric scale: run "
          "reconstruct with --gps)");
    }
    const std::optional<Eigen::Vector2d> centre = CameraCentre(recon, dir + "/recon.json");
    if (!centre) fail("no registered image");
    site.cameras = CameraCentres(recon, dir + "/recon.json");
    const terrain::VerdictModel& model = built_in ? *built_in : *model_read;
    // the model's candidate set unless --candidates names one (then the verdict says whether
    // the model was trained on it)
    if (!a.Has("--candidates")) site.detector.candidates = model.candidates;
    if (model.cloud_settings) CheckCloudMadeAsTrained(*model.cloud_settings, a, cloud_path);
    const std::string model_file = !built_in ? model_arg
                                   : model_arg == "dense"
                                       ? "built-in dense (data/verdict_model_dense.json)"
                                       : "built-in sparse (data/verdict_model.json)";
    try {
      doc.update(SiteVerdictJson(JudgeSite(cloud.xyz, *centre, site, model), model, model_file,
                                 site.detector));
    } catch (const NoResultError& e) {
      fail(e.what());
    }
  }
  WriteFileAtomic(out, doc.dump(1) + "\n");
  std::cerr << "mound_recon verdict: " << doc["label"].get<std::string>();
  if (doc.contains("p_mound"))
    std::cerr << " (p_mound " << doc["p_mound"].get<double>() << ")";
  else
    std::cerr << " (confidence " << doc["confidence"].get<double>() << ")";
  std::cerr << ": " << doc["reason"].get<std::string>() << "\n";
  return kExitOk;
}

}  // namespace mound::recon
