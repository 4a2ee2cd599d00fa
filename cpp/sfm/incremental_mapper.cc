#include "sfm/incremental_mapper.h"

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <optional>

#include "ba/bundle_adjuster.h"
#include "common/error.h"
#include "sfm/tracks.h"
#include "sfm/two_view.h"

namespace mound::sfm {

namespace {

constexpr double kDeg = M_PI / 180;

// Adds the seconds of its lifetime to `*sum`.
class ScopedTimer {
 public:
  explicit ScopedTimer(double* sum) : sum_(sum), t0_(std::chrono::steady_clock::now()) {}
  ~ScopedTimer() {
    *sum_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
  }
  ScopedTimer(const ScopedTimer&) = delete;
  ScopedTimer& operator=(const ScopedTimer&) = delete;

 private:
  double* sum_;
  std::chrono::steady_clock::time_point t0_;
};

// Angle between two directions, radians.
double Angle(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0));
}

class Mapper {
 public:
  Mapper(const std::vector<ImageFeatures>& f, const std::vector<VerifiedPair>& pairs,
         const geometry::CameraModel& camera, const MapperOptions& o)
      : f_(f), pairs_(pairs), o_(o), prior_(camera) {
    const int n = static_cast<int>(f.size());
    r_.camera = camera;
    r_.registered.assign(n, false);
    r_.cam_from_world.resize(n);
    r_.image_error_px.assign(n, 0);
    r_.image_points.assign(n, 0);
    std::vector<int> kps;
    for (const ImageFeatures& x : f) kps.push_back(static_cast<int>(x.keypoints.size()));
    tracks_ = BuildTracks(pairs, kps);
    track_of_.resize(n);
    for (int i = 0; i < n; ++i) track_of_[i].assign(kps[i], -1);
    for (size_t t = 0; t < tracks_.size(); ++t)
      for (const TrackElement& e : tracks_[t]) track_of_[e.image][e.keypoint] = static_cast<int>(t);
    point_of_track_.assign(tracks_.size(), -1);
  }

  Reconstruction Run() {
    {
      ScopedTimer timer(&r_.timings.initialise_s);
      Initialise();
    }
    std::vector<int> failures(f_.size(), 0);
    int next_ba = std::max(4, r_.NumRegistered() + 1);
    while (true) {
      const int image = NextImage(failures);
      if (image < 0) break;
      bool ok;
      {
        ScopedTimer timer(&r_.timings.register_s);
        ok = Register(image);
      }
      if (!ok) {
        ++failures[image];
        continue;
      }
      {
        ScopedTimer timer(&r_.timings.triangulate_s);
        Triangulate(image);
      }
      if (r_.NumRegistered() >= next_ba) {
        Adjust();
        next_ba = std::max(next_ba + 1,
                           static_cast<int>(std::ceil(r_.NumRegistered() * o_.global_ba_growth)));
        std::fill(failures.begin(), failures.end(), 0);  // a better model may register them
      } else {
        LocalAdjust(image);
      }
    }
    Adjust();
    {
      ScopedTimer timer(&r_.timings.triangulate_s);
      for (size_t i = 0; i < f_.size(); ++i)
        if (r_.registered[i]) Triangulate(static_cast<int>(i));
    }
    Adjust(200);  // the last adjustment runs to convergence; the ones on the way stop at 50
    Finish();
    return std::move(r_);
  }

 private:
  Eigen::Vector3d Ray(int image, int kp) const {
    const Eigen::Vector2d xy = r_.camera.NormalisedFromImage(f_[image].keypoints[kp]);
    return Eigen::Vector3d(xy.x(), xy.y(), 1.0);
  }
  double ErrorPx(const Point3D& p, const TrackElement& e) const {
    Eigen::Vector2d uv;
    if (!r_.camera.ImageFromCamera(r_.cam_from_world[e.image] * p.xyz, &uv)) return 1e9;
    return (uv - f_[e.image].keypoints[e.keypoint]).norm();
  }

