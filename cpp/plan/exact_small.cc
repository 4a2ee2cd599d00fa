#include "plan/exact_small.h"

#include <algorithm>
#include <limits>
#include <stdexcept>

namespace mound::plan {

SubsetRoutes::SubsetRoutes(const OpInstance& inst)
    : inst_(inst),
      first_(inst.FirstSite()),
      m_(inst.Size() - inst.FirstSite()),
      limit_(inst.budget_m + BudgetSlack(inst.budget_m)) {
  if (m_ > kMaxExactSites) throw std::invalid_argument("too many sites for the exact method");
  const double inf = std::numeric_limits<double>::infinity();
  const size_t states = size_t{1} << m_;
  const int m = m_;
  std::vector<double> dp(states * std::max(m, 1), inf);
  from_.assign(states * std::max(m, 1), -1);
  auto at = [&](size_t mask, int j) { return mask * m + j; };
  for (int j = 0; j < m; ++j) dp[at(size_t{1} << j, j)] = inst.Cost(OpInstance::kHome, first_ + j);
  tour_.assign(states, inf);
  last_.assign(states, -1);
  const double direct = inst.Cost(OpInstance::kHome, inst.end);
  if (direct <= limit_) tour_[0] = direct;
  for (size_t mask = 1; mask < states; ++mask) {
    for (int j = 0; j < m; ++j) {
      if (!(mask >> j & 1)) continue;
      const double c = dp[at(mask, j)];
      if (c == inf || c > limit_) continue;
      const double total = c + inst.Cost(first_ + j, inst.end);
      if (total <= limit_ && total < tour_[mask]) {
        tour_[mask] = total;
        last_[mask] = static_cast<int8_t>(j);
      }
      for (int k = 0; k < m; ++k) {
        if (mask >> k & 1) continue;
        const size_t next = mask | (size_t{1} << k);
        const double nc = c + inst.Cost(first_ + j, first_ + k);
        if (nc < dp[at(next, k)]) {
          dp[at(next, k)] = nc;
          from_[at(next, k)] = static_cast<int8_t>(j);
        }
      }
    }
  }
  reward_.assign(states, 0.0);
  for (size_t mask = 1; mask < states; ++mask) {
    const int j = __builtin_ctzll(mask);
    reward_[mask] = reward_[mask & (mask - 1)] + inst.nodes[first_ + j].reward;
  }
}

std::vector<int> SubsetRoutes::Route(size_t mask) const {
  std::vector<int> middle;
  for (int j = last_[mask]; j >= 0 && mask != 0;) {
    middle.push_back(first_ + j);
    const int prev = from_[mask * m_ + j];
    mask &= ~(size_t{1} << j);
    j = prev;
  }
  std::vector<int> route{OpInstance::kHome};
  route.insert(route.end(), middle.rbegin(), middle.rend());
  route.push_back(inst_.end);
  return route;
}

PlanResult SolveExactSmall(const OpInstance& inst) {
  const SubsetRoutes routes(inst);
  double best_reward = -1, best_cost = std::numeric_limits<double>::infinity();
  size_t best = 0;
  for (size_t mask = 0; mask < routes.Subsets(); ++mask) {
    if (!routes.Fits(mask)) continue;
    const double r = routes.Reward(mask), c = routes.Cost(mask);
    if (r > best_reward + 1e-12 || (r >= best_reward - 1e-12 && c < best_cost)) {
      best_reward = r;
      best_cost = c;
      best = mask;
    }
  }
  PlanResult res;
  res.stats = {{"name", "exact"}, {"subsets", routes.Subsets()}};
  res.route = routes.Route(best);
  res.reward = inst.RouteReward(res.route);
  res.cost = inst.RouteCost(res.route);
  return res;
}

}  // namespace mound::plan
