#include "recon/reconstruct.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
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

namespace {

// Stage 1: the features of every image (SIFT per image, or KLT tracks with their matches
// of consecutive images), one camera size for all.
struct FeatureStage {
  std::vector<sfm::MatchList> tracked;  // KLT: matches of consecutive images
};

FeatureStage ExtractAll(const ReconstructOptions& o, const std::vector<std::string>& files,
                        std::vector<sfm::ImageFeatures>* features) {
  const std::string& dir = o.images_dir;
  const int n = static_cast<int>(files.size());
  FeatureStage out;
  features->resize(n);
  if (o.feature_kind == FeatureKind::kKlt) {
    std::vector<std::string> paths;
    for (const std::string& f : files) paths.push_back(dir + "/" + f);
    sfm::KltResult k = sfm::TrackKlt(paths, o.features);
    *features = std::move(k.features);
    out.tracked = std::move(k.consecutive);
  } else {
    // One image per thread, and OpenCV's SIFT loops inside it single-threaded: --threads N
    // uses N cores (two sites on two cores do not oversubscribe them).
    sfm::SetLibraryThreads(1);
    ParallelFor(n, o.threads, [&](int i) {
      (*features)[i] = sfm::ExtractFeatures(dir + "/" + files[i], o.features);
    });
    sfm::SetLibraryThreads(o.threads);
  }
  const auto& f = *features;
  for (int i = 1; i < n; ++i) {
    if (f[i].width != f[0].width || f[i].height != f[0].height) {
      throw InputError(files[i] + ": " + std::to_string(f[i].width) + "x" +
                       std::to_string(f[i].height) + " pixels, but " + files[0] + " is " +
                       std::to_string(f[0].width) + "x" + std::to_string(f[0].height) +
                       " (one camera for all images)");
    }
  }
  return out;
}

// Stage 2: the camera: a file (calibrated, fixed), or EXIF (--lens: refined in bundle
// adjustment about EXIF's values by default); the photos' EXIF where it is needed.
struct CameraStage {
  geometry::CameraModel camera;
  std::string source;
  std::optional<FocalPrior> focal;  // EXIF's focal length, where it came from, its prior
  std::vector<Exif> exif;
  Lens lens = Lens::kPrior;
};

CameraStage SetUpCamera(const ReconstructOptions& o, const std::vector<std::string>& files, int W,
                        int H) {
  const int n = static_cast<int>(files.size());
  CameraStage c;
  c.exif.resize(n);
  if (o.gps == GpsSource::kExif || o.camera_file.empty()) {
    for (int i = 0; i < n; ++i) c.exif[i] = ReadExif(o.images_dir + "/" + files[i]);
  }
  if (!o.camera_file.empty()) {
    c.camera = ReadCamera(o.camera_file, W, H);
    c.source = "file";
  } else {
    c.camera.width = W;
    c.camera.height = H;
    c.camera.cx = (W - 1) / 2.0;
    c.camera.cy = (H - 1) / 2.0;
    c.focal = FocalFromExif(c.exif[0], W);
    c.source = c.focal ? "exif (" + c.focal->source + ")" : "default (1.2 x the longer side)";
    c.camera.fx = c.camera.fy = c.focal ? c.focal->px : 1.2 * std::max(W, H);
  }
  // Check() refuses prior and free with a camera file
  c.lens = o.lens.value_or(o.camera_file.empty() ? Lens::kPrior : Lens::kFixed);
  return c;
}

// Stage 3 (--gps exif): the photos' positions from EXIF, their RTK weights and datum.
struct ExifGps {
  GpsPositions gps;
  int rtk_fixed = 0;     // photos with an RTK fix (DJI XMP)
  bool all_rtk = false;  // every photo with GPS has a fix with a height sd within 0.1 m
  // 1 / the variance of each photo's RTK position (DJI XMP RtkStdLon/Lat/Hgt), by file
  std::map<std::string, double> weight;
};

ExifGps GpsFromExif(const std::string& dir, const std::vector<std::string>& files,
                    const std::vector<Exif>& exif) {
  const int n = static_cast<int>(files.size());
  ExifGps out;
  GpsPositions& g = out.gps;
  g.source = "exif";
  for (int i = 0; i < n; ++i) {
    if (!exif[i].lat_deg) continue;
    const geometry::Geodetic here{*exif[i].lat_deg, *exif[i].lon_deg, exif[i].alt_m.value_or(0)};
    if (!g.origin) g.origin = here;
    g.enu_m[files[i]] = geometry::EnuFromGeodetic(*g.origin, here);
  }
  if (g.enu_m.empty()) throw InputError("--gps exif: no image in " + dir + " has EXIF GPS");
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
      out.weight[files[i]] = 1 / var;
    }
  }
  out.rtk_fixed = rtk;
  out.all_rtk = rtk > 0 && rtk == with_gps;
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
  g.alt_datum = fixed > 0 ? "ellipsoid" : "egm96";
  return out;
}