  void Initialise() {
    std::vector<const VerifiedPair*> cand;
    for (const VerifiedPair& p : pairs_)
      if (static_cast<int>(p.inliers.size()) >= o_.min_inliers) cand.push_back(&p);
    std::sort(cand.begin(), cand.end(), [](const VerifiedPair* a, const VerifiedPair* b) {
      return a->inliers.size() > b->inliers.size();
    });
    int best_score = 0;
    TwoViewResult best;
    const VerifiedPair* best_pair = nullptr;
    Matches best_m;
    int tried = 0;
    for (const VerifiedPair* p : cand) {
      if (tried >= 30) break;
      // A pair's score counts some of its inliers, and the candidates come by inlier count:
      // none of the rest can beat the best so far.
      if (static_cast<int>(p->inliers.size()) <= best_score) break;
      // A pair a homography explains (planar scene or pure rotation) has little parallax.
      if (p->homography_inliers > 0.95 * p->inliers.size() &&
          tried + 1 < static_cast<int>(cand.size()))
        continue;
      ++tried;
      Matches m;
      for (const auto& [a, b] : p->inliers) {
        m.px1.push_back(f_[p->image1].keypoints[a]);
        m.px2.push_back(f_[p->image2].keypoints[b]);
      }
      TwoViewResult tv;
      try {
        tv = InitialiseTwoView(m, r_.camera, o_.max_error_px / 2, o_.seed);
        RefineTwoView(m, r_.camera, &tv);
      } catch (const NoResultError&) {
        continue;
      }
      // Score: inliers triangulated in front of both cameras with enough parallax.
      const Eigen::Vector3d c2 = tv.cam2_from_cam1.Centre();
      const std::vector<Eigen::Vector3d> x1 = Normalise(
          [&] {
            std::vector<Eigen::Vector2d> px;
            for (int i : tv.inliers) px.push_back(m.px1[i]);
            return px;
          }(),
          r_.camera);
      int score = 0;
      for (size_t k = 0; k < tv.inliers.size(); ++k) {
        if (!(tv.depth1[k] > 0 && tv.depth2[k] > 0)) continue;
        const Eigen::Vector3d X = tv.depth1[k] * x1[k];
        const double angle = Angle(X, X - c2);
        if (angle >= o_.min_tri_angle_deg * kDeg) ++score;
      }
      if (score > best_score) {
        best_score = score;
        best = tv;
        best_pair = p;
        best_m = m;
      }
    }
    if (best_pair == nullptr || best_score < o_.min_inliers) {
      throw NoResultError("no image pair with enough matches and parallax to start from (" +
                          std::to_string(cand.size()) +
                          " pairs with >= " + std::to_string(o_.min_inliers) +
                          " verified matches; best had " + std::to_string(best_score) +
                          " points at >= " + FormatAngle(o_.min_tri_angle_deg) +
                          " deg): too little motion or texture?");
    }
    r_.init_image1 = best_pair->image1;
    r_.init_image2 = best_pair->image2;
    r_.registered[best_pair->image1] = r_.registered[best_pair->image2] = true;
    r_.cam_from_world[best_pair->image1] = geometry::Rigid3d();
    r_.cam_from_world[best_pair->image2] = best.cam2_from_cam1;
    Triangulate(best_pair->image2);
  }

