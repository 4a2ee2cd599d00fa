#include "icp/icp.h"

#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/registration/correspondence_rejection_median_distance.h>
#include <pcl/registration/icp.h>
#include <pcl/registration/transformation_estimation_svd_scale.h>
#include <pcl/search/kdtree.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <functional>
#include <numeric>
#include <random>

#include "common/error.h"
#include "common/stats.h"
#include "geometry/rigid3.h"

namespace mound::icp {
namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;
using geometry::Sim3d;

Sim3d Shift(const Eigen::Vector3d& t) {
  Sim3d s;
  s.translation = t;
  return s;
}

Eigen::Matrix4f ToMatrix(const Sim3d& s) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = s.scale * s.rotation.toRotationMatrix();
  m.topRightCorner<3, 1>() = s.translation;
  return m.cast<float>();
}

Sim3d FromMatrix(const Eigen::Matrix4f& mf) {
  const Eigen::Matrix4d m = mf.cast<double>();
  const Eigen::Matrix3d a = m.topLeftCorner<3, 3>();
  Sim3d s;
  s.scale = std::cbrt(a.determinant());
  if (!(s.scale > 0) || !std::isfinite(s.scale))
    throw NoResultError("ICP degenerated (scale " + std::to_string(s.scale) + ")");
  // The nearest rotation to a / s (float round-off).
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(a / s.scale,
                                              Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d r = svd.matrixU() * svd.matrixV().transpose();
  if (r.determinant() < 0) r = -r;
  s.rotation = Eigen::Quaterniond(r).normalized();
  s.translation = m.topRightCorner<3, 1>();
  return s;
}

Cloud::Ptr ToPcl(const std::vector<Eigen::Vector3d>& p, const Eigen::Vector3d& offset,
                 const std::vector<int>& which) {
  Cloud::Ptr c(new Cloud);
  c->reserve(which.size());
  for (int i : which) {
    const Eigen::Vector3d q = p[i] - offset;
    c->push_back(pcl::PointXYZ(static_cast<float>(q.x()), static_cast<float>(q.y()),
                               static_cast<float>(q.z())));
  }
  return c;
}

std::vector<int> Sample(int n, int max_points, uint64_t seed) {
  std::vector<int> idx(n);
  std::iota(idx.begin(), idx.end(), 0);
  if (n > max_points) {
    std::mt19937_64 rng(seed);
    std::shuffle(idx.begin(), idx.end(), rng);
    idx.resize(max_points);
    std::sort(idx.begin(), idx.end());
  }
  return idx;
}

struct Stats {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  double rms_radius = 0;
};

Stats Moments(const std::vector<Eigen::Vector3d>& p) {
  Stats s;
  for (const auto& x : p) s.centroid += x;
  s.centroid /= static_cast<double>(p.size());
  for (const auto& x : p) s.cov += (x - s.centroid) * (x - s.centroid).transpose();
  s.cov /= static_cast<double>(p.size());
  s.rms_radius = std::sqrt(s.cov.trace());
  return s;
}

struct Run {
  Sim3d T;  // target_from_source in the centred frames
  int iterations = 0;
  bool converged = false;
  double median = 0, rmse = 0, inlier_fraction = 0;
};

// Nearest-neighbour statistics of `src` mapped by T against the target tree.
void Score(const Cloud& src, const pcl::search::KdTree<pcl::PointXYZ>& tree, double median_factor,
           Run* r) {
  const Eigen::Matrix4f M = ToMatrix(r->T);
  std::vector<double> d(src.size());
  pcl::Indices k(1);
  std::vector<float> d2(1);
  for (size_t i = 0; i < src.size(); ++i) {
    pcl::PointXYZ q;
    q.getVector3fMap() = (M * src[i].getVector4fMap()).head<3>();
    d[i] = tree.nearestKSearch(q, 1, k, d2) > 0 ? std::sqrt(d2[0]) : 1e30;
  }
  r->median = Median(d);
  const double cut = median_factor * r->median;
  double s2 = 0;
  int n = 0;
  for (double x : d)
    if (x <= cut) {
      s2 += x * x;
      ++n;
    }
  r->rmse = n ? std::sqrt(s2 / n) : 0;
  r->inlier_fraction = static_cast<double>(n) / static_cast<double>(d.size());
}

Run RunIcp(const Cloud::Ptr& src, const Cloud::Ptr& tgt,
           const pcl::search::KdTree<pcl::PointXYZ>::Ptr& tree, const Sim3d& init, const Options& o,
           int max_iterations, double extent) {
  pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;
  icp.setInputSource(src);
  icp.setInputTarget(tgt);
  icp.setSearchMethodTarget(tree, true);
  if (o.estimate_scale) {
    icp.setTransformationEstimation(
        pcl::make_shared<
            pcl::registration::TransformationEstimationSVDScale<pcl::PointXYZ, pcl::PointXYZ>>());
  }
  auto rejector = pcl::make_shared<pcl::registration::CorrespondenceRejectorMedianDistance>();
  rejector->setMedianFactor(o.median_factor);
  icp.addCorrespondenceRejector(rejector);
  icp.setMaxCorrespondenceDistance(extent);
  icp.setMaximumIterations(max_iterations);
  const double te = o.translation_epsilon * extent;
  icp.setTransformationEpsilon(te * te);
  icp.setTransformationRotationEpsilon(std::cos(o.rotation_epsilon_rad));
  icp.setEuclideanFitnessEpsilon(o.relative_mse_epsilon);
  Run r;
  std::function<void(const Cloud&, const pcl::Indices&, const Cloud&, const pcl::Indices&)> count =
      [&r](const Cloud&, const pcl::Indices&, const Cloud&, const pcl::Indices&) {
        ++r.iterations;
      };
  icp.registerVisualizationCallback(count);
  Cloud out;
  icp.align(out, ToMatrix(init));
  using State = pcl::registration::DefaultConvergenceCriteria<float>::ConvergenceState;
  const State state = icp.getConvergeCriteria()->getConvergenceState();
  if (state == State::CONVERGENCE_CRITERIA_NO_CORRESPONDENCES) {
    throw NoResultError("the clouds do not overlap: ICP found too few correspondences");
  }
  r.converged = icp.hasConverged() && state != State::CONVERGENCE_CRITERIA_ITERATIONS &&
                state != State::CONVERGENCE_CRITERIA_FAILURE_AFTER_MAX_ITERATIONS;
  r.T = FromMatrix(icp.getFinalTransformation());
  return r;
}

// Surface normals of reference points (PCA of their 8 nearest neighbours), computed on
// first use and cached: only the points that become correspondences need one.
class Normals {
 public:
  Normals(const Cloud::Ptr& ref, const pcl::search::KdTree<pcl::PointXYZ>::Ptr& tree)
      : ref_(ref),
        tree_(tree),
        n_(ref->size(), Eigen::Vector3d::Zero()),
        done_(ref->size(), false) {}
  const Eigen::Vector3d& At(int i) {
    if (!done_[i]) {
      pcl::Indices k;
      std::vector<float> d2;
      tree_->nearestKSearch((*ref_)[i], 8, k, d2);
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (int j : k) mean += (*ref_)[j].getVector3fMap().cast<double>();
      mean /= static_cast<double>(k.size());
      Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
      for (int j : k) {
        const Eigen::Vector3d d = (*ref_)[j].getVector3fMap().cast<double>() - mean;
        C += d * d.transpose();
      }
      n_[i] = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(C).eigenvectors().col(0);
      done_[i] = true;
    }
    return n_[i];
  }

 private:
  Cloud::Ptr ref_;
  pcl::search::KdTree<pcl::PointXYZ>::Ptr tree_;
  std::vector<Eigen::Vector3d> n_;
  std::vector<bool> done_;
};

// ICP with scale, point-to-plane (Chen & Medioni 1992) plus a weak point-to-point term
// (weight 0.02) that keeps the directions a smooth surface leaves free determined. Each
// iteration: nearest reference point of every sampled source point; correspondences beyond
// median_factor x the median distance dropped; one Gauss-Newton step on the 7 parameters
// (rotation, translation, scale about the correspondences' centroid).
Run RunPlaneIcp(const std::vector<Eigen::Vector3d>& src, const Cloud::Ptr& tgt,
                const pcl::search::KdTree<pcl::PointXYZ>::Ptr& tree, Normals* normals,
                const Sim3d& init, const Options& o, int max_iterations, double extent) {
  Run r;
  r.T = init;
  const int np = o.estimate_scale ? 7 : 6;
  const double w_point = 0.02;
  pcl::Indices k(1);
  std::vector<float> d2(1);
  std::vector<Eigen::Vector3d> p(src.size());
  std::vector<int> nn(src.size());
  std::vector<double> dist(src.size());
  for (int it = 0; it < max_iterations; ++it) {
    ++r.iterations;
    for (size_t i = 0; i < src.size(); ++i) {
      p[i] = r.T * src[i];
      const pcl::PointXYZ q(static_cast<float>(p[i].x()), static_cast<float>(p[i].y()),
                            static_cast<float>(p[i].z()));
      if (tree->nearestKSearch(q, 1, k, d2) > 0) {
        nn[i] = k[0];
        dist[i] = std::sqrt(d2[0]);
      } else {
        nn[i] = -1;
        dist[i] = 1e30;
      }
    }
    const double cut = std::min(extent, std::max(1e-9, o.median_factor * Median(dist)));
    std::vector<int> use;
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (size_t i = 0; i < src.size(); ++i)
      if (nn[i] >= 0 && dist[i] <= cut) {
        use.push_back(static_cast<int>(i));
        c += p[i];
      }
    if (use.size() < 10)
      throw NoResultError("the clouds do not overlap: ICP found too few correspondences");
    c /= static_cast<double>(use.size());
    Eigen::Matrix<double, 7, 7> A = Eigen::Matrix<double, 7, 7>::Zero();
    Eigen::Matrix<double, 7, 1> b = Eigen::Matrix<double, 7, 1>::Zero();
    for (int i : use) {
      const Eigen::Vector3d q = (*tgt)[nn[i]].getVector3fMap().cast<double>();
      const Eigen::Vector3d& n = normals->At(nn[i]);
      const Eigen::Vector3d pt = p[i] - c;
      Eigen::Matrix<double, 7, 1> J;
      J << pt.cross(n), n, n.dot(pt);
      const double res = n.dot(p[i] - q);
      A += J * J.transpose();
      b += J * res;
      Eigen::Matrix<double, 3, 7> Jp;
      Jp << -geometry::Skew(pt), Eigen::Matrix3d::Identity(), pt;
      A += w_point * w_point * Jp.transpose() * Jp;
      b += w_point * w_point * Jp.transpose() * (p[i] - q);
    }
    Eigen::Matrix<double, 7, 1> x = Eigen::Matrix<double, 7, 1>::Zero();
    x.head(np) = -A.topLeftCorner(np, np).ldlt().solve(b.head(np));
    if (!x.allFinite()) throw NoResultError("ICP degenerated (singular normal equations)");
    const Eigen::Vector3d w = x.head<3>(), tau = x.segment<3>(3);
    Sim3d step;
    step.scale = 1 + x[6];
    step.rotation = w.norm() > 0 ? Eigen::Quaterniond(Eigen::AngleAxisd(w.norm(), w.normalized()))
                                 : Eigen::Quaterniond::Identity();
    // p -> c + tau + s R (p - c)
    step.translation = c + tau - step.scale * (step.rotation * c);
    r.T = step * r.T;
    if (w.norm() < o.rotation_epsilon_rad && tau.norm() < o.translation_epsilon * extent &&
        std::fabs(x[6]) < o.translation_epsilon) {
      r.converged = true;
      break;
    }
  }
  return r;
}

}  // namespace

