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
#include "sfm/features.h"
#include "sfm/reconstruction.h"

namespace mound::recon {
namespace {

constexpr const char* kVersion = "mound_recon 0.1.0";

constexpr const char* kUsage =
    "usage: mound_recon reconstruct IMAGES_DIR --out OUT_DIR [--camera camera.json|K.txt]\n"
    "                   [--gps poses.json|exif] [--max-image-size PX] [--max-features N]\n"
    "                   [--features sift|klt] [--matching auto|exhaustive|sequential]\n"
    "                   [--window N] [--align level|full]\n"
    "                   [--threads N] [--seed N]\n"
    "       mound_recon densify RECON_DIR --out OUT_DIR [--resolution-m R] [--threads N]\n"
    "                   [--max-image-size PX] [--source-views N] [--window PX] [--min-ncc C]\n"
    "                   [--min-consistent N] [--max-step-px PX] [--images DIR]\n"
    "       mound_recon compare CLOUD.ply REFERENCE.ply --out OUT_DIR [--no-scale]\n"
    "                   [--init auto|none|pca] [--max-points N] [--seed N]\n"
    "       mound_recon verdict RECON_DIR --out verdict.json [--reference REFERENCE.ply]\n"
    "                   [--threshold-ratio R] [--radius M] [--model verdict_model.json]\n"
    "                   [--relief-threshold M] [--cloud CLOUD.ply]\n"
    "       mound_recon photos CARD_DIR [--out LIST.json]\n"
    "       mound_recon --help | --version\n"
    "\n"
    "reconstruct: incremental structure from motion of one site's UAV images (SIFT,\n"
    "matching, RANSAC, the 8-point initialisation with the stacked-epipolar depths, PnP,\n"
    "triangulation, Ceres bundle adjustment), georeferenced by a robust similarity to GPS.\n"
    "  --out DIR            recon.json, points.ply, cameras.txt, images.txt, points3D.txt\n"
    "  --camera FILE        mound.camera v1 JSON (the simulator's) or a K.txt (3 x 3);\n"
    "                       without it: EXIF focal length, refined with k1, k2 in BA\n"
    "  --gps FILE|exif      mound.poses v1 (images[].file + gps_enu_m) or the photos' EXIF\n"
    "                       GPS (ENU metres around the first photo, WGS84)\n"
    "  --align A            level: the vertical from the images (the cameras' mean viewing\n"
    "                       direction), heading/scale/position from horizontal GPS (the\n"
    "                       default with --gps exif: consumer GPS heights drift); full: a\n"
    "                       7-parameter similarity to the GPS positions (default otherwise)\n"
    "  --max-image-size PX  longer side for feature extraction (default 2000)\n"
    "  --max-features N     SIFT features (or KLT corners) per image (default 8000)\n"
    "  --features F         sift (default: detect and match) or klt (track corners from\n"
    "                       each image into the next: small motions, in sequence order)\n"
    "  --matching M         auto (exhaustive up to 20 images, else a window along the\n"
    "                       sequence plus the GPS neighbours), exhaustive, sequential\n"
    "  --window N           images ahead matched in sequence (default 8)\n"
    "  --threads N          (default: the number of cores)\n"
    "  --seed N             RANSAC seed (default 1)\n"
    "\n"
    "densify: multi-view stereo on a georeferenced model: per-image depth maps by plane\n"
    "sweeping (horizontal planes; NCC over the best of the source views the sparse model\n"
    "picks), fused where the neighbours' depth maps agree, merged on a voxel grid.\n"
    "  --out DIR            dense.ply (x y z, colour, nx ny nz, support), dense.json\n"
    "                       (mound.dense v1)\n"
    "  --resolution-m R     voxel of the fused cloud (default 0.1)\n"
    "  --max-image-size PX  longer side of the depth maps (default 640)\n"
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
    "                       verdict model (mound.verdict_model v1; --model, default: the\n"
    "                       one built in from data/verdict_model.json); needs a\n"
    "                       georeferenced model; --relief-threshold (0.3 m), --radius (the\n"
    "                       site, default: 80 % of the points)\n"
    "  --reference PLY      the paper's test: compare, N(mu, sigma) fitted to the distances\n"
    "                       below their 99th percentile, mound when mu <= R x the\n"
    "                       reference's relief (--threshold-ratio, default 0.05)\n"
    "  --cloud PLY          judge this cloud of the model instead of points.ply (e.g.\n"
    "                       densify's dense.ply)\n"
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

using Clock = std::chrono::steady_clock;

double Since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

std::vector<std::string> ListImages(const std::string& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InputError("IMAGES_DIR: " + dir + " is not a directory");
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (!e.is_regular_file()) continue;
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (ext == ".jpg" || ext == ".jpeg" || ext == ".png" || ext == ".tif" || ext == ".tiff") {
      files.push_back(e.path().filename().string());
    }
  }
  if (ec) throw InputError("IMAGES_DIR: " + dir + ": " + ec.message());
  std::sort(files.begin(), files.end());
  if (files.size() < 2) {
    throw InputError("IMAGES_DIR: " + dir + " holds " + std::to_string(files.size()) +
                     " image(s) (.jpg, .png, .tif); a reconstruction needs at least 2");
  }
  return files;
}

nlohmann::json PoseJson(const geometry::Rigid3d& p) {
  const Eigen::Matrix3d R = p.RotationMatrix();
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 3; ++r) rows.push_back({R(r, 0), R(r, 1), R(r, 2)});
  return {{"R", rows}, {"t", {p.translation.x(), p.translation.y(), p.translation.z()}}};
}