// Stage 4: the pairs to match (KLT: the consecutive images it tracked; else
// sfm::SelectPairs).
struct PairStage {
  std::vector<std::pair<int, int>> pairs;
  std::string method = "sequential (KLT tracks)";
};

PairStage SelectMatchPairs(const ReconstructOptions& o, const std::vector<std::string>& files,
                           const std::vector<sfm::ImageFeatures>& features,
                           const std::optional<GpsPositions>& gps, nlohmann::json* timings) {
  const int n = static_cast<int>(files.size());
  const Matching matching = o.matching;
  PairStage out;
  if (o.feature_kind == FeatureKind::kKlt) {
    for (int i = 0; i + 1 < n; ++i) out.pairs.push_back({i, i + 1});
    return out;
  }
  // exhaustive: every pair, as for a small unlocated set (no positions given);
  // sequential: the next `window` images only; auto: SelectPairs' choice.
  sfm::PairingOptions po;
  po.sequence_window =
      matching == Matching::kSequential ? o.window : std::min(o.window, po.sequence_window);
  po.spatial_neighbours = matching == Matching::kSequential ? 0 : o.neighbours;
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
      matching == Matching::kSequential || matching == Matching::kExhaustive ? 0 : o.neighbours;
  std::optional<std::vector<std::vector<int>>> similar;
  if (sfm::PairsByAppearance(positions, po)) {
    const auto tr = Clock::now();
    similar = sfm::MostSimilar(sfm::GlobalDescriptors(features), o.neighbours);
    (*timings)["retrieval_s"] = Since(tr);
  }
  const sfm::PairSelection sel = sfm::SelectPairs(positions, po, similar ? &*similar : nullptr);
  out.pairs = sel.pairs;
  out.method = sel.method;
  return out;
}

// Stage 5: matching and geometric verification of each pair.
struct MatchStage {
  std::vector<sfm::VerifiedPair> verified;
  int useful_pairs = 0;  // with at least 30 inliers
  size_t putative = 0, inliers = 0;
};

MatchStage MatchPairs(const ReconstructOptions& o, const std::vector<sfm::ImageFeatures>& features,
                      const FeatureStage& fs, const std::vector<std::pair<int, int>>& pairs,
                      const geometry::CameraModel& camera) {
  const bool klt = o.feature_kind == FeatureKind::kKlt;
  const double verify_px =
      std::max(1.0, 1.0 * std::max(features[0].width, features[0].height) / 2000.0);
  MatchStage out;
  out.verified.resize(pairs.size());
  std::vector<size_t> putative(pairs.size());
  const sfm::DescriptorMatcher matcher(features, 0.8f, o.matcher);
  ParallelFor(static_cast<int>(pairs.size()), o.threads, [&](int k) {
    const auto [i, j] = pairs[k];
    const sfm::MatchList m = klt ? fs.tracked[i] : matcher.Match(i, j);
    putative[k] = m.size();
    out.verified[k] =
        sfm::VerifyPair(i, j, features[i], features[j], m, camera, verify_px, o.seed + k);
  });
  for (size_t k = 0; k < out.verified.size(); ++k) {
    out.useful_pairs += out.verified[k].inliers.size() >= 30;
    out.putative += putative[k];
    out.inliers += out.verified[k].inliers.size();
  }
  return out;
}

