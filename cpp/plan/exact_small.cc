#include "plan/exact_small.h"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <stdexcept>

namespace mound::plan {

PlanResult SolveExactSmall(const OpInstance& inst) {
  const int first = inst.FirstSite();
  const int m = inst.Size() - first;
  if (m > kMaxExactSites) throw std::invalid_argument("too many sites for the exact method");
  const double inf = std::numeric_limits<double>::infinity();
  const size_t states = size_t{1} << m;
  std::vector<double> dp(states * std::max(m, 1), inf);
  std::vector<int8_t> from(states * std::max(m, 1), -1);
  auto at = [&](size_t mask, int j) { return mask * m + j; };
  for (int j = 0; j < m; ++j) dp[at(size_t{1} << j, j)] = inst.Cost(OpInstance::kHome, first + j);
  const double limit = inst.budget_m + BudgetSlack(inst.budget_m);
  double best_reward = -1, best_cost = inf;
  size_t best_mask = 0;
  int best_last = -1;
  const double direct = inst.Cost(OpInstance::kHome, inst.end);
  if (direct <= limit) {
    best_reward = 0;
    best_cost = direct;
  }
  for (size_t mask = 1; mask < states; ++mask) {
    double reward = 0;
    for (int j = 0; j < m; ++j)
      if (mask >> j & 1) reward += inst.nodes[first + j].reward;
    for (int j = 0; j < m; ++j) {
      if (!(mask >> j & 1)) continue;
      const double c = dp[at(mask, j)];
      if (c == inf || c > limit) continue;
      const double total = c + inst.Cost(first + j, inst.end);
      if (total <= limit &&
          (reward > best_reward + 1e-12 || (reward >= best_reward - 1e-12 && total < best_cost))) {
        best_reward = reward;
        best_cost = total;
        best_mask = mask;
        best_last = j;
      }
      for (int k = 0; k < m; ++k) {
        if (mask >> k & 1) continue;
        const size_t next = mask | (size_t{1} << k);
        const double nc = c + inst.Cost(first + j, first + k);
        if (nc < dp[at(next, k)]) {
          dp[at(next, k)] = nc;
          from[at(next, k)] = static_cast<int8_t>(j);
        }
      }
    }
  }
  PlanResult res;
  res.stats = {{"name", "exact"}, {"subsets", states}};
  std::vector<int> middle;
  size_t mask = best_mask;
  for (int j = best_last; j >= 0 && mask != 0;) {
    middle.push_back(first + j);
    const int prev = from[at(mask, j)];
    mask &= ~(size_t{1} << j);
    j = prev;
  }
  std::reverse(middle.begin(), middle.end());
  res.route.push_back(OpInstance::kHome);
  res.route.insert(res.route.end(), middle.begin(), middle.end());
  res.route.push_back(inst.end);
  res.reward = inst.RouteReward(res.route);
  res.cost = inst.RouteCost(res.route);
  return res;
}

}  // namespace mound::plan
