#include "recon/reconstruct.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <utility>

#include "common/error.h"
#include "common/parallel.h"
#include "common/timing.h"
#include "geometry/geodesy.h"
#include "recon/exif.h"
#include "recon/inputs.h"
#include "recon/recon_io.h"
#include "sfm/georegistration.h"
#include "sfm/incremental_mapper.h"
#include "sfm/pairing.h"
#include "sfm/retrieval.h"

namespace mound::recon {
namespace {

std::vector<std::string> ListImages(const std::string& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InputError("IMAGES_DIR: " + dir + " is not a directory");
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (!e.is_regular_file()) continue;
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return std::tolower(c); });
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

// Seconds since an arbitrary epoch of an EXIF "YYYY:MM:DD HH:MM:SS" (days counted as
// 31 per month: only differences within a flight are used); nothing when malformed.
std::optional<double> ExifSeconds(const std::string& t) {
  int y, mo, d, h, mi, s;
  if (t.size() != 19 || std::sscanf(t.c_str(), "%d:%d:%d %d:%d:%d", &y, &mo, &d, &h, &mi, &s) != 6)
    return std::nullopt;
  return ((((y * 12.0 + mo) * 31 + d) * 24 + h) * 60 + mi) * 60 + s;
}

// GNSS latency (DJI's consumer aircraft record where they were a fraction of a second
// before the shutter): on a back-and-forth pattern alternate strips are shifted along
// track in opposite directions, and the fit drops a whole strip as outliers. The GPS
// positions are corrected by lambda x the photo's own step d_k (half the displacement
// from the photo before to the photo after, in capture order), lambda the same for the
// whole flight and searched on -1.5 .. 1.5 steps; kept where it explains the GPS clearly
// better (more inliers, or the RMSE down by a fifth) than none.
struct Latency {
  double steps = 0;
  std::vector<Eigen::Vector3d> step;  // d_k per fitted photo (horizontal)
};

Latency GpsSteps(const std::vector<Eigen::Vector3d>& world, const std::vector<double>& order_key) {
  Latency l;
  const size_t n = world.size();
  std::vector<size_t> order(n);
  for (size_t k = 0; k < n; ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return order_key[a] < order_key[b]; });
  l.step.assign(n, Eigen::Vector3d::Zero());
  for (size_t j = 0; j < n; ++j) {
    const size_t before = order[j == 0 ? 0 : j - 1], after = order[j + 1 < n ? j + 1 : n - 1];
    const double span = (j > 0) + (j + 1 < n);
    if (span == 0) continue;
    Eigen::Vector3d d = (world[after] - world[before]) / span;
    d.z() = 0;
    l.step[order[j]] = d;
  }
  return l;
}

}  // namespace

void ReconstructOptions::Check() const {
  if (window < 0 || (window == 0 && matching == Matching::kSequential)) {
    throw InputError(
        "--window: must be >= 1 (0, no sequence pairs, only with auto or retrieval matching)");
  }
  if (neighbours < 1) throw InputError("--neighbours: must be >= 1");
  if (threads < 1) throw InputError("--threads: must be >= 1");
  if (gps == GpsSource::kPosesFile && poses_file.empty())
    throw InputError("--gps: the poses file is empty");
  if (lens && *lens != Lens::kFixed && !camera_file.empty())
    throw InputError(
        "--lens: a --camera file is a calibrated lens, held fixed (--lens "
        "prior and free refine EXIF's)");
}