  static std::string FormatAngle(double d) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.1f", d);
    return buf;
  }

  int NextImage(const std::vector<int>& failures) const {
    int best = -1, best_count = o_.min_pnp_inliers - 1;
    for (size_t i = 0; i < f_.size(); ++i) {
      if (r_.registered[i] || failures[i] >= 2) continue;
      int count = 0;
      for (int t : track_of_[i])
        if (t >= 0 && point_of_track_[t] >= 0) ++count;
      if (count > best_count) {
        best_count = count;
        best = static_cast<int>(i);
      }
    }
    return best;
  }

  bool Register(int image) {
    std::vector<cv::Point3d> obj;
    std::vector<cv::Point2d> img;
    std::vector<int> point_ids, kp_ids;
    for (size_t k = 0; k < track_of_[image].size(); ++k) {
      const int t = track_of_[image][k];
      if (t < 0 || point_of_track_[t] < 0) continue;
      const Eigen::Vector3d& X = r_.points[point_of_track_[t]].xyz;
      obj.emplace_back(X.x(), X.y(), X.z());
      img.emplace_back(f_[image].keypoints[k].x(), f_[image].keypoints[k].y());
      point_ids.push_back(point_of_track_[t]);
      kp_ids.push_back(static_cast<int>(k));
    }
    if (static_cast<int>(obj.size()) < o_.min_pnp_inliers) return false;
    const cv::Matx33d K(r_.camera.fx, 0, r_.camera.cx, 0, r_.camera.fy, r_.camera.cy, 0, 0, 1);
    const std::vector<double> dist(r_.camera.dist.begin(), r_.camera.dist.end());
    cv::Mat rvec, tvec;
    std::vector<int> inliers;
    cv::theRNG() = cv::RNG(o_.seed + image);
    if (!cv::solvePnPRansac(obj, img, K, dist, rvec, tvec, false, 1000, o_.max_error_px, 0.9999,
                            inliers, cv::SOLVEPNP_EPNP) ||
        static_cast<int>(inliers.size()) < o_.min_pnp_inliers) {
      return false;
    }
    std::vector<cv::Point3d> obj_in;
    std::vector<cv::Point2d> img_in;
    for (int i : inliers) {
      obj_in.push_back(obj[i]);
      img_in.push_back(img[i]);
    }
    cv::solvePnPRefineLM(obj_in, img_in, K, dist, rvec, tvec);
    Eigen::Vector3d w(rvec.at<double>(0), rvec.at<double>(1), rvec.at<double>(2));
    const Eigen::Quaterniond q =
        w.norm() > 0 ? Eigen::Quaterniond(Eigen::AngleAxisd(w.norm(), w.normalized()))
                     : Eigen::Quaterniond::Identity();
    r_.cam_from_world[image] = {
        q, Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2))};
    r_.registered[image] = true;
    for (int i : inliers) {
      Point3D& p = r_.points[point_ids[i]];
      const TrackElement e{image, kp_ids[i]};
      if (ErrorPx(p, e) <= o_.max_error_px) p.track.push_back(e);
    }
    return true;
  }

  // Triangulates every track that `image` sees and that has no point yet, from the two
  // registered rays with the widest angle; keeps the observations that reproject.
  void Triangulate(int image) {
    for (size_t k = 0; k < track_of_[image].size(); ++k) {
      const int t = track_of_[image][k];
      if (t < 0) continue;
      if (point_of_track_[t] >= 0) {
        // Continue an existing point into this image when it agrees.
        Point3D& p = r_.points[point_of_track_[t]];
        const TrackElement e{image, static_cast<int>(k)};
        bool present = false;
        for (const TrackElement& x : p.track) present |= x.image == image;
        if (!present && ErrorPx(p, e) <= o_.max_error_px) p.track.push_back(e);
        continue;
      }
      std::vector<TrackElement> obs;
      for (const TrackElement& e : tracks_[t])
        if (r_.registered[e.image]) obs.push_back(e);
      if (obs.size() < 2) continue;
      // Widest pair of rays (world directions).
      double best_angle = 0;
      int ia = -1, ib = -1;
      std::vector<Eigen::Vector3d> dirs, centres;
      for (const TrackElement& e : obs) {
        dirs.push_back((r_.cam_from_world[e.image].rotation.conjugate() * Ray(e.image, e.keypoint))
                           .normalized());
        centres.push_back(r_.cam_from_world[e.image].Centre());
      }
      for (size_t a = 0; a < obs.size(); ++a)
        for (size_t b = a + 1; b < obs.size(); ++b) {
          const double ang = Angle(dirs[a], dirs[b]);
          if (ang > best_angle) {
            best_angle = ang;
            ia = static_cast<int>(a);
            ib = static_cast<int>(b);
          }
        }
      if (ia < 0 || best_angle < o_.min_tri_angle_deg * kDeg) continue;
      const std::optional<Eigen::Vector3d> X = TriangulateDlt(obs[ia], obs[ib]);
      if (!X) continue;
      Point3D p;
      p.xyz = *X;
      // The triangulation angle at the point itself must be wide enough too.
      const double at_point = Angle(centres[ia] - *X, centres[ib] - *X);
      if (at_point < o_.min_tri_angle_deg * kDeg) continue;
      for (const TrackElement& e : obs)
        if (ErrorPx(p, e) <= o_.max_error_px) p.track.push_back(e);
      if (p.track.size() < 2) continue;
      const TrackElement& c = p.track.front();
      p.color = f_[c.image].colors[c.keypoint];
      point_of_track_[t] = static_cast<int>(r_.points.size());
      track_id_.push_back(t);
      r_.points.push_back(std::move(p));
    }
  }

  std::optional<Eigen::Vector3d> TriangulateDlt(const TrackElement& a,
                                                const TrackElement& b) const {
    const Eigen::Vector3d x1 = Ray(a.image, a.keypoint), x2 = Ray(b.image, b.keypoint);
    Eigen::Matrix<double, 3, 4> P1, P2;
    P1 << r_.cam_from_world[a.image].RotationMatrix(), r_.cam_from_world[a.image].translation;
    P2 << r_.cam_from_world[b.image].RotationMatrix(), r_.cam_from_world[b.image].translation;
    Eigen::Matrix4d A;
    A.row(0) = x1.x() * P1.row(2) - P1.row(0);
    A.row(1) = x1.y() * P1.row(2) - P1.row(1);
    A.row(2) = x2.x() * P2.row(2) - P2.row(0);
    A.row(3) = x2.y() * P2.row(2) - P2.row(1);
    const Eigen::Vector4d h =
        Eigen::JacobiSVD<Eigen::Matrix4d>(A, Eigen::ComputeFullV).matrixV().col(3);
    if (std::fabs(h[3]) < 1e-12) return std::nullopt;
    const Eigen::Vector3d X = h.head<3>() / h[3];
    if ((r_.cam_from_world[a.image] * X).z() <= 0 || (r_.cam_from_world[b.image] * X).z() <= 0)
      return std::nullopt;
    return X;
  }

  // Bundle adjustment of `image` and the images sharing the most points with it, over the
  // points they see; every other registered image that sees those points is held
  // constant (and fixes the gauge). Skipped while fewer than two images would be held.
  void LocalAdjust(int image) {
    if (o_.local_ba_images <= 0) return;
    ScopedTimer timer(&r_.timings.local_ba_s);
    std::vector<int> shared(f_.size(), 0);
    for (const Point3D& p : r_.points) {
      bool sees = false;
      for (const TrackElement& e : p.track) sees |= e.image == image;
      if (!sees) continue;
      for (const TrackElement& e : p.track)
        if (e.image != image) ++shared[e.image];
    }
    std::vector<int> others;
    for (size_t i = 0; i < f_.size(); ++i)
      if (shared[i] > 0) others.push_back(static_cast<int>(i));
    std::sort(others.begin(), others.end(),
              [&](int a, int b) { return shared[a] != shared[b] ? shared[a] > shared[b] : a < b; });
    if (static_cast<int>(others.size()) > o_.local_ba_images) others.resize(o_.local_ba_images);
    std::vector<bool> local(f_.size(), false);
    local[image] = true;
    for (int i : others) local[i] = true;

    Subproblem sp = Build(local);
    if (sp.constant_views.size() < 2) return;
    ba::Options bo;
    bo.fixed_view = -1;
    bo.scale_view = -1;
    bo.max_iterations = o_.local_ba_iterations;
    bo.function_tolerance = 1e-6;
    Solve(&sp, bo);
    ++r_.local_ba_runs;
  }

  void Adjust(int max_iterations = 50) {
    ScopedTimer timer(&r_.timings.global_ba_s);
    Subproblem sp = Build(r_.registered);
    ba::Options bo;
    bo.fixed_view = sp.view_of[r_.init_image1];
    bo.scale_view = sp.view_of[r_.init_image2];
    bo.max_iterations = max_iterations;
    // 1e-6 for the last one too: with the intrinsics refined, 1e-7 took Caliterra's last
    // adjustment from 40 to 90 iterations (4.3 instead of 1.9 s) for a cost 0.002 % lower
    // and a focal length 0.03 px apart; with a known camera it changed nothing.
    bo.function_tolerance = 1e-6;
    bo.refine_intrinsics = o_.refine_intrinsics && r_.NumRegistered() >= 3;
    if (bo.refine_intrinsics && o_.focal_prior_sd > 0 && o_.distortion_prior_sd > 0) {
      // about the starting (EXIF) camera, not the last adjustment's: the prior does not drift
      bo.intrinsics_prior = ba::IntrinsicsPrior{prior_.fx, prior_.dist[0], prior_.dist[1],
                                                o_.focal_prior_sd, o_.distortion_prior_sd};
    }
    Solve(&sp, bo);
    ++r_.ba_runs;
  }

  // A bundle-adjustment problem: the images marked `free` are its variable views (in image
  // order), the points any of them sees its points, and every other image observing those
  // points joins as a constant view (a local adjustment's fixed surroundings).
  struct Subproblem {
    ba::Problem problem;
    std::vector<int> view_of, image_of, point_ids, constant_views;
    std::vector<bool> free;
  };

  Subproblem Build(const std::vector<bool>& free) const {
    Subproblem sp;
    sp.free = free;
    sp.problem.camera = r_.camera;
    sp.view_of.assign(f_.size(), -1);
    auto view = [&](int i) {
      if (sp.view_of[i] < 0) {
        sp.view_of[i] = static_cast<int>(sp.problem.cam_from_world.size());
        sp.image_of.push_back(i);
        sp.problem.cam_from_world.push_back(r_.cam_from_world[i]);
        if (!free[i]) sp.constant_views.push_back(sp.view_of[i]);
      }
      return sp.view_of[i];
    };
    for (size_t i = 0; i < f_.size(); ++i)
      if (free[i]) view(static_cast<int>(i));
    for (size_t j = 0; j < r_.points.size(); ++j) {
      bool in = false;
      for (const TrackElement& e : r_.points[j].track) in |= free[e.image];
      if (!in) continue;
      const int id = static_cast<int>(sp.problem.points.size());
      sp.point_ids.push_back(static_cast<int>(j));
      sp.problem.points.push_back(r_.points[j].xyz);
      for (const TrackElement& e : r_.points[j].track)
        sp.problem.observations.push_back({view(e.image), id, f_[e.image].keypoints[e.keypoint]});
    }
    return sp;
  }

  // Adjusts (Huber 1 px, the mapper's threads) and writes the free views, the points and
  // the camera (changed only when refine_intrinsics) back; then filters.
  void Solve(Subproblem* sp, ba::Options bo) {
    bo.constant_views = sp->constant_views;
    bo.threads = o_.threads;
    bo.huber_px = 1.0;
    ba::Adjust(&sp->problem, bo);
    r_.camera = sp->problem.camera;
    for (size_t v = 0; v < sp->image_of.size(); ++v)
      if (sp->free[sp->image_of[v]])
        r_.cam_from_world[sp->image_of[v]] = sp->problem.cam_from_world[v];
    for (size_t k = 0; k < sp->point_ids.size(); ++k)
      r_.points[sp->point_ids[k]].xyz = sp->problem.points[k];
    Filter();
  }

  // Drops observations that no longer reproject and points left with fewer than two
  // observations or too little parallax.
  void Filter() {
    std::vector<Point3D> kept;
    std::vector<int> kept_track;
    std::fill(point_of_track_.begin(), point_of_track_.end(), -1);
    for (size_t j = 0; j < r_.points.size(); ++j) {
      Point3D& p = r_.points[j];
      std::vector<TrackElement> good;
      for (const TrackElement& e : p.track)
        if (ErrorPx(p, e) <= o_.max_error_px) good.push_back(e);
      if (good.size() < 2) continue;
      double widest = 0;
      for (size_t a = 0; a < good.size() && widest < o_.min_tri_angle_deg * kDeg; ++a)
        for (size_t b = a + 1; b < good.size(); ++b) {
          widest = std::max(widest, Angle(r_.cam_from_world[good[a].image].Centre() - p.xyz,
                                          r_.cam_from_world[good[b].image].Centre() - p.xyz));
        }
      if (widest < o_.min_tri_angle_deg * kDeg) continue;
      p.track = std::move(good);
      point_of_track_[track_id_[j]] = static_cast<int>(kept.size());
      kept_track.push_back(track_id_[j]);
      kept.push_back(std::move(p));
    }
    r_.points = std::move(kept);
    track_id_ = std::move(kept_track);
  }

  void Finish() {
    std::vector<double> sum(f_.size(), 0);
    std::vector<int> count(f_.size(), 0);
    double total = 0;
    long n = 0;
    for (Point3D& p : r_.points) {
      double s = 0;
      for (const TrackElement& e : p.track) {
        const double err = ErrorPx(p, e);
        s += err;
        sum[e.image] += err;
        ++count[e.image];
        total += err * err;
        ++n;
      }
      p.error_px = s / p.track.size();
    }
    for (size_t i = 0; i < f_.size(); ++i) {
      r_.image_points[i] = count[i];
      r_.image_error_px[i] = count[i] ? sum[i] / count[i] : 0;
    }
    r_.rmse_px = n ? std::sqrt(total / n) : 0;
  }

  const std::vector<ImageFeatures>& f_;
  const std::vector<VerifiedPair>& pairs_;
  MapperOptions o_;
  geometry::CameraModel prior_;  // the starting camera: the intrinsics prior's mean
  Reconstruction r_;
  std::vector<std::vector<TrackElement>> tracks_;
  std::vector<std::vector<int>> track_of_;  // per image, per keypoint
  std::vector<int> point_of_track_;
  std::vector<int> track_id_;  // per point
};

}  // namespace

Reconstruction IncrementalMap(const std::vector<ImageFeatures>& features,
                              const std::vector<VerifiedPair>& pairs,
                              const geometry::CameraModel& camera, const MapperOptions& options) {
  return Mapper(features, pairs, camera, options).Run();
}

}  // namespace mound::sfm
