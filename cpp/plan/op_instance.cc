#include "plan/op_instance.h"

#include <cmath>
#include <vector>

namespace mound::plan {

double OpInstance::Dist(int i, int j) const {
  if (!dist_matrix.empty()) return dist_matrix[static_cast<size_t>(i) * nodes.size() + j];
  // sqrt rather than std::hypot: coordinates are metres (no overflow risk) and hypot is
  // several times slower on this hot path of the planner.
  const double dx = nodes[i].x_m - nodes[j].x_m, dy = nodes[i].y_m - nodes[j].y_m;
  return std::sqrt(dx * dx + dy * dy);
}

double OpInstance::RouteCost(const std::vector<int>& route) const {
  double c = 0;
  for (size_t i = 0; i + 1 < route.size(); ++i) c += Cost(route[i], route[i + 1]);
  return c;
}

double OpInstance::RouteReward(const std::vector<int>& route) const {
  double r = 0;
  for (int v : route)
    if (IsSite(v)) r += nodes[v].reward;
  return r;
}

bool OpInstance::Better(const std::vector<int>& a, double cost_a, const std::vector<int>& b,
                        double cost_b) const {
  const double ra = RouteReward(a), rb = RouteReward(b);
  const double eps = 1e-12 * (1.0 + std::abs(rb));
  if (ra > rb + eps) return true;
  return ra >= rb - eps && cost_a < cost_b - 1e-9;
}

std::string OpInstance::CheckRoute(const std::vector<int>& route) const {
  if (route.size() < 2) return "route has fewer than two nodes";
  if (route.front() != kHome) return "route does not start at home";
  if (route.back() != end) return "route does not finish at the end node";
  std::vector<char> seen(nodes.size(), 0);
  for (size_t i = 1; i + 1 < route.size(); ++i) {
    const int v = route[i];
    if (v < 0 || v >= Size() || !IsSite(v)) return "route holds a non-site inside";
    if (seen[v]) return "site " + nodes[v].id + " visited twice";
    seen[v] = 1;
  }
  if (RouteCost(route) > budget_m + BudgetSlack(budget_m)) return "route exceeds the budget";
  return "";
}

}  // namespace mound::plan