// recon.json's `inputs`: what the reconstruction was made from.
nlohmann::json InputsDoc(const ReconstructOptions& o, int n, const CameraStage& cam,
                         const std::optional<GpsPositions>& gps, const PairStage& ps,
                         const MatchStage& ms) {
  const sfm::FeatureOptions& fo = o.features;
  nlohmann::json inputs = {{"images", n},
                           {"camera_source", cam.source},
                           {"lens", NameOf(cam.lens, kLensNames)},
                           {"gps_source", gps ? gps->source : "none"},
                           {"pairs_matched", ps.pairs.size()},
                           {"pairs_verified", ms.useful_pairs},
                           {"matches_putative", ms.putative},
                           {"matches_verified", ms.inliers},
                           {"pairing", ps.method},
                           {"max_image_size", fo.max_image_size},
                           {"max_features", fo.max_features},
                           {"contrast_threshold", fo.contrast_threshold},
                           {"features", NameOf(o.feature_kind, kFeatureKindNames)},
                           {"matcher", NameOf(o.matcher, kMatcherNames)}};
  if (o.camera_file.empty()) {
    // Where the starting focal length came from (recon.json's inputs.focal).
    const auto& focal = cam.focal;
    inputs["focal"] =
        focal ? nlohmann::json{{"px", focal->px},
                               {"source", focal->source},
                               {"prior_rel_sd", cam.lens == Lens::kPrior ? focal->rel_sd : 0.0},
                               {"detail", focal->detail}}
              : nlohmann::json{{"px", cam.camera.fx},
                               {"source", "default"},
                               {"prior_rel_sd", cam.lens == Lens::kPrior ? 0.01 : 0.0},
                               {"detail", "no focal length in EXIF: 1.2 x the longer side"}};
  }
  return inputs;
}

// Stage 6's options: the incremental mapper's, from the lens and its prior.
sfm::MapperOptions MapperOptionsFor(const ReconstructOptions& o, const CameraStage& cam) {
  sfm::MapperOptions mo;
  mo.max_error_px = 4.0;  // COLMAP's filter threshold, full-resolution pixels
  mo.refine_intrinsics = cam.lens != Lens::kFixed;
  if (cam.lens == Lens::kPrior) {
    // as sure as its source: 0.5 % (DJI's calibration) ... 5 % (the 35 mm equivalent)
    mo.focal_prior_sd = cam.focal ? cam.focal->rel_sd : 0.01;
    mo.distortion_prior_sd = 0.01;
  }
  mo.threads = o.threads;
  mo.seed = o.seed;
  return mo;
}

// The registered cameras' centres (model) against their GPS positions (world).
struct GpsPairs {
  std::vector<Eigen::Vector3d> model, world;
  std::vector<double> weights;  // the GPS positions' 1 / variance, where every one has it
  std::vector<int> which;       // the image of each pair
  bool weighted = false;
};

GpsPairs PairWithGps(const sfm::Reconstruction& r, const std::vector<std::string>& files,
                     const GpsPositions& gps, const std::map<std::string, double>& gps_weight) {
  GpsPairs p;
  for (int i = 0; i < static_cast<int>(files.size()); ++i) {
    auto g = gps.enu_m.find(files[i]);
    if (!r.registered[i] || g == gps.enu_m.end()) continue;
    p.model.push_back(r.cam_from_world[i].Centre());
    p.world.push_back(g->second);
    p.which.push_back(i);
    const auto w = gps_weight.find(files[i]);
    if (w != gps_weight.end()) p.weights.push_back(w->second);
  }
  p.weighted = !p.weights.empty() && p.weights.size() == p.model.size();
  return p;
}