ReconstructResult Reconstruct(const ReconstructOptions& o) {
  o.Check();
  const std::string& dir = o.images_dir;
  const bool exif_gps = o.gps == GpsSource::kExif;
  Align align = o.align != Align::kAuto ? o.align : exif_gps ? Align::kLevel : Align::kFull;
  const sfm::FeatureOptions& fo = o.features;
  const bool klt = o.feature_kind == FeatureKind::kKlt;
  const Matching matching = o.matching;
  const int window = o.window, neighbours = o.neighbours, threads = o.threads;
  const uint64_t seed = o.seed;
  ReconstructResult res;
  res.files = ListImages(dir);
  const std::vector<std::string>& files = res.files;
  const int n = static_cast<int>(files.size());

  nlohmann::json timings = nlohmann::json::object();
  // GPS from a poses file is checked before any work.
  std::optional<GpsPositions> gps;
  if (o.gps == GpsSource::kPosesFile) gps = ReadGpsPoses(o.poses_file, files);

  auto t0 = Clock::now();
  std::vector<sfm::ImageFeatures>& features = res.features;
  features.resize(n);
  std::vector<sfm::MatchList> tracked;  // KLT: matches of consecutive images
  if (klt) {
    std::vector<std::string> paths;
    for (const std::string& f : files) paths.push_back(dir + "/" + f);
    sfm::KltResult k = sfm::TrackKlt(paths, fo);
    features = std::move(k.features);
    tracked = std::move(k.consecutive);
  } else {
    // One image per thread, and OpenCV's SIFT loops inside it single-threaded: --threads N
    // uses N cores (two sites on two cores do not oversubscribe them).
    sfm::SetLibraryThreads(1);
    ParallelFor(n, threads,
                [&](int i) { features[i] = sfm::ExtractFeatures(dir + "/" + files[i], fo); });
    sfm::SetLibraryThreads(threads);
  }
  for (int i = 1; i < n; ++i) {
    if (features[i].width != features[0].width || features[i].height != features[0].height) {
      throw InputError(files[i] + ": " + std::to_string(features[i].width) + "x" +
                       std::to_string(features[i].height) + " pixels, but " + files[0] + " is " +
                       std::to_string(features[0].width) + "x" +
                       std::to_string(features[0].height) + " (one camera for all images)");
    }
  }
  timings["features_s"] = Since(t0);
  const int W = features[0].width, H = features[0].height;

  // The camera: a file (calibrated, fixed), or EXIF (--lens: refined in bundle adjustment
  // about EXIF's values by default).
  geometry::CameraModel camera;
  std::string camera_source;
  std::optional<FocalPrior> focal;  // EXIF's focal length, where it came from, its prior
  std::vector<Exif> exif(n);
  int rtk_fixed = 0;  // photos with an RTK fix (DJI XMP), with --gps exif
  // 1 / the variance of each photo's RTK position (DJI XMP RtkStdLon/Lat/Hgt), by file
  std::map<std::string, double> gps_weight;
  if (exif_gps || o.camera_file.empty()) {
    for (int i = 0; i < n; ++i) exif[i] = ReadExif(dir + "/" + files[i]);
  }
  if (!o.camera_file.empty()) {
    camera = ReadCamera(o.camera_file, W, H);
    camera_source = "file";
  } else {
    camera.width = W;
    camera.height = H;
    camera.cx = (W - 1) / 2.0;
    camera.cy = (H - 1) / 2.0;
    focal = FocalFromExif(exif[0], W);
    camera_source = focal ? "exif (" + focal->source + ")" : "default (1.2 x the longer side)";
    camera.fx = camera.fy = focal ? focal->px : 1.2 * std::max(W, H);
  }
  // Check() refuses prior and free with a camera file
  const Lens lens = o.lens.value_or(o.camera_file.empty() ? Lens::kPrior : Lens::kFixed);
  if (exif_gps) {
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
    // DJI's RTK photos (XMP RtkFlag 50, fixed) carry heights to centimetres: where every
    // photo with GPS has a fix and a vertical standard deviation within 0.1 m, the heights
    // do not drift as consumer GNSS heights do, and the default fit takes all three
    // coordinates instead of levelling from the images.
    int rtk = 0, with_gps = 0;
    for (int i = 0; i < n; ++i) {
      if (!exif[i].lat_deg) continue;
      ++with_gps;
      const auto& d = exif[i].dji;
      if (d && d->rtk_flag == 50 && d->rtk_std_hgt_m && *d->rtk_std_hgt_m <= 0.1) ++rtk;
      if (d && d->rtk_std_lon_m && d->rtk_std_lat_m && d->rtk_std_hgt_m) {
        // at least 1 mm: a zero standard deviation is a rounding, not a certainty
        const double var = std::max(1e-6, *d->rtk_std_lon_m * *d->rtk_std_lon_m +
                                              *d->rtk_std_lat_m * *d->rtk_std_lat_m +
                                              *d->rtk_std_hgt_m * *d->rtk_std_hgt_m);
        gps_weight[files[i]] = 1 / var;
      }
    }
    rtk_fixed = rtk;
    if (o.align == Align::kAuto && rtk > 0 && rtk == with_gps) align = Align::kFull;
    // The heights' datum: EXIF's GPSAltitude is above sea level (DJI: EGM96) for a GNSS
    // position, above the WGS84 ellipsoid with DJI's RTK fix (RtkFlag 50). A card mixing
    // the two holds heights tens of metres apart for the same place: refused, not fitted.
    int fixed = 0;
    for (int i = 0; i < n; ++i)
      if (exif[i].lat_deg && exif[i].dji && exif[i].dji->rtk_flag == 50) ++fixed;
    if (fixed > 0 && fixed < with_gps)
      throw InputError("--gps exif: " + std::to_string(fixed) + " of " + std::to_string(with_gps) +
                       " photos have a DJI RTK fix (heights above the WGS84 ellipsoid) and the "
                       "others not (above EGM96 sea level): reconstruct them apart, or give "
                       "their positions in one datum (--gps poses.json)");
    gps->alt_datum = fixed > 0 ? "ellipsoid" : "egm96";
  }

  // Pairs to match (KLT: the consecutive images it tracked; else sfm::SelectPairs).
  std::vector<std::pair<int, int>> pair_list;
  std::string pairing = "sequential (KLT tracks)";
  if (klt) {
    for (int i = 0; i + 1 < n; ++i) pair_list.push_back({i, i + 1});
  } else {
    // exhaustive: every pair, as for a small unlocated set (no positions given);
    // sequential: the next `window` images only; auto: SelectPairs' choice.
    sfm::PairingOptions po;
    po.sequence_window =
        matching == Matching::kSequential ? window : std::min(window, po.sequence_window);
    po.spatial_neighbours = matching == Matching::kSequential ? 0 : neighbours;
    po.exhaustive_up_to = matching == Matching::kExhaustive ? n
                          : matching == Matching::kSequential || matching == Matching::kRetrieval
                              ? 0
                              : po.exhaustive_up_to;
    std::vector<std::optional<Eigen::Vector3d>> positions(n);
    if (gps && matching == Matching::kAuto) {
      for (int i = 0; i < n; ++i) {
        auto g = gps->enu_m.find(files[i]);
        if (g != gps->enu_m.end()) positions[i] = g->second;
      }
    }
    // Images without a position in a set too large for every pair are paired by
    // appearance too (sfm/retrieval), as are all images with --matching retrieval (no
    // positions, no exhaustive set); never with sequential or exhaustive matching.
    po.retrieval_neighbours =
        matching == Matching::kSequential || matching == Matching::kExhaustive ? 0 : neighbours;
    std::optional<std::vector<std::vector<int>>> similar;
    if (sfm::PairsByAppearance(positions, po)) {
      const auto tr = Clock::now();
      similar = sfm::MostSimilar(sfm::GlobalDescriptors(features), neighbours);
      timings["retrieval_s"] = Since(tr);
    }
    const sfm::PairSelection sel = sfm::SelectPairs(positions, po, similar ? &*similar : nullptr);
    pair_list = sel.pairs;
    pairing = sel.method;
  }

  t0 = Clock::now();
  const double verify_px = std::max(1.0, 1.0 * std::max(W, H) / 2000.0);
  std::vector<sfm::VerifiedPair> verified(pair_list.size());
  std::vector<size_t> putative(pair_list.size());
  const sfm::DescriptorMatcher matcher(features, 0.8f, o.matcher);
  ParallelFor(static_cast<int>(pair_list.size()), threads, [&](int k) {
    const auto [i, j] = pair_list[k];
    const sfm::MatchList m = klt ? tracked[i] : matcher.Match(i, j);
    putative[k] = m.size();
    verified[k] = sfm::VerifyPair(i, j, features[i], features[j], m, camera, verify_px, seed + k);
  });
  timings["matching_s"] = Since(t0);
  int useful_pairs = 0;
  size_t matches_putative = 0, matches_verified = 0;
  for (size_t k = 0; k < verified.size(); ++k) {
    useful_pairs += verified[k].inliers.size() >= 30;
    matches_putative += putative[k];
    matches_verified += verified[k].inliers.size();
  }

  nlohmann::json doc = {{"schema", "mound.recon"},
                        {"version", 1},
                        {"tool", o.tool},
                        {"images_dir", dir},
                        {"status", "ok"}};
  doc["inputs"] = {{"images", n},
                   {"camera_source", camera_source},
                   {"lens", NameOf(lens, kLensNames)},
                   {"gps_source", gps ? gps->source : "none"},
                   {"pairs_matched", pair_list.size()},
                   {"pairs_verified", useful_pairs},
                   {"matches_putative", matches_putative},
                   {"matches_verified", matches_verified},
                   {"pairing", pairing},
                   {"max_image_size", fo.max_image_size},
                   {"max_features", fo.max_features},
                   {"contrast_threshold", fo.contrast_threshold},
                   {"features", NameOf(o.feature_kind, kFeatureKindNames)},
                   {"matcher", NameOf(o.matcher, kMatcherNames)}};
  if (o.camera_file.empty()) {
    // Where the starting focal length came from (recon.json's inputs.focal).
    doc["inputs"]["focal"] =
        focal ? nlohmann::json{{"px", focal->px},
                               {"source", focal->source},
                               {"prior_rel_sd", lens == Lens::kPrior ? focal->rel_sd : 0.0},
                               {"detail", focal->detail}}
              : nlohmann::json{{"px", camera.fx},
                               {"source", "default"},
                               {"prior_rel_sd", lens == Lens::kPrior ? 0.01 : 0.0},
                               {"detail", "no focal length in EXIF: 1.2 x the longer side"}};
  }
  sfm::MapperOptions mo;
  mo.max_error_px = 4.0;  // COLMAP's filter threshold, full-resolution pixels
  mo.refine_intrinsics = lens != Lens::kFixed;
  if (lens == Lens::kPrior) {
    // as sure as its source: 0.5 % (DJI's calibration) ... 5 % (the 35 mm equivalent)
    mo.focal_prior_sd = focal ? focal->rel_sd : 0.01;
    mo.distortion_prior_sd = 0.01;
  }
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
    res.doc = std::move(doc);
    return res;
  }
  timings["mapping_s"] = Since(t0);
  nlohmann::json mapping_stages = {{"initialise", r.timings.initialise_s},
                                   {"register", r.timings.register_s},
                                   {"triangulate", r.timings.triangulate_s},
                                   {"local_ba", r.timings.local_ba_s},
                                   {"global_ba", r.timings.global_ba_s}};

  // The metric frame: a robust similarity from the camera centres to GPS.
  doc["frame"] = "arbitrary";
  doc["scale"] = "unknown";
  if (gps) {
    std::vector<Eigen::Vector3d> model, world;
    std::vector<double> weights;  // the GPS positions' 1 / variance, where every one has it
    std::vector<int> which;
    for (int i = 0; i < n; ++i) {
      auto g = gps->enu_m.find(files[i]);
      if (!r.registered[i] || g == gps->enu_m.end()) continue;
      model.push_back(r.cam_from_world[i].Centre());
      world.push_back(g->second);
      which.push_back(i);
      const auto w = gps_weight.find(files[i]);
      if (w != gps_weight.end()) weights.push_back(w->second);
    }
    // Consumer GPS heights drift (Caliterra's climb 80 m during the flight): by default
    // with EXIF GPS the vertical comes from the images (FitLevelledSim3Robust), with a
    // poses file from all three GPS coordinates; --align chooses.
    Eigen::Vector3d down_in_model = Eigen::Vector3d::Zero();
    for (int i = 0; i < n; ++i)
      if (r.registered[i])
        down_in_model += r.cam_from_world[i].rotation.conjugate() * Eigen::Vector3d::UnitZ();
    const bool weighted = !weights.empty() && weights.size() == model.size();
    auto fit_to = [&](const std::vector<Eigen::Vector3d>& w) {
      return align == Align::kLevel
                 ? sfm::FitLevelledSim3Robust(model, w, down_in_model, seed)
                 : sfm::FitSim3Robust(model, w, seed, 0.5, weighted ? &weights : nullptr);
    };
    auto fit = fit_to(world);
    // GNSS latency, for positions from the photos' EXIF (see GpsSteps): the capture order
    // from EXIF's time where every fitted photo has one, else the file names' order.
    nlohmann::json latency_doc;
    std::vector<Eigen::Vector3d> step;
    if (gps->source == "exif" && fit && model.size() >= 6) {
      std::vector<double> key(which.size()), seconds;
      bool timed = true;
      for (size_t k = 0; k < which.size(); ++k) {
        const auto t = ExifSeconds(exif[which[k]].datetime);
        timed = timed && t.has_value();
        if (t) seconds.push_back(*t);
        key[k] = t ? *t * 1e4 + k : static_cast<double>(k);  // ties kept in name order
      }
      if (!timed)
        for (size_t k = 0; k < key.size(); ++k) key[k] = static_cast<double>(k);
      step = GpsSteps(world, key).step;
      // Each lambda scored by the same yardstick: the mean squared horizontal residual of
      // the best 80 % of the photos (the fits' own inlier thresholds adapt to their
      // residuals, so their inlier counts are not comparable from one lambda to the next).
      auto trimmed = [&](const sfm::GeoFit& f, const std::vector<Eigen::Vector3d>& w) {
        std::vector<double> r2;
        for (size_t k = 0; k < w.size(); ++k) {
          const Eigen::Vector3d e = f.world_from_model * model[k] - w[k];
          r2.push_back(e.x() * e.x() + e.y() * e.y());
        }
        std::sort(r2.begin(), r2.end());
        const size_t keep = std::max<size_t>(1, r2.size() * 4 / 5);
        double sum = 0;
        for (size_t k = 0; k < keep; ++k) sum += r2[k];
        return sum / keep;
      };
      double best_steps = 0, best_score = trimmed(*fit, world);
      auto best = fit;
      for (int j = -30; j <= 30; ++j) {
        if (j == 0) continue;
        std::vector<Eigen::Vector3d> w = world;
        for (size_t k = 0; k < w.size(); ++k) w[k] += j * 0.05 * step[k];
        auto f = fit_to(w);
        if (!f) continue;
        const double score = trimmed(*f, w);
        if (score < best_score) {
          best = f;
          best_score = score;
          best_steps = j * 0.05;
        }
      }
      // clearly better: two more photos explained, or the RMSE down by a fifth (one more
      // inlier or a few percent is what a photo's noise alone can buy)
      const bool clearer = best_steps != 0 &&
                           (best->inliers >= fit->inliers + 2 || best->rmse_m < 0.8 * fit->rmse_m);
      best_steps = std::round(best_steps * 100) / 100;
      std::vector<double> dt;
      if (timed) {
        std::sort(seconds.begin(), seconds.end());
        for (size_t k = 1; k < seconds.size(); ++k) dt.push_back(seconds[k] - seconds[k - 1]);
        std::nth_element(dt.begin(), dt.begin() + dt.size() / 2, dt.end());
      }
      latency_doc = {{"applied", clearer},
                     {"steps", clearer ? best_steps : 0.0},
                     {"best_steps", best_steps},
                     {"order", timed ? "EXIF capture time" : "file names"},
                     {"without", {{"inliers", fit->inliers}, {"rmse_m", fit->rmse_m}}},
                     {"with_best", {{"inliers", best->inliers}, {"rmse_m", best->rmse_m}}},
                     {"note",
                      "GPS positions moved by steps x each photo's own step (half the "
                      "displacement between its neighbours in capture order): GNSS latency"}};
      if (timed && !dt.empty()) {
        latency_doc["seconds"] = (clearer ? best_steps : 0.0) * dt[dt.size() / 2];
        latency_doc["photo_interval_s"] = dt[dt.size() / 2];
      }
      if (clearer) {
        for (size_t k = 0; k < world.size(); ++k) world[k] += best_steps * step[k];
        fit = best;
      }
    }
    if (fit && fit->inliers >= 3) {
      sfm::Transform(fit->world_from_model, &r);
      doc["frame"] = "enu";
      doc["scale"] = "metric";
      if (gps->origin)
        doc["origin"] = {{"lat", gps->origin->lat_deg},
                         {"lon", gps->origin->lon_deg},
                         {"alt_m", gps->origin->alt_m},
                         {"alt_datum", gps->alt_datum}};
      nlohmann::json outliers = nlohmann::json::array();
      nlohmann::json explained = nlohmann::json::array();
      for (size_t k = 0; k < which.size(); ++k) {
        if (fit->inlier[k]) continue;
        outliers.push_back(files[which[k]]);
        // each outlier's residual, along and across the flight where its step is known
        const Eigen::Vector3d e = fit->world_from_model * model[k] - world[k];
        nlohmann::json o = {
            {"file", files[which[k]]}, {"residual_m", e.norm()}, {"vertical_m", e.z()}};
        if (k < step.size() && step[k].norm() > 1e-6) {
          const Eigen::Vector3d u = step[k].normalized();
          o["along_track_m"] = e.dot(u);
          o["across_track_m"] = (Eigen::Vector3d(e.x(), e.y(), 0) - e.dot(u) * u).norm();
        }
        explained.push_back(o);
      }
      doc["gps_fit"] = {{"images", model.size()},
                        {"inliers", fit->inliers},
                        {"outliers", outliers},
                        {"outlier_residuals", explained},
                        {"rmse_m", fit->rmse_m},
                        {"rmse_horizontal_m", fit->rmse_horizontal_m},
                        {"rmse_vertical_m", fit->rmse_vertical_m},
                        {"scale", fit->world_from_model.scale},
                        {"rtk_fixed_images", rtk_fixed},
                        {"weighted_by_rtk_std", align == Align::kFull && weighted},
                        {"method", align == Align::kLevel
                                       ? "level: vertical from the images, heading, scale and "
                                         "position from horizontal GPS, height offset by median"
                                       : "full: 7-parameter similarity to the GPS positions"}};
      if (!latency_doc.is_null()) doc["gps_fit"]["latency"] = latency_doc;
    } else {
      doc["gps_fit"] = {{"images", model.size()},
                        {"note", "fewer than 3 registered images with GPS: frame left arbitrary"}};
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
  doc["timings_s"] = timings;
  doc["mapping_timings_s"] = mapping_stages;
  res.doc = std::move(doc);
  res.model = std::move(r);
  return res;
}

}  // namespace mound::recon
