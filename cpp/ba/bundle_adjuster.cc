#include "ba/bundle_adjuster.h"

#include <ceres/ceres.h>

#include <array>
#include <cmath>

#include "ba/cost_functions.h"
#include "common/error.h"

namespace mound::ba {
namespace {

// A view's pose as Ceres' parameter blocks: angle-axis rotation and translation.
struct PoseBlocks {
  std::array<double, 3> rotation{}, translation{};
};

PoseBlocks ToBlocks(const geometry::Rigid3d& cam_from_world) {
  PoseBlocks b;
  const Eigen::AngleAxisd aa(cam_from_world.rotation);
  const Eigen::Vector3d w = aa.angle() * aa.axis();
  b.rotation = {w.x(), w.y(), w.z()};
  b.translation = {cam_from_world.translation.x(), cam_from_world.translation.y(),
                   cam_from_world.translation.z()};
  return b;
}

geometry::Rigid3d FromBlocks(const PoseBlocks& b) {
  const Eigen::Vector3d w(b.rotation[0], b.rotation[1], b.rotation[2]);
  const Eigen::Quaterniond q = w.norm() > 0
                                   ? Eigen::Quaterniond(Eigen::AngleAxisd(w.norm(), w.normalized()))
                                   : Eigen::Quaterniond::Identity();
  return {q, Eigen::Vector3d(b.translation[0], b.translation[1], b.translation[2])};
}

}  // namespace

double RmseReprojection(const Problem& p) {
  double sum = 0;
  for (const Observation& o : p.observations) {
    Eigen::Vector2d uv;
    if (!p.camera.ImageFromCamera(p.cam_from_world[o.view] * p.points[o.point], &uv)) continue;
    sum += (uv - o.px).squaredNorm();
  }
  return p.observations.empty() ? 0 : std::sqrt(sum / p.observations.size());
}

Summary Adjust(Problem* p, const Options& o) {
  const int nv = static_cast<int>(p->cam_from_world.size()),
            np = static_cast<int>(p->points.size());
  for (size_t k = 0; k < p->observations.size(); ++k) {
    const Observation& ob = p->observations[k];
    if (ob.view < 0 || ob.view >= nv || ob.point < 0 || ob.point >= np) {
      throw InternalError("ba::Adjust: observations[" + std::to_string(k) +
                          "]: view or point out of range");
    }
  }
  if (o.fixed_view < -1 || o.fixed_view >= nv)
    throw InternalError("ba::Adjust: fixed_view out of range");
  for (int v : o.constant_views)
    if (v < 0 || v >= nv) throw InternalError("ba::Adjust: constant_views: view out of range");
  if (o.intrinsics_prior && !(o.intrinsics_prior->f_px > 0 && o.intrinsics_prior->f_sd > 0 &&
                              o.intrinsics_prior->k_sd > 0))
    throw InternalError("ba::Adjust: intrinsics_prior: f_px, f_sd and k_sd must be > 0");
  Summary s;
  s.initial_rmse_px = RmseReprojection(*p);
  std::vector<PoseBlocks> poses;
  for (const geometry::Rigid3d& v : p->cam_from_world) poses.push_back(ToBlocks(v));
  // One robust loss for every residual (the problem does not own it) instead of one
  // allocation per observation; the blocks' sizes are fixed by construction, so Ceres'
  // per-block checks are skipped.
  ceres::HuberLoss loss(o.huber_px);
  ceres::Problem::Options po;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  po.disable_all_safety_checks = true;
  ceres::Problem problem(po);
  std::array<double, 3> intrinsics{p->camera.fx, p->camera.dist[0], p->camera.dist[1]};
  for (const Observation& ob : p->observations) {
    if (o.refine_intrinsics) {
      problem.AddResidualBlock(
          ReprojectionErrorWithIntrinsics::Create(ob.px.x(), ob.px.y(), p->camera), &loss,
          poses[ob.view].rotation.data(), poses[ob.view].translation.data(),
          p->points[ob.point].data(), intrinsics.data());
    } else {
      problem.AddResidualBlock(ReprojectionError::Create(ob.px.x(), ob.px.y(), p->camera), &loss,
                               poses[ob.view].rotation.data(), poses[ob.view].translation.data(),
                               p->points[ob.point].data());
    }
  }
  if (o.refine_intrinsics && o.intrinsics_prior && problem.HasParameterBlock(intrinsics.data())) {
    const IntrinsicsPrior& q = *o.intrinsics_prior;
    // the prior is not robustified: it is a belief about the lens, not an observation
    problem.AddResidualBlock(IntrinsicsPriorError::Create(q.f_px, q.k1, q.k2, q.f_sd, q.k_sd),
                             nullptr, intrinsics.data());
  }
  std::vector<bool> constant(nv, false);
  if (o.fixed_view >= 0) constant[o.fixed_view] = true;
  for (int v : o.constant_views) constant[v] = true;
  int free_views = 0;  // views with observations that the solver moves
  for (int v = 0; v < nv; ++v) {
    if (!problem.HasParameterBlock(poses[v].rotation.data())) continue;
    if (!constant[v]) {
      ++free_views;
      continue;
    }
    problem.SetParameterBlockConstant(poses[v].rotation.data());
    problem.SetParameterBlockConstant(poses[v].translation.data());
  }
  if (o.scale_view >= 0 && o.scale_view < nv && !constant[o.scale_view] &&
      problem.HasParameterBlock(poses[o.scale_view].translation.data())) {
    problem.SetManifold(poses[o.scale_view].translation.data(), new ceres::SphereManifold<3>());
  }
  ceres::Solver::Options so;
  so.minimizer_type = ceres::TRUST_REGION;
  so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  // The points are eliminated (Schur complement); the reduced camera system is 6 numbers a
  // free view. Up to 50 free views it is factorised dense, as COLMAP does: for a survey
  // site's 18 views that is a 108 x 108 matrix, where a sparse ordering costs more than it
  // saves.
  so.linear_solver_type = free_views <= 50 ? ceres::DENSE_SCHUR : ceres::SPARSE_SCHUR;
  so.max_num_iterations = o.max_iterations;
  so.num_threads = o.threads;
  so.function_tolerance = o.function_tolerance;
  so.parameter_tolerance = 1e-10;
  so.max_solver_time_in_seconds = o.max_time_s;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  for (int k = 0; k < nv; ++k) p->cam_from_world[k] = FromBlocks(poses[k]);
  if (o.refine_intrinsics && problem.HasParameterBlock(intrinsics.data())) {
    const double aspect = p->camera.fy / p->camera.fx;
    p->camera.fx = intrinsics[0];
    p->camera.fy = intrinsics[0] * aspect;
    p->camera.dist[0] = intrinsics[1];
    p->camera.dist[1] = intrinsics[2];
  }
  s.final_rmse_px = RmseReprojection(*p);
  s.iterations = static_cast<int>(summary.iterations.size());
  s.converged = summary.termination_type == ceres::CONVERGENCE;
  s.brief = summary.BriefReport();
  return s;
}

}  // namespace mound::ba