using FitTo = std::function<std::optional<sfm::GeoFit>(const std::vector<Eigen::Vector3d>&)>;

// GNSS latency, for positions from the photos' EXIF (see GpsSteps): the capture order
// from EXIF's time where every fitted photo has one, else the file names' order. Returns
// recon.json's gps_fit.latency; where a latency explains the GPS clearly better, `p->world`
// is moved by it and `fit` becomes its fit. `step`: each photo's own step.
nlohmann::json SearchLatency(GpsPairs* p, const std::vector<Exif>& exif, const FitTo& fit_to,
                             std::optional<sfm::GeoFit>* fit, std::vector<Eigen::Vector3d>* step) {
  const std::vector<Eigen::Vector3d>& model = p->model;
  std::vector<Eigen::Vector3d>& world = p->world;
  std::vector<double> key(p->which.size()), seconds;
  bool timed = true;
  for (size_t k = 0; k < p->which.size(); ++k) {
    const auto t = ExifSeconds(exif[p->which[k]].datetime);
    timed = timed && t.has_value();
    if (t) seconds.push_back(*t);
    key[k] = t ? *t * 1e4 + k : static_cast<double>(k);  // ties kept in name order
  }
  if (!timed)
    for (size_t k = 0; k < key.size(); ++k) key[k] = static_cast<double>(k);
  *step = GpsSteps(world, key).step;
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
  double best_steps = 0, best_score = trimmed(**fit, world);
  auto best = *fit;
  for (int j = -30; j <= 30; ++j) {
    if (j == 0) continue;
    std::vector<Eigen::Vector3d> w = world;
    for (size_t k = 0; k < w.size(); ++k) w[k] += j * 0.05 * (*step)[k];
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
  const auto& none = **fit;
  const bool clearer =
      best_steps != 0 && (best->inliers >= none.inliers + 2 || best->rmse_m < 0.8 * none.rmse_m);
  best_steps = std::round(best_steps * 100) / 100;
  std::vector<double> dt;
  if (timed) {
    std::sort(seconds.begin(), seconds.end());
    for (size_t k = 1; k < seconds.size(); ++k) dt.push_back(seconds[k] - seconds[k - 1]);
    std::nth_element(dt.begin(), dt.begin() + dt.size() / 2, dt.end());
  }
  nlohmann::json doc = {{"applied", clearer},
                        {"steps", clearer ? best_steps : 0.0},
                        {"best_steps", best_steps},
                        {"order", timed ? "EXIF capture time" : "file names"},
                        {"without", {{"inliers", none.inliers}, {"rmse_m", none.rmse_m}}},
                        {"with_best", {{"inliers", best->inliers}, {"rmse_m", best->rmse_m}}},
                        {"note",
                         "GPS positions moved by steps x each photo's own step (half the "
                         "displacement between its neighbours in capture order): GNSS latency"}};
  if (timed && !dt.empty()) {
    doc["seconds"] = (clearer ? best_steps : 0.0) * dt[dt.size() / 2];
    doc["photo_interval_s"] = dt[dt.size() / 2];
  }
  if (clearer) {
    for (size_t k = 0; k < world.size(); ++k) world[k] += best_steps * (*step)[k];
    *fit = best;
  }
  return doc;
}

// recon.json's gps_fit of an accepted fit: its residuals, the outliers and why.
nlohmann::json GpsFitDoc(const sfm::GeoFit& fit, const GpsPairs& p,
                         const std::vector<std::string>& files,
                         const std::vector<Eigen::Vector3d>& step, int rtk_fixed, Align align) {
  nlohmann::json outliers = nlohmann::json::array();
  nlohmann::json explained = nlohmann::json::array();
  for (size_t k = 0; k < p.which.size(); ++k) {
    if (fit.inlier[k]) continue;
    outliers.push_back(files[p.which[k]]);
    // each outlier's residual, along and across the flight where its step is known
    const Eigen::Vector3d e = fit.world_from_model * p.model[k] - p.world[k];
    nlohmann::json o = {
        {"file", files[p.which[k]]}, {"residual_m", e.norm()}, {"vertical_m", e.z()}};
    if (k < step.size() && step[k].norm() > 1e-6) {
      const Eigen::Vector3d u = step[k].normalized();
      o["along_track_m"] = e.dot(u);
      o["across_track_m"] = (Eigen::Vector3d(e.x(), e.y(), 0) - e.dot(u) * u).norm();
    }
    explained.push_back(o);
  }
  return {
      {"images", p.model.size()},
      {"inliers", fit.inliers},
      {"outliers", outliers},
      {"outlier_residuals", explained},
      {"rmse_m", fit.rmse_m},
      {"rmse_horizontal_m", fit.rmse_horizontal_m},
      {"rmse_vertical_m", fit.rmse_vertical_m},
      {"scale", fit.world_from_model.scale},
      {"rtk_fixed_images", rtk_fixed},
      {"weighted_by_rtk_std", align == Align::kFull && p.weighted},
      {"method", align == Align::kLevel ? "level: vertical from the images, heading, scale and "
                                          "position from horizontal GPS, height offset by median"
                                        : "full: 7-parameter similarity to the GPS positions"}};
}

// Stage 7: the metric frame: a robust similarity from the camera centres to GPS, applied
// to `r`; writes recon.json's frame, origin and gps_fit into `doc`.
void Georeference(const ReconstructOptions& o, const std::vector<std::string>& files,
                  const GpsPositions& gps, const std::vector<Exif>& exif, const ExifGps& eg,
                  Align align, sfm::Reconstruction* r, nlohmann::json* doc) {
  GpsPairs p = PairWithGps(*r, files, gps, eg.weight);
  // Consumer GPS heights drift (Caliterra's climb 80 m during the flight): by default
  // with EXIF GPS the vertical comes from the images (FitLevelledSim3Robust), with a
  // poses file from all three GPS coordinates; --align chooses.
  Eigen::Vector3d down_in_model = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < files.size(); ++i)
    if (r->registered[i])
      down_in_model += r->cam_from_world[i].rotation.conjugate() * Eigen::Vector3d::UnitZ();
  const FitTo fit_to = [&](const std::vector<Eigen::Vector3d>& w) {
    return align == Align::kLevel
               ? sfm::FitLevelledSim3Robust(p.model, w, down_in_model, o.seed)
               : sfm::FitSim3Robust(p.model, w, o.seed, 0.5, p.weighted ? &p.weights : nullptr);
  };
  auto fit = fit_to(p.world);
  nlohmann::json latency_doc;
  std::vector<Eigen::Vector3d> step;
  if (gps.source == "exif" && fit && p.model.size() >= 6)
    latency_doc = SearchLatency(&p, exif, fit_to, &fit, &step);
  if (!fit || fit->inliers < 3) {
    (*doc)["gps_fit"] = {{"images", p.model.size()},
                         {"note", "fewer than 3 registered images with GPS: frame left arbitrary"}};
    return;
  }
  sfm::Transform(fit->world_from_model, r);
  (*doc)["frame"] = "enu";
  (*doc)["scale"] = "metric";
  if (gps.origin)
    (*doc)["origin"] = {{"lat", gps.origin->lat_deg},
                        {"lon", gps.origin->lon_deg},
                        {"alt_m", gps.origin->alt_m},
                        {"alt_datum", gps.alt_datum}};
  (*doc)["gps_fit"] = GpsFitDoc(*fit, p, files, step, eg.rtk_fixed, align);
  if (!latency_doc.is_null()) (*doc)["gps_fit"]["latency"] = latency_doc;
}

