#include "recon/recon_cli.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <set>

#include "common/atomic_file.h"
#include "common/cli_args.h"
#include "common/error.h"
#include "common/json_util.h"
#include "common/parallel.h"
#include "recon/compare_cli.h"
#include "recon/densify_cli.h"
#include "recon/exif.h"
#include "recon/photos.h"
#include "recon/recon_io.h"
#include "recon/reconstruct.h"
#include "sfm/features.h"
#include "sfm/reconstruction.h"

namespace mound::recon {
namespace {

constexpr const char* kVersion = "mound_recon " MOUND_VERSION;  // pyproject.toml's, from CMake

constexpr const char* kUsage =
    "usage: mound_recon reconstruct IMAGES_DIR --out OUT_DIR [--camera camera.json|K.txt]\n"
    "                   [--gps poses.json|exif] [--max-image-size PX] [--max-features N]\n"
    "                   [--contrast-threshold C]\n"
    "                   [--features sift|klt] [--matching auto|exhaustive|sequential|retrieval]\n"
    "                   [--matcher cascade|flann|exact] [--window N] [--neighbours N]\n"
    "                   [--align level|full] [--lens prior|free|fixed]\n"
    "                   [--threads N] [--seed N]\n"
    "       mound_recon densify RECON_DIR --out OUT_DIR [--resolution-m R] [--threads N]\n"
    "                   [--max-image-size PX] [--source-views N] [--window PX] [--min-ncc C]\n"
    "                   [--min-consistent N] [--max-step-px PX] [--images DIR]\n"
    "       mound_recon compare CLOUD.ply REFERENCE.ply --out OUT_DIR [--no-scale]\n"
    "                   [--init auto|none|pca] [--max-points N] [--seed N]\n"
    "       mound_recon verdict RECON_DIR --out verdict.json [--reference REFERENCE.ply]\n"
    "                   [--threshold-ratio R] [--radius M] [--model sparse|dense|FILE]\n"
    "                   [--relief-threshold M] [--cloud CLOUD.ply]\n"
    "                   [--candidates site_ground|local_relief]\n"
    "                   [--second-look FIRST_VERDICT.json] [--decide-at P]\n"
    "       mound_recon photos CARD_DIR [--out LIST.json]\n"
    "       mound_recon --help | --version\n"
    "\n"
    "reconstruct: incremental structure from motion of one site's UAV images (SIFT,\n"
    "matching, RANSAC, the 8-point initialisation with the stacked-epipolar depths, PnP,\n"
    "triangulation, Ceres bundle adjustment), georeferenced by a robust similarity to GPS.\n"
    "  --out DIR            recon.json, points.ply, cameras.txt, images.txt, points3D.txt\n"
    "  --camera FILE        mound.camera v1 JSON (the simulator's) or a K.txt (3 x 3);\n"
    "                       without it: EXIF focal length, refined with k1, k2 in BA\n"
    "  --lens L             with EXIF's camera: prior (default: f, k1, k2 refined, held\n"
    "                       about EXIF's f and no distortion, sd 1 % and 0.01, as\n"
    "                       OpenSfM: a nadir block's self-calibration otherwise domes the\n"
    "                       model), free (refined freely, as COLMAP) or fixed (EXIF's\n"
    "                       as it is, as ODM's --use-fixed-camera-params)\n"
    "  --gps FILE|exif      mound.poses v1 (images[].file + gps_enu_m) or the photos' EXIF\n"
    "                       GPS (ENU metres around the first photo, WGS84)\n"
    "  --align A            level: the vertical from the images (the cameras' mean viewing\n"
    "                       direction), heading/scale/position from horizontal GPS (the\n"
    "                       default with --gps exif: consumer GPS heights drift); full: a\n"
    "                       7-parameter similarity to the GPS positions (default otherwise)\n"
    "  --max-image-size PX  longer side for feature extraction (default 2000)\n"
    "  --max-features N     SIFT features (or KLT corners) per image (default 6000)\n"
    "  --contrast-threshold C  SIFT's (OpenCV's; default 0.01): lower finds more\n"
    "                       keypoints. The defaults are what the survey runs on a card's\n"
    "                       photos (COLMAP's density); its simulated sites take 4000 and\n"
    "                       0.04 (640 x 480 renders)\n"
    "  --features F         sift (default: detect and match) or klt (track corners from\n"
    "                       each image into the next: small motions, in sequence order)\n"
    "  --matching M         auto (located images: each with the next 3 in sequence and\n"
    "                       its --neighbours nearest by GPS; unlocated: every pair up to\n"
    "                       20 images, else the next 3 and the --neighbours most similar\n"
    "                       by VLAD retrieval), exhaustive, sequential (the next --window\n"
    "                       images), retrieval (as auto's unlocated images, GPS or not)\n"
    "  --window N           images ahead matched in sequence (default 8; auto and\n"
    "                       retrieval: at most 3; 0: none)\n"
    "  --neighbours N       nearest images by GPS, or most similar by retrieval, matched\n"
    "                       with each (default 8)\n"
    "  --matcher M          cascade (cascade hashing, default), flann (k-d trees) or\n"
    "                       exact (brute force: the reference, slow)\n"
    "  --threads N          (default: the number of cores)\n"
    "  --seed N             RANSAC seed (default 1)\n"
    "\n"
    "densify: multi-view stereo on a georeferenced model: per-image depth maps by plane\n"
    "sweeping (horizontal planes; NCC over the best of the source views the sparse model\n"
    "picks), fused where the neighbours' depth maps agree, merged on a voxel grid.\n"
    "  --out DIR            dense.ply (x y z, colour, nx ny nz, support), dense.json\n"
    "                       (mound.dense v1)\n"
    "  --resolution-m R     voxel of the fused cloud (default 0.25: the verdict models'\n"
    "                       training clouds; another value makes a cloud they refuse)\n"
    "  --max-image-size PX  longer side of the depth maps (default 320: the same)\n"
    "  --source-views N     source images per depth map (default 4)\n"
    "  --window PX          NCC window side, odd (default 7)\n"
    "  --min-ncc C          lowest accepted score (default 0.4)\n"
    "  --min-consistent N   depth maps that must confirm a point (default 2)\n"
    "  --max-step-px PX     plane spacing: the most a source pixel moves (default 2)\n"
    "  --images DIR         the images (default: recon.json's images_dir)\n"
    "\n"
    "compare: ICP with scale (PCL; correspondences beyond 3x their median rejected) of the\n"
    "cloud onto the reference, then each point's distance to the reference surface.\n"
    "  --out DIR            compare.json (mound.compare v1), aligned.ply (+ distance)\n"
    "  --no-scale           rigid ICP (the clouds share a metric scale)\n"
    "  --init I             auto (none when the clouds overlap already, else pca), none,\n"
    "                       pca (principal axes, 24 starts tried by a coarse ICP)\n"
    "  --max-points N       cloud points sampled for the ICP iterations (default 20000)\n"
    "verdict: mound or no_mound for a reconstructed site (verdict.json, mound.verdict v1).\n"
    "  default              reference-free: ground fitted robustly, the most prominent rise\n"
    "                       measured (height, base diameter, roundness, dome fit, symmetry,\n"
    "                       flank slope, clipping by the scan's edge); p_mound from the\n"
    "                       verdict model (mound.verdict_model v1); needs a\n"
    "                       georeferenced model; --relief-threshold (0.3 m), --radius (the\n"
    "                       site, default: 80 % of the points)\n"
    "  --model M            sparse (built in from data/verdict_model.json, learned on\n"
    "                       sparse clouds: the default for points.ply), dense (from\n"
    "                       data/verdict_model_dense.json, learned on densify's clouds: the\n"
    "                       default with --cloud) or a model file\n"
    "  --reference PLY      the paper's test: compare, N(mu, sigma) fitted to the distances\n"
    "                       below their 99th percentile, mound when mu <= R x the\n"
    "                       reference's relief (--threshold-ratio, default 0.05)\n"
    "  --cloud PLY          judge this cloud of the model instead of points.ply (e.g.\n"
    "                       densify's dense.ply)\n"
    "  --candidates C       the candidate rises measured: site_ground (over the site's\n"
    "                       ground, and its heights' scale space) or local_relief (those\n"
    "                       and the local relief's blobs at every scale: a tumulus on a\n"
    "                       steep slope or beside a larger landform); default: the set\n"
    "                       the model was trained on (its detector.candidates, else\n"
    "                       site_ground). Another set than the model's: undecided, reason\n"
    "                       model (to measure a training grid)\n"
    "  --second-look V      RECON_DIR is the site's second flight, with a scan\n"
    "                       second_look.scan_factor x as wide as the first, whose\n"
    "                       verdict.json V advised it: p_mound of both flights together\n"
    "  --decide-at P        two answers, mound at p_mound >= P (the paper's protocol),\n"
    "                       instead of the model's: mound, no_mound or undecided when the\n"
    "                       model has an undecided band (p_low <= p < p_high), or a\n"
    "                       terrain_domain that the site's ground lies outside (reason\n"
    "                       terrain: ground unlike its training sites')\n"
    "\n"
    "photos: the files of a photo card (every file under CARD_DIR; links to folders not\n"
    "followed, unreadable folders listed under skipped), each with its kind by its first\n"
    "bytes (jpeg, tiff, png, not_an_image, unreadable; bad_name for a name that is not\n"
    "UTF-8) and its EXIF: GPS lat, lon, alt_m,\n"
    "capture time, make, model, focal length (headers only; no pixel is decoded), as\n"
    "mound.photo_list v1 JSON on stdout or --out.\n"
    "--help anywhere on the command line prints this text.\n"
    "Exit codes: 0 ok, 1 internal error, 2 bad input (one line naming it), 3 valid input\n"
    "that allowed no result (recon.json says \"status\": \"failed\" and why).\n";

int RunReconstruct(const std::vector<std::string>& args) {
  const Args a = ParseArgs(args, 1,
                           {"--out", "--camera", "--gps", "--max-image-size", "--max-features",
                            "--matching", "--matcher", "--window", "--neighbours", "--threads",
                            "--seed", "--features", "--align", "--lens", "--contrast-threshold"});
  if (a.positional.size() != 1)
    throw InputError("reconstruct: expected exactly one IMAGES_DIR (see --help)");
  if (!a.Has("--out")) throw InputError("--out: the output directory is required");
  const std::string out = a.options.at("--out");
  auto opt = [&](const char* name, const std::string& fallback) {
    return a.Has(name) ? a.options.at(name) : fallback;
  };
  auto num = [&](const char* name, long long lo, long long hi, long long fallback) {
    return a.Has(name) ? ParseInt(a.options.at(name), name, lo, hi) : fallback;
  };
  ReconstructOptions o;
  o.images_dir = a.positional[0];
  o.camera_file = opt("--camera", "");
  if (a.Has("--gps")) {
    const std::string& g = a.options.at("--gps");
    o.gps = g == "exif" ? GpsSource::kExif : GpsSource::kPosesFile;
    if (o.gps == GpsSource::kPosesFile) o.poses_file = g;
  }
  o.features.max_image_size =
      static_cast<int>(num("--max-image-size", 100, 100000, o.features.max_image_size));
  o.features.max_features =
      static_cast<int>(num("--max-features", 100, 1000000, o.features.max_features));
  if (a.Has("--contrast-threshold")) {
    o.features.contrast_threshold =
        ParseNumber(a.options.at("--contrast-threshold"), "--contrast-threshold");
    if (!(o.features.contrast_threshold > 0 && o.features.contrast_threshold <= 1))
      throw InputError("--contrast-threshold: must be in (0, 1]");
  }
  if (a.Has("--features")) o.feature_kind = ParseEnum(a, "--features", kFeatureKindNames);
  if (a.Has("--matching")) o.matching = ParseEnum(a, "--matching", kMatchingNames);
  if (a.Has("--matcher")) o.matcher = ParseEnum(a, "--matcher", kMatcherNames);
  o.window = static_cast<int>(num("--window", 0, 10000, o.window));
  o.neighbours = static_cast<int>(num("--neighbours", 1, 10000, o.neighbours));
  if (a.Has("--align")) o.align = ParseEnum(a, "--align", kAlignNames);
  if (a.Has("--lens")) o.lens = ParseEnum(a, "--lens", kLensNames);
  o.threads = static_cast<int>(num("--threads", 1, 256, DefaultThreads()));
  o.seed = static_cast<uint64_t>(num("--seed", 0, 1LL << 62, 1));
  o.tool = kVersion;
  o.Check();
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec) throw InputError("--out: cannot create " + out + ": " + ec.message());

