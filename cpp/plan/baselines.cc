#include "plan/baselines.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace mound::plan {
namespace {

constexpr double kTiny = 1e-12;

void Finish(const OpInstance& inst, const char* name, PlanResult* res) {
  res->reward = inst.RouteReward(res->route);
  res->cost = inst.RouteCost(res->route);
  res->stats["name"] = name;
}

// Cheapest position to insert v into route (between route[pos-1] and route[pos]).
std::pair<double, size_t> CheapestInsertion(const OpInstance& inst, const std::vector<int>& route,
                                            int v) {
  double best = std::numeric_limits<double>::infinity();
  size_t pos = 1;
  for (size_t i = 1; i < route.size(); ++i) {
    const double d =
        inst.Cost(route[i - 1], v) + inst.Cost(v, route[i]) - inst.Cost(route[i - 1], route[i]);
    if (d < best) {
      best = d;
      pos = i;
    }
  }
  return {best, pos};
}

}  // namespace

int TwoOptRoute(const OpInstance& inst, std::vector<int>* route) {
  std::vector<int>& r = *route;
  int moves = 0;
  bool improved = true;
  while (improved) {
    improved = false;
    for (size_t i = 0; i + 3 < r.size() && !improved; ++i) {
      for (size_t j = i + 2; j + 1 < r.size(); ++j) {
        // Replace edges (r[i], r[i+1]) and (r[j], r[j+1]) by (r[i], r[j]), (r[i+1], r[j+1]).
        const double delta = inst.Cost(r[i], r[j]) + inst.Cost(r[i + 1], r[j + 1]) -
                             inst.Cost(r[i], r[i + 1]) - inst.Cost(r[j], r[j + 1]);
        if (delta < -1e-12) {
          std::reverse(r.begin() + i + 1, r.begin() + j + 1);
          ++moves;
          improved = true;
          break;
        }
      }
    }
  }
  return moves;
}

PlanResult SolveGreedy(const OpInstance& inst) {
  const double limit = inst.budget_m + BudgetSlack(inst.budget_m);
  std::vector<char> used(inst.Size(), 0);
  PlanResult res;
  res.route = {OpInstance::kHome};
  double cost = 0;
  int last = OpInstance::kHome;
  for (;;) {
    int best = -1;
    double best_ratio = -1;
    for (int v = inst.FirstSite(); v < inst.Size(); ++v) {
      if (used[v] || inst.nodes[v].reward <= 0) continue;
      const double step = inst.Cost(last, v);
      if (cost + step + inst.Cost(v, inst.end) > limit) continue;
      const double ratio = inst.nodes[v].reward / std::max(step, kTiny);
      if (ratio > best_ratio) {
        best_ratio = ratio;
        best = v;
      }
    }
    if (best < 0) break;
    used[best] = 1;
    cost += inst.Cost(last, best);
    res.route.push_back(best);
    last = best;
  }
  res.route.push_back(inst.end);
  Finish(inst, "greedy", &res);
  return res;
}

PlanResult SolveTsiligirides(const OpInstance& inst, const BaselineOptions& opt) {
  const double limit = inst.budget_m + BudgetSlack(inst.budget_m);
  std::mt19937_64 rng(opt.seed);
  std::uniform_real_distribution<double> unif(0.0, 1.0);
  PlanResult res;
  res.route = {OpInstance::kHome, inst.end};
  double best_cost = inst.RouteCost(res.route);
  std::vector<char> used(inst.Size(), 0);
  std::vector<std::pair<double, int>> scored;
  for (int r = 0; r < opt.tsiligirides_routes; ++r) {
    std::fill(used.begin(), used.end(), 0);
    std::vector<int> route{OpInstance::kHome};
    double cost = 0;
    int last = OpInstance::kHome;
    for (;;) {
      scored.clear();
      for (int v = inst.FirstSite(); v < inst.Size(); ++v) {
        if (used[v] || inst.nodes[v].reward <= 0) continue;
        const double step = inst.Cost(last, v);
        if (cost + step + inst.Cost(v, inst.end) > limit) continue;
        scored.emplace_back(
            std::pow(inst.nodes[v].reward / std::max(step, kTiny), opt.tsiligirides_exponent), v);
      }
      if (scored.empty()) break;
      const size_t keep = std::min<size_t>(opt.tsiligirides_candidates, scored.size());
      std::partial_sort(scored.begin(), scored.begin() + keep, scored.end(),
                        [](const auto& a, const auto& b) {
                          return a.first != b.first ? a.first > b.first : a.second < b.second;
                        });
      double total = 0;
      for (size_t i = 0; i < keep; ++i) total += scored[i].first;
      double pick = unif(rng) * total;
      size_t chosen = keep - 1;
      for (size_t i = 0; i < keep; ++i) {
        if (pick < scored[i].first) {
          chosen = i;
          break;
        }
        pick -= scored[i].first;
      }
      const int v = scored[chosen].second;
      used[v] = 1;
      cost += inst.Cost(last, v);
      route.push_back(v);
      last = v;
    }
    route.push_back(inst.end);
    const double c = inst.RouteCost(route);
    if (inst.Better(route, c, res.route, best_cost)) {
      res.route = std::move(route);
      best_cost = c;
    }
  }
  res.stats["routes"] = opt.tsiligirides_routes;
  Finish(inst, "tsiligirides", &res);
  return res;
}