// recon.json's camera, images and model figures.
void ModelDoc(const sfm::Reconstruction& r, const std::vector<std::string>& files,
              nlohmann::json* doc) {
  (*doc)["camera"] = CameraJson(r.camera);
  nlohmann::json images = nlohmann::json::array();
  for (size_t i = 0; i < files.size(); ++i) {
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
  (*doc)["images"] = images;
  (*doc)["registered"] = r.NumRegistered();
  (*doc)["points"] = r.points.size();
  (*doc)["reprojection_rmse_px"] = r.rmse_px;
  (*doc)["initial_pair"] = {files[r.init_image1], files[r.init_image2]};
  (*doc)["bundle_adjustments"] = {{"global", r.ba_runs}, {"local", r.local_ba_runs}};
}

}  // namespace

ReconstructResult Reconstruct(const ReconstructOptions& o) {
  o.Check();
  ReconstructResult res;
  res.files = ListImages(o.images_dir);
  const std::vector<std::string>& files = res.files;
  const int n = static_cast<int>(files.size());
  nlohmann::json timings = nlohmann::json::object();
  // GPS from a poses file is checked before any work.
  std::optional<GpsPositions> gps;
  if (o.gps == GpsSource::kPosesFile) gps = ReadGpsPoses(o.poses_file, files);

  auto t0 = Clock::now();
  const FeatureStage fs = ExtractAll(o, files, &res.features);
  timings["features_s"] = Since(t0);
  const CameraStage cam = SetUpCamera(o, files, res.features[0].width, res.features[0].height);
  Align align = o.align != Align::kAuto     ? o.align
                : o.gps == GpsSource::kExif ? Align::kLevel
                                            : Align::kFull;
  ExifGps eg;
  if (o.gps == GpsSource::kExif) {
    eg = GpsFromExif(o.images_dir, files, cam.exif);
    gps = eg.gps;
    if (o.align == Align::kAuto && eg.all_rtk) align = Align::kFull;
  }
  const PairStage ps = SelectMatchPairs(o, files, res.features, gps, &timings);
  t0 = Clock::now();
  const MatchStage ms = MatchPairs(o, res.features, fs, ps.pairs, cam.camera);
  timings["matching_s"] = Since(t0);

  nlohmann::json doc = {{"schema", "mound.recon"},
                        {"version", 1},
                        {"tool", o.tool},
                        {"images_dir", o.images_dir},
                        {"status", "ok"}};
  doc["inputs"] = InputsDoc(o, n, cam, gps, ps, ms);
  t0 = Clock::now();
  sfm::Reconstruction r;
  try {
    r = sfm::IncrementalMap(res.features, ms.verified, cam.camera, MapperOptionsFor(o, cam));
  } catch (const NoResultError& e) {
    timings["mapping_s"] = Since(t0);
    doc["status"] = "failed";
    doc["reason"] = e.what();
    doc["timings_s"] = timings;
    res.doc = std::move(doc);
    return res;
  }
  timings["mapping_s"] = Since(t0);
  const nlohmann::json mapping_stages = {{"initialise", r.timings.initialise_s},
                                         {"register", r.timings.register_s},
                                         {"triangulate", r.timings.triangulate_s},
                                         {"local_ba", r.timings.local_ba_s},
                                         {"global_ba", r.timings.global_ba_s}};
  doc["frame"] = "arbitrary";
  doc["scale"] = "unknown";
  if (gps) Georeference(o, files, *gps, cam.exif, eg, align, &r, &doc);
  ModelDoc(r, files, &doc);
  doc["timings_s"] = timings;
  doc["mapping_timings_s"] = mapping_stages;
  res.doc = std::move(doc);
  res.model = std::move(r);
  return res;
}

}  // namespace mound::recon