void Options::Check() const {
  auto require = [](bool ok, const std::string& field, const std::string& what) {
    if (!ok) throw InputError("icp." + field + ": must be " + what);
  };
  require(max_iterations >= 1, "max_iterations", ">= 1");
  require(median_factor > 1, "median_factor", "> 1");
  require(translation_epsilon > 0, "translation_epsilon", "> 0");
  require(rotation_epsilon_rad > 0, "rotation_epsilon_rad", "> 0");
  require(relative_mse_epsilon > 0, "relative_mse_epsilon", "> 0");
  require(max_source_points >= 10, "max_source_points", ">= 10");
  require(max_scale_change > 0, "max_scale_change", "> 0");
  require(max_shift_fraction > 0, "max_shift_fraction", "> 0");
  require(max_rotation_rad > 0, "max_rotation_rad", "> 0");
}

Result Align(const std::vector<Eigen::Vector3d>& cloud,
             const std::vector<Eigen::Vector3d>& reference, const Options& o) {
  if (cloud.size() < 10)
    throw InputError("cloud: " + std::to_string(cloud.size()) + " points; ICP needs at least 10");
  if (reference.size() < 10)
    throw InputError("reference: " + std::to_string(reference.size()) +
                     " points; ICP needs at least 10");
  o.Check();
  const Stats sc = Moments(cloud), sr = Moments(reference);
  if (!(sr.rms_radius > 0) || !(sc.rms_radius > 0))
    throw NoResultError("a cloud has all its points at one place");
  std::vector<int> all_ref(reference.size());
  std::iota(all_ref.begin(), all_ref.end(), 0);
  const Cloud::Ptr tgt = ToPcl(reference, sr.centroid, all_ref);
  pcl::search::KdTree<pcl::PointXYZ>::Ptr tree(new pcl::search::KdTree<pcl::PointXYZ>);
  // Approximate nearest neighbours (within 1 + eps of the nearest distance): ICP needs
  // correspondences, not exact ones, and the last iterations' distances are ~ the spacing.
  tree->setEpsilon(0.5f);
  tree->setInputCloud(tgt);
  Normals normals(tgt, tree);
  const std::vector<int> sample =
      Sample(static_cast<int>(cloud.size()), o.max_source_points, o.seed);
  const Cloud::Ptr src = ToPcl(cloud, sc.centroid, sample);
  std::vector<Eigen::Vector3d> src_e;
  for (int i : sample) src_e.push_back(cloud[i] - sc.centroid);
  const double extent = sr.rms_radius;
  auto run = [&](const Cloud::Ptr& s, const std::vector<Eigen::Vector3d>& se, const Sim3d& start,
                 int iters, const Options& opt) {
    Run r = opt.method == Method::kPointToPlane
                ? RunPlaneIcp(se, tgt, tree, &normals, start, opt, iters, extent)
                : RunIcp(s, tgt, tree, start, opt, iters, extent);
    Score(*s, *tree, opt.median_factor, &r);
    return r;
  };
  // Centred frames: reference' = reference - c_r, cloud' = cloud - c_c.
  Init init = o.init;
  if (init == Init::kAuto) {
    const double ratio = sc.rms_radius / sr.rms_radius;
    init = (sc.centroid - sr.centroid).norm() < extent && ratio > 0.1 && ratio < 2 ? Init::kNone
                                                                                   : Init::kPca;
  }
  // Coarse to fine: a 2,000-point sample converges first (most of the iterations, at a
  // tenth of the cost), then the full sample refines from there.
  const std::vector<int> coarse_idx = Sample(static_cast<int>(cloud.size()), 2000, o.seed + 1);
  const Cloud::Ptr coarse = ToPcl(cloud, sc.centroid, coarse_idx);
  std::vector<Eigen::Vector3d> coarse_e;
  for (int i : coarse_idx) coarse_e.push_back(cloud[i] - sc.centroid);
  Run best;
  int coarse_iterations = 0;
  bool scale_fixed = false, frame_kept = false;
  if (init == Init::kNone) {
    const Sim3d start = Shift(sc.centroid - sr.centroid);  // the identity, centred frames
    auto coarse_to_fine = [&](const Options& opt) {
      const Run c = run(coarse, coarse_e, start, opt.max_iterations, opt);
      coarse_iterations += c.iterations;
      return run(src, src_e, c.T, opt.max_iterations, opt);
    };
    best = coarse_to_fine(o);
    // Both clouds georeferenced: their scales agree to the GPS fit's accuracy (~1 %). A
    // fit that leaves [1 - max_scale_change, 1 + max_scale_change] has made the shapes
    // agree by stretching one (a flat site against a mound's reference does that): redo it
    // rigid.
    if (o.estimate_scale && std::fabs(best.T.scale - 1) > o.max_scale_change) {
      Options rigid = o;
      rigid.estimate_scale = false;
      best = coarse_to_fine(rigid);
      scale_fixed = true;
    }
    // Nor is a fit that moved the cloud far beyond GPS errors (a flat site slides over a
    // mound's reference onto its flat surroundings): the georeferenced frame is kept.
    const double moved =
        (best.T * Eigen::Vector3d::Zero() - start * Eigen::Vector3d::Zero()).norm();
    if (moved > o.max_shift_fraction * sc.rms_radius ||
        best.T.rotation.angularDistance(start.rotation) > o.max_rotation_rad) {
      Run r;
      r.T = start;
      Score(*src, *tree, o.median_factor, &r);
      best = r;
      frame_kept = true;
    }
  } else {
    // Principal axes (largest first); rotations about the smallest axis (the normal of a
    // terrain patch, whose in-plane axes are ill-defined) in 30-degree steps, normal flipped
    // or not: 24 starts, each refined by a coarse ICP; the best by median distance wins.
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> ec(sc.cov), er(sr.cov);
    Eigen::Matrix3d Ec = ec.eigenvectors().rowwise().reverse(),
                    Er = er.eigenvectors().rowwise().reverse();
    if (Ec.determinant() < 0) Ec.col(2) *= -1;
    if (Er.determinant() < 0) Er.col(2) *= -1;
    // A start is scored both ways: the median distance of the cloud's points to the
    // reference and of a reference sample to the mapped cloud, so that a fit whose scale
    // collapsed onto a patch of the reference does not win.
    const std::vector<int> ref_idx = Sample(static_cast<int>(reference.size()), 2000, o.seed + 2);
    auto reverse_median = [&](const Sim3d& T) {
      Cloud::Ptr mapped(new Cloud);
      for (const Eigen::Vector3d& p : coarse_e) {
        const Eigen::Vector3d q = T * p;
        mapped->push_back(pcl::PointXYZ(static_cast<float>(q.x()), static_cast<float>(q.y()),
                                        static_cast<float>(q.z())));
      }
      pcl::KdTreeFLANN<pcl::PointXYZ> t;
      t.setInputCloud(mapped);
      pcl::Indices k(1);
      std::vector<float> d2(1);
      std::vector<double> d;
      for (int i : ref_idx)
        d.push_back(t.nearestKSearch((*tgt)[i], 1, k, d2) > 0 ? std::sqrt(d2[0]) : 1e30);
      return Median(std::move(d));
    };
    double best_median = std::numeric_limits<double>::infinity();
    for (int flip = 0; flip < 2; ++flip)
      for (int k = 0; k < 12; ++k) {
        Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
        if (flip) D.diagonal() << 1, -1, -1;
        const Eigen::Matrix3d R =
            Er * Eigen::AngleAxisd(k * M_PI / 6, Eigen::Vector3d::UnitZ()).toRotationMatrix() * D *
            Ec.transpose();
        Sim3d start;
        start.rotation = Eigen::Quaterniond(R);
        start.scale = o.estimate_scale ? sr.rms_radius / sc.rms_radius : 1.0;
        Run r;
        try {
          r = run(coarse, coarse_e, start, 30, o);
        } catch (const NoResultError&) {
          continue;  // this start lost the overlap
        }
        const double score = r.median + reverse_median(r.T);
        coarse_iterations += r.iterations;
        if (score < best_median) {
          best_median = score;
          best = r;
        }
      }
    if (!std::isfinite(best_median))
      throw NoResultError("no start of the ICP found an overlap between the clouds");
    best = run(src, src_e, best.T, o.max_iterations, o);
  }
  Result res;
  res.reference_from_cloud = Shift(sr.centroid) * best.T * Shift(-sc.centroid);
  res.init_used = init;
  res.iterations = best.iterations;
  res.coarse_iterations = coarse_iterations;
  res.scale_fixed = scale_fixed;
  res.frame_kept = frame_kept;
  res.converged = best.converged;
  res.rmse_m = best.rmse;
  res.inlier_fraction = best.inlier_fraction;
  return res;
}