int RunReconstruct(const std::vector<std::string>& args) {
  const Args a = ParseArgs(args, 1, {"--out", "--camera", "--gps", "--max-image-size", "--max-features",
                                     "--matching", "--window", "--threads", "--seed", "--features", "--align"});
  if (a.positional.size() != 1) throw InputError("reconstruct: expected exactly one IMAGES_DIR (see --help)");
  if (!a.Has("--out")) throw InputError("--out: the output directory is required");
  const std::string dir = a.positional[0], out = a.options.at("--out");
  sfm::FeatureOptions fo;
  if (a.Has("--max-image-size")) fo.max_image_size = static_cast<int>(ParseInt(a.options.at("--max-image-size"), "--max-image-size", 100, 100000));
  if (a.Has("--max-features")) fo.max_features = static_cast<int>(ParseInt(a.options.at("--max-features"), "--max-features", 100, 1000000));
  const int threads = a.Has("--threads") ? static_cast<int>(ParseInt(a.options.at("--threads"), "--threads", 1, 256))
                                         : DefaultThreads();
  const uint64_t seed = a.Has("--seed") ? static_cast<uint64_t>(ParseInt(a.options.at("--seed"), "--seed", 0, 1LL << 62)) : 1;
  const std::string matching = a.Has("--matching") ? a.options.at("--matching") : "auto";
  if (matching != "auto" && matching != "exhaustive" && matching != "sequential") {
    throw InputError("--matching: expected auto, exhaustive or sequential, got '" + matching + "'");
  }
  const std::string gps_arg = a.Has("--gps") ? a.options.at("--gps") : "";
  const std::string align = a.Has("--align") ? a.options.at("--align") : (gps_arg == "exif" ? "level" : "full");
  if (align != "level" && align != "full") throw InputError("--align: expected level or full, got '" + align + "'");
  const std::string feature_kind = a.Has("--features") ? a.options.at("--features") : "sift";
  if (feature_kind != "sift" && feature_kind != "klt") {
    throw InputError("--features: expected sift or klt, got '" + feature_kind + "'");
  }
  const int window = a.Has("--window") ? static_cast<int>(ParseInt(a.options.at("--window"), "--window", 1, 10000)) : 8;
  const std::vector<std::string> files = ListImages(dir);
  const int n = static_cast<int>(files.size());
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec) throw InputError("--out: cannot create " + out + ": " + ec.message());

  nlohmann::json timings = nlohmann::json::object();
  // GPS from a poses file is checked before any work.
  std::optional<GpsPositions> gps;
  if (!gps_arg.empty() && gps_arg != "exif") gps = ReadGpsPoses(gps_arg, files);

  auto t0 = Clock::now();
  std::vector<sfm::ImageFeatures> features(n);
  std::vector<sfm::MatchList> tracked;  // KLT: matches of consecutive images
  if (feature_kind == "klt") {
    std::vector<std::string> paths;
    for (const std::string& f : files) paths.push_back(dir + "/" + f);
    sfm::KltResult k = sfm::TrackKlt(paths, fo);
    features = std::move(k.features);
    tracked = std::move(k.consecutive);
  } else {
    ParallelFor(n, threads, [&](int i) { features[i] = sfm::ExtractFeatures(dir + "/" + files[i], fo); });
  }
  for (int i = 1; i < n; ++i) {
    if (features[i].width != features[0].width || features[i].height != features[0].height) {
      throw InputError(files[i] + ": " + std::to_string(features[i].width) + "x" + std::to_string(features[i].height) +
                       " pixels, but " + files[0] + " is " + std::to_string(features[0].width) + "x" +
                       std::to_string(features[0].height) + " (one camera for all images)");
    }
  }
  timings["features_s"] = Since(t0);
  const int W = features[0].width, H = features[0].height;

  // The camera: a file, or EXIF (refined in bundle adjustment).
  geometry::CameraModel camera;
  std::string camera_source;
  bool refine = false;
  std::vector<Exif> exif(n);
  if (gps_arg == "exif" || !a.Has("--camera")) {
    for (int i = 0; i < n; ++i) exif[i] = ReadExif(dir + "/" + files[i]);
  }
  if (a.Has("--camera")) {
    camera = ReadCamera(a.options.at("--camera"), W, H);
    camera_source = "file";
  } else {
    camera.width = W;
    camera.height = H;
    camera.cx = (W - 1) / 2.0;
    camera.cy = (H - 1) / 2.0;
    std::string how;
    std::optional<double> f = FocalPx(exif[0], W, &how);
    camera_source = f ? "exif (" + how + ")" : "default (1.2 x the longer side)";
    camera.fx = camera.fy = f.value_or(1.2 * std::max(W, H));
    refine = true;
  }
  if (gps_arg == "exif") {
    GpsPositions g;
    g.source = "exif";
    for (int i = 0; i < n; ++i) {
      if (!exif[i].lat_deg) continue;
      const geometry::Geodetic here{*exif[i].lat_deg, *exif[i].lon_deg, exif[i].alt_m.value_or(0)};
      if (!g.origin) g.origin = here;
      g.enu_m[files[i]] = geometry::EnuFromGeodetic(*g.origin, here);
    }
    if (g.enu_m.empty()) throw InputError("--gps exif: no image in " + dir + " has EXIF GPS");
    gps = g;
  }

  // Pairs to match (KLT: the consecutive images it tracked).
  std::set<std::pair<int, int>> pair_set;
  if (feature_kind == "klt") {
    for (int i = 0; i + 1 < n; ++i) pair_set.insert({i, i + 1});
  } else if (matching == "exhaustive" || (matching == "auto" && n <= 20)) {
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j) pair_set.insert({i, j});
  } else {
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j <= std::min(n - 1, i + window); ++j) pair_set.insert({i, j});
    if (gps && matching == "auto") {
      for (int i = 0; i < n; ++i) {
        auto gi = gps->enu_m.find(files[i]);
        if (gi == gps->enu_m.end()) continue;
        std::vector<std::pair<double, int>> near;
        for (int j = 0; j < n; ++j) {
          auto gj = gps->enu_m.find(files[j]);
          if (j != i && gj != gps->enu_m.end()) near.emplace_back((gi->second - gj->second).norm(), j);
        }
        std::sort(near.begin(), near.end());
        for (size_t k = 0; k < std::min<size_t>(window, near.size()); ++k)
          pair_set.insert({std::min(i, near[k].second), std::max(i, near[k].second)});
      }
    }
  }
  const std::vector<std::pair<int, int>> pair_list(pair_set.begin(), pair_set.end());
  t0 = Clock::now();
  const double verify_px = std::max(1.0, 1.0 * std::max(W, H) / 2000.0);
  std::vector<sfm::VerifiedPair> verified(pair_list.size());
  const sfm::DescriptorMatcher matcher(features);
  ParallelFor(static_cast<int>(pair_list.size()), threads, [&](int k) {
    const auto [i, j] = pair_list[k];
    const sfm::MatchList m = feature_kind == "klt" ? tracked[i] : matcher.Match(i, j);
    verified[k] = sfm::VerifyPair(i, j, features[i], features[j], m, camera, verify_px, seed + k);
  });
  timings["matching_s"] = Since(t0);
  int useful_pairs = 0;
  for (const auto& v : verified) useful_pairs += v.inliers.size() >= 30;

  nlohmann::json doc = {{"schema", "mound.recon"}, {"version", 1}, {"tool", kVersion},
                        {"images_dir", dir}, {"status", "ok"}};
  doc["inputs"] = {{"images", n}, {"camera_source", camera_source}, {"gps_source", gps ? gps->source : "none"},
                   {"pairs_matched", pair_list.size()}, {"pairs_verified", useful_pairs},
                   {"max_image_size", fo.max_image_size}, {"max_features", fo.max_features},
                   {"features", feature_kind}};
  sfm::MapperOptions mo;
  mo.max_error_px = 4.0;  // COLMAP's filter threshold, full-resolution pixels
  mo.refine_intrinsics = refine;
  mo.threads = threads;
  mo.seed = seed;
  t0 = Clock::now();
  sfm::Reconstruction r;
  try {
    r = sfm::IncrementalMap(features, verified, camera, mo);
  } catch (const NoResultError& e) {
    timings["mapping_s"] = Since(t0);
    doc["status"] = "failed";
    doc["reason"] = e.what();
    doc["timings_s"] = timings;
    WriteFileAtomic(out + "/recon.json", doc.dump(1) + "\n");
    throw;
  }
  timings["mapping_s"] = Since(t0);
  nlohmann::json mapping_stages = {{"initialise", r.timings.initialise_s}, {"register", r.timings.register_s},
                                 {"triangulate", r.timings.triangulate_s}, {"local_ba", r.timings.local_ba_s},
                                 {"global_ba", r.timings.global_ba_s}};

  // The metric frame: a robust similarity from the camera centres to GPS.
  doc["frame"] = "arbitrary";
  doc["scale"] = "unknown";
  if (gps) {
    std::vector<Eigen::Vector3d> model, world;
    std::vector<int> which;
    for (int i = 0; i < n; ++i) {
      auto g = gps->enu_m.find(files[i]);
      if (!r.registered[i] || g == gps->enu_m.end()) continue;
      model.push_back(r.cam_from_world[i].Centre());
      world.push_back(g->second);
      which.push_back(i);
    }
    // Consumer GPS heights drift (Caliterra's climb 80 m during the flight): by default
    // with EXIF GPS the vertical comes from the images (FitLevelledSim3Robust), with a
    // poses file from all three GPS coordinates; --align chooses.
    Eigen::Vector3d down_in_model = Eigen::Vector3d::Zero();
    for (int i = 0; i < n; ++i)
      if (r.registered[i]) down_in_model += r.cam_from_world[i].rotation.conjugate() * Eigen::Vector3d::UnitZ();
    const auto fit = align == "level" ? sfm::FitLevelledSim3Robust(model, world, down_in_model, seed)
                                      : sfm::FitSim3Robust(model, world, seed);
    if (fit && fit->inliers >= 3) {
      sfm::Transform(fit->world_from_model, &r);
      doc["frame"] = "enu";
      doc["scale"] = "metric";
      if (gps->origin) doc["origin"] = {{"lat", gps->origin->lat_deg}, {"lon", gps->origin->lon_deg}, {"alt_m", gps->origin->alt_m}};
      nlohmann::json outliers = nlohmann::json::array();
      for (size_t k = 0; k < which.size(); ++k)
        if (!fit->inlier[k]) outliers.push_back(files[which[k]]);
      doc["gps_fit"] = {{"images", model.size()}, {"inliers", fit->inliers}, {"outliers", outliers},
                        {"rmse_m", fit->rmse_m}, {"rmse_horizontal_m", fit->rmse_horizontal_m},
                        {"rmse_vertical_m", fit->rmse_vertical_m}, {"scale", fit->world_from_model.scale},
                        {"method", align == "level" ? "level: vertical from the images, heading, scale and "
                                                      "position from horizontal GPS, height offset by median"
                                                    : "full: 7-parameter similarity to the GPS positions"}};
    } else {
      doc["gps_fit"] = {{"images", model.size()}, {"note", "fewer than 3 registered images with GPS: frame left arbitrary"}};
    }
  }
  doc["camera"] = CameraJson(r.camera);
  nlohmann::json images = nlohmann::json::array();
  for (int i = 0; i < n; ++i) {
    nlohmann::json im = {{"file", files[i]}, {"registered", static_cast<bool>(r.registered[i])}};
    if (r.registered[i]) {
      im["cam_from_world"] = PoseJson(r.cam_from_world[i]);
      const Eigen::Vector3d c = r.cam_from_world[i].Centre();
      im["centre"] = {c.x(), c.y(), c.z()};
      im["reprojection_error_px"] = r.image_error_px[i];
      im["observations"] = r.image_points[i];
    }
    images.push_back(im);
  }
  doc["images"] = images;
  doc["registered"] = r.NumRegistered();
  doc["points"] = r.points.size();
  doc["reprojection_rmse_px"] = r.rmse_px;
  doc["initial_pair"] = {files[r.init_image1], files[r.init_image2]};
  doc["bundle_adjustments"] = {{"global", r.ba_runs}, {"local", r.local_ba_runs}};
  t0 = Clock::now();
  WritePly(out + "/points.ply", r);
  WriteColmapText(out, r, files, features);
  timings["write_s"] = Since(t0);
  doc["timings_s"] = timings;
  doc["mapping_timings_s"] = mapping_stages;
  WriteFileAtomic(out + "/recon.json", doc.dump(1) + "\n");
  std::cerr << "mound_recon: " << r.NumRegistered() << "/" << n << " images registered, " << r.points.size()
            << " points, RMSE " << r.rmse_px << " px, frame " << doc["frame"].get<std::string>() << "\n";
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
    std::string source;
    if (e.width_px && *e.width_px > 0) {
      if (auto f = FocalPx(e, *e.width_px, &source)) {
        x["focal_px"] = *f;  // for an image PixelXDimension wide
        x["focal_source"] = source;
      }
    }
    j["exif"] = x;
    files.push_back(j);
  }
  const nlohmann::json doc = {{"schema", "mound.photo_list"}, {"version", 1},
                              {"card", a.positional[0]}, {"files", files},
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
  return RunGuarded("mound_recon", err, [&]() {
    if (WantsHelp(args)) {
      out << kUsage;
      return static_cast<int>(kExitOk);
    }
    if (args.empty()) throw InputError("missing a command: reconstruct, densify, compare, verdict or photos (see --help)");
    if (args[0] == "--version") {
      out << kVersion << "\n";
      return static_cast<int>(kExitOk);
    }
    if (args[0] == "reconstruct") return RunReconstruct(args);
    if (args[0] == "densify") return RunDensify(args);
    if (args[0] == "compare") return RunCompare(args);
    if (args[0] == "verdict") return RunVerdict(args);
    if (args[0] == "photos") return RunPhotos(args, out);
    throw InputError("unknown command '" + args[0] + "' (see --help)");
  });
}

}  // namespace mound::recon
