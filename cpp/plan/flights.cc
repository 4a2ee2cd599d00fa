#include "plan/flights.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <stdexcept>

#include "plan/exact_small.h"

namespace mound::plan {

std::string CheckFlights(const OpInstance& inst, const std::vector<std::vector<int>>& routes) {
  std::vector<char> seen(inst.Size(), 0);
  for (size_t k = 0; k < routes.size(); ++k) {
    const std::string defect = inst.CheckRoute(routes[k]);
    if (!defect.empty()) return "flight " + std::to_string(k + 1) + ": " + defect;
    for (size_t i = 1; i + 1 < routes[k].size(); ++i) {
      const int v = routes[k][i];
      if (seen[v]) return "site " + inst.nodes[v].id + " in two flights";
      seen[v] = 1;
    }
  }
  return "";
}

void OrderFlights(const OpInstance& inst, FlightsResult* r) {
  std::vector<std::pair<double, double>> key;
  for (const auto& route : r->routes)
    key.push_back({inst.RouteReward(route), inst.RouteCost(route)});
  std::vector<size_t> order(r->routes.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    if (key[a].first != key[b].first) return key[a].first > key[b].first;
    return key[a].second < key[b].second;
  });
  std::vector<std::vector<int>> sorted;
  for (size_t k : order) sorted.push_back(std::move(r->routes[k]));
  r->routes = std::move(sorted);
  r->reward = r->cost = 0;
  for (const auto& route : r->routes) {
    r->reward += inst.RouteReward(route);
    r->cost += inst.RouteCost(route);
  }
}

namespace {

// The instance restricted to home, the end node and the sites of `keep` (indices into
// inst), in that order; matrices restricted alike.
OpInstance Restrict(const OpInstance& inst, const std::vector<int>& keep) {
  OpInstance sub;
  sub.end = inst.end;
  sub.budget_m = inst.budget_m;
  for (int v : keep) sub.nodes.push_back(inst.nodes[v]);
  const size_t n = inst.nodes.size(), m = keep.size();
  auto restrict = [&](const std::vector<double>& full, std::vector<double>* out) {
    if (full.empty()) return;
    out->resize(m * m);
    for (size_t a = 0; a < m; ++a)
      for (size_t b = 0; b < m; ++b) (*out)[a * m + b] = full[keep[a] * n + keep[b]];
  };
  restrict(inst.dist_matrix, &sub.dist_matrix);
  restrict(inst.extra_m, &sub.extra_m);
  return sub;
}

}  // namespace

FlightsResult SequentialFlights(
    const OpInstance& inst, int flights,
    const std::function<PlanResult(const OpInstance&, int flight)>& solve_one) {
  FlightsResult res;
  res.stats = nlohmann::json::object();
  std::vector<char> used(inst.Size(), 0);
  nlohmann::json per = nlohmann::json::array();
  for (int k = 0; k < flights; ++k) {
    std::vector<int> keep{OpInstance::kHome};
    if (!inst.Closed()) keep.push_back(inst.end);
    for (int v = inst.FirstSite(); v < inst.Size(); ++v)
      if (!used[v]) keep.push_back(v);
    std::vector<int> route;
    if (static_cast<int>(keep.size()) > inst.FirstSite()) {
      const OpInstance sub = Restrict(inst, keep);
      const PlanResult r = solve_one(sub, k);
      for (int v : r.route) route.push_back(keep[v]);
      per.push_back(r.stats);
    } else {
      route = {OpInstance::kHome, inst.end};
    }
    for (size_t i = 1; i + 1 < route.size(); ++i) used[route[i]] = 1;
    res.routes.push_back(std::move(route));
  }
  res.stats["flights"] = per;
  OrderFlights(inst, &res);
  return res;
}

FlightsResult SolveExactFlights(const OpInstance& inst, int flights) {
  const int m = inst.Size() - inst.FirstSite();
  if (m > kMaxExactFlightSites) {
    throw std::invalid_argument("too many sites for the exact method with several flights");
  }
  const SubsetRoutes routes(inst);
  const size_t states = routes.Subsets();
  // best[k][mask]: the most reward (then the least cost) of k flights on sites of mask.
  struct Value {
    double reward = 0, cost = 0;
    bool Beats(const Value& o) const {
      if (reward > o.reward + 1e-12 * (1.0 + std::abs(o.reward))) return true;
      return reward >= o.reward - 1e-12 * (1.0 + std::abs(o.reward)) && cost < o.cost - 1e-9;
    }
  };
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<std::vector<Value>> best(flights + 1, std::vector<Value>(states));
  std::vector<std::vector<uint32_t>> choice(flights + 1, std::vector<uint32_t>(states, 0));
  for (int k = 1; k <= flights; ++k) {
    for (size_t mask = 0; mask < states; ++mask) {
      Value b{-1, inf};
      uint32_t arg = 0;
      // T = one flight's sites, a submask of mask (0 included: home -> end).
      for (size_t t = mask;; t = (t - 1) & mask) {
        if (routes.Fits(t)) {
          const Value& rest = best[k - 1][mask ^ t];
          const Value v{routes.Reward(t) + rest.reward, routes.Cost(t) + rest.cost};
          if (v.Beats(b)) {
            b = v;
            arg = static_cast<uint32_t>(t);
          }
        }
        if (t == 0) break;
      }
      best[k][mask] = b;
      choice[k][mask] = arg;
    }
  }
  FlightsResult res;
  size_t mask = states - 1;
  for (int k = flights; k >= 1; --k) {
    const size_t t = choice[k][mask];
    res.routes.push_back(routes.Route(t));
    mask ^= t;
  }
  res.stats = {{"name", "exact"}, {"subsets", states}, {"flights", flights}};
  OrderFlights(inst, &res);
  return res;
}

}  // namespace mound::plan
