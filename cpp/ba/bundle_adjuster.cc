#include "ba/bundle_adjuster.h"

#include <ceres/ceres.h>

#include <cmath>

#include "common/error.h"

namespace mound::ba {

double RmseReprojection(const Problem& p) {
  double sum = 0;
  for (const Observation& o : p.observations) {
    const ReprojectionError e(o.u_px, o.v_px, p.camera);
    double r[2];
    e(p.views[o.view].rotation.data(), p.views[o.view].translation.data(),
      p.points[o.point].data(), r);
    sum += r[0] * r[0] + r[1] * r[1];
  }
  return p.observations.empty() ? 0 : std::sqrt(sum / p.observations.size());
}

Summary Adjust(Problem* p, const Options& o) {
  const int nv = static_cast<int>(p->views.size()), np = static_cast<int>(p->points.size());
  for (size_t k = 0; k < p->observations.size(); ++k) {
    const Observation& ob = p->observations[k];
    if (ob.view < 0 || ob.view >= nv || ob.point < 0 || ob.point >= np) {
      throw InputError("observations[" + std::to_string(k) + "]: view or point out of range");
    }
  }
  if (o.fixed_view < 0 || o.fixed_view >= nv) throw InputError("fixed_view: out of range");
  Summary s;
  s.initial_rmse_px = RmseReprojection(*p);
  ceres::Problem problem;
  for (const Observation& ob : p->observations) {
    problem.AddResidualBlock(ReprojectionError::Create(ob.u_px, ob.v_px, p->camera),
                             new ceres::HuberLoss(o.huber_px), p->views[ob.view].rotation.data(),
                             p->views[ob.view].translation.data(), p->points[ob.point].data());
  }
  View& fixed = p->views[o.fixed_view];
  if (problem.HasParameterBlock(fixed.rotation.data())) {
    problem.SetParameterBlockConstant(fixed.rotation.data());
    problem.SetParameterBlockConstant(fixed.translation.data());
  }
  if (o.scale_view >= 0 && o.scale_view < nv && o.scale_view != o.fixed_view &&
      problem.HasParameterBlock(p->views[o.scale_view].translation.data())) {
    problem.SetManifold(p->views[o.scale_view].translation.data(), new ceres::SphereManifold<3>());
  }
  ceres::Solver::Options so;
  so.minimizer_type = ceres::TRUST_REGION;
  so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  so.linear_solver_type = ceres::SPARSE_SCHUR;
  so.max_num_iterations = o.max_iterations;
  so.num_threads = o.threads;
  so.function_tolerance = 1e-10;
  so.parameter_tolerance = 1e-10;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  s.final_rmse_px = RmseReprojection(*p);
  s.iterations = static_cast<int>(summary.iterations.size());
  s.converged = summary.termination_type == ceres::CONVERGENCE;
  s.brief = summary.BriefReport();
  return s;
}

}  // namespace mound::ba