PlanResult SolveGlv(const OpInstance& inst, const BaselineOptions& opt) {
  const double limit = inst.budget_m + BudgetSlack(inst.budget_m);
  const int first = inst.FirstSite(), n = inst.Size();
  auto centre = [&](const std::vector<int>& sites) {
    double sx = 0, sy = 0, sw = 0;
    for (int v : sites) {
      sx += inst.nodes[v].reward * inst.nodes[v].x_m;
      sy += inst.nodes[v].reward * inst.nodes[v].y_m;
      sw += inst.nodes[v].reward;
    }
    if (sw <= 0) return std::pair{inst.nodes[0].x_m, inst.nodes[0].y_m};
    return std::pair{sx / sw, sy / sw};
  };
  std::vector<int> all;
  for (int v = first; v < n; ++v) all.push_back(v);
  auto [gx, gy] = centre(all);

  PlanResult res;
  res.route = {OpInstance::kHome, inst.end};
  double best_cost = inst.RouteCost(res.route);
  std::vector<std::vector<int>> seen;
  int iterations = 0;
  for (int it = 0; it < opt.glv_iterations; ++it) {
    ++iterations;
    // (2) Construction around (gx, gy).
    std::vector<std::pair<double, int>> order;
    for (int v = first; v < n; ++v) {
      if (inst.nodes[v].reward <= 0) continue;
      const double d = std::hypot(inst.nodes[v].x_m - gx, inst.nodes[v].y_m - gy);
      order.emplace_back(-inst.nodes[v].reward / std::max(d, kTiny), v);
    }
    std::sort(order.begin(), order.end());
    std::vector<int> route{OpInstance::kHome, inst.end};
    double cost = inst.RouteCost(route);
    std::vector<char> in(n, 0);
    auto insert_in_order = [&]() {
      for (const auto& [key, v] : order) {
        if (in[v]) continue;
        const auto [delta, pos] = CheapestInsertion(inst, route, v);
        if (cost + delta <= limit) {
          route.insert(route.begin() + pos, v);
          cost += delta;
          in[v] = 1;
        }
      }
    };
    insert_in_order();
    // (3) Improvement: 2-opt, then insertion of what now fits; repeat while it helps.
    for (;;) {
      const int moves = TwoOptRoute(inst, &route);
      cost = inst.RouteCost(route);
      const size_t before = route.size();
      insert_in_order();
      if (moves == 0 && route.size() == before) break;
    }
    if (inst.Better(route, cost, res.route, best_cost)) {
      res.route = route;
      best_cost = cost;
    }
    // (4) New centre of gravity from the route; stop when the route repeats.
    std::vector<int> sorted(route.begin() + 1, route.end() - 1);
    std::sort(sorted.begin(), sorted.end());
    if (std::find(seen.begin(), seen.end(), sorted) != seen.end()) break;
    seen.push_back(sorted);
    std::tie(gx, gy) = centre(sorted);
  }
  res.stats["iterations"] = iterations;
  Finish(inst, "glv", &res);
  return res;
}

}  // namespace mound::plan