  ReconstructResult res = Reconstruct(o);
  nlohmann::json& doc = res.doc;
  if (!res.model) {
    WriteFileAtomic(out + "/recon.json", doc.dump(1) + "\n");
    throw NoResultError(doc.value("reason", std::string("no reconstruction")));
  }
  const sfm::Reconstruction& r = *res.model;
  const auto t0 = std::chrono::steady_clock::now();
  WritePly(out + "/points.ply", r);
  WriteColmapText(out, r, res.files, res.features);
  doc["timings_s"]["write_s"] =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  WriteFileAtomic(out + "/recon.json", doc.dump(1) + "\n");
  std::cerr << "mound_recon: " << r.NumRegistered() << "/" << res.files.size()
            << " images registered, " << r.points.size() << " points, RMSE " << r.rmse_px
            << " px, frame " << doc["frame"].get<std::string>() << "\n";
  return kExitOk;
}

// `photos`: the card's files, their kinds and EXIF (headers only), as mound.photo_list v1.
int RunPhotos(const std::vector<std::string>& args, std::ostream& out) {
  const Args a = ParseArgs(args, 1, {"--out"});
  if (a.positional.size() != 1) throw InputError("photos: expected exactly one CARD_DIR");
  const CardListing card = ListCard(a.positional[0]);
  nlohmann::json files = nlohmann::json::array();
  for (const CardFile& f : card.files) {
    nlohmann::json j = {{"file", f.file}, {"kind", f.kind}, {"bytes", f.bytes}};
    const Exif& e = f.exif;
    nlohmann::json x = nlohmann::json::object();
    if (e.lat_deg && e.lon_deg) {
      x["lat"] = *e.lat_deg;
      x["lon"] = *e.lon_deg;
      if (e.alt_m) x["alt_m"] = *e.alt_m;
    }
    if (!e.datetime.empty()) x["time"] = e.datetime;
    if (!e.make.empty()) x["make"] = e.make;
    if (!e.model.empty()) x["model"] = e.model;
    if (e.focal_mm) x["focal_mm"] = *e.focal_mm;
    if (e.focal_35mm) x["focal_35mm"] = *e.focal_35mm;
    if (e.width_px) x["width_px"] = *e.width_px;
    if (e.focal_plane_x_res && e.focal_plane_unit_mm) {
      x["pixel_pitch_mm"] = *e.focal_plane_unit_mm / *e.focal_plane_x_res;
    }
    if (e.width_px && *e.width_px > 0) {
      if (auto f = FocalFromExif(e, *e.width_px)) {
        x["focal_px"] = f->px;  // for an image PixelXDimension wide
        x["focal_source"] = f->source;
        x["focal_detail"] = f->detail;
      }
    }
    j["exif"] = x;
    if (e.dji) {
      nlohmann::json d = nlohmann::json::object();
      const DjiXmp& v = *e.dji;
      const std::pair<const char*, const std::optional<double>*> fields[] = {
          {"abs_alt_m", &v.abs_alt_m},
          {"rel_alt_m", &v.rel_alt_m},
          {"gimbal_pitch_deg", &v.gimbal_pitch_deg},
          {"gimbal_yaw_deg", &v.gimbal_yaw_deg},
          {"gimbal_roll_deg", &v.gimbal_roll_deg},
          {"flight_pitch_deg", &v.flight_pitch_deg},
          {"flight_yaw_deg", &v.flight_yaw_deg},
          {"flight_roll_deg", &v.flight_roll_deg},
          {"lat", &v.lat_deg},
          {"lon", &v.lon_deg},
          {"rtk_std_lon_m", &v.rtk_std_lon_m},
          {"rtk_std_lat_m", &v.rtk_std_lat_m},
          {"rtk_std_hgt_m", &v.rtk_std_hgt_m}};
      for (const auto& [name, value] : fields)
        if (*value) d[name] = **value;
      if (v.rtk_flag) d["rtk_flag"] = *v.rtk_flag;
      j["dji_xmp"] = d;
    }
    files.push_back(j);
  }
  const nlohmann::json doc = {{"schema", "mound.photo_list"},
                              {"version", 1},
                              {"card", a.positional[0]},
                              {"files", files},
                              {"skipped", card.skipped}};
  const std::string text = doc.dump(1) + "\n";
  if (a.Has("--out")) {
    WriteFileAtomic(a.options.at("--out"), text);
  } else {
    out << text;
  }
  return kExitOk;
}

}  // namespace

int RunMoundRecon(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  return RunTool("mound_recon", kUsage, kVersion, args, out, err, [&]() {
    if (args.empty())
      throw InputError(
          "missing a command: reconstruct, densify, compare, verdict or photos (see --help)");
    if (args[0] == "reconstruct") return RunReconstruct(args);
    if (args[0] == "densify") return RunDensify(args);
    if (args[0] == "compare") return RunCompare(args);
    if (args[0] == "verdict") return RunVerdict(args);
    if (args[0] == "photos") return RunPhotos(args, out);
    throw InputError("unknown command '" + args[0] + "' (see --help)");
  });
}

}  // namespace mound::recon