std::vector<double> SurfaceDistances(const std::vector<Eigen::Vector3d>& points,
                                     const std::vector<Eigen::Vector3d>& reference) {
  if (reference.size() < 6) throw InputError("reference: fewer than 6 points, no surface");
  const Stats sr = Moments(reference);
  std::vector<int> all(reference.size());
  std::iota(all.begin(), all.end(), 0);
  const Cloud::Ptr ref = ToPcl(reference, sr.centroid, all);
  pcl::KdTreeFLANN<pcl::PointXYZ> tree;
  tree.setInputCloud(ref);
  std::vector<double> out(points.size());
  pcl::Indices k(6);
  std::vector<float> d2(6);
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d q = points[i] - sr.centroid;
    const int n =
        tree.nearestKSearch(pcl::PointXYZ(static_cast<float>(q.x()), static_cast<float>(q.y()),
                                          static_cast<float>(q.z())),
                            6, k, d2);
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    std::vector<Eigen::Vector3d> nb(n);
    for (int j = 0; j < n; ++j) {
      nb[j] = reference[k[j]] - sr.centroid;
      mean += nb[j];
    }
    mean /= n;
    const double nearest = std::sqrt(d2[0]);
    double radius = 0;
    Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
    for (int j = 0; j < n; ++j) {
      C += (nb[j] - mean) * (nb[j] - mean).transpose();
      radius = std::max(radius, (nb[j] - nb[0]).norm());
    }
    double d = nearest;
    if (n >= 3) {
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(C);
      // A plane when the neighbourhood is not a line: the two larger spreads comparable.
      if (es.eigenvalues()[1] > 1e-6 * es.eigenvalues()[2]) {
        const double plane = std::fabs(es.eigenvectors().col(0).dot(q - mean));
        d = std::max(plane, nearest - radius);
      }
    }
    out[i] = d;
  }
  return out;
}

}  // namespace mound::icp
