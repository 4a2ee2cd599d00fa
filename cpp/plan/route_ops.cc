#include "plan/route_ops.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "tsp/problem.h"

namespace mound::plan {

bool ReorderWithLkh(const OpInstance& inst, std::vector<int>* route, uint64_t seed,
                    RouteOpsStats* stats, const ReorderOptions& options) {
  // The TSP nodes: the route without the repeated home of a closed tour.
  std::vector<int> nodes(route->begin(), route->end() - (inst.Closed() ? 1 : 0));
  const int m = static_cast<int>(nodes.size());
  if (m <= 3) return false;
  // Each pairwise cost once; then scale so the longest edge is 1e6.
  std::vector<double> c(static_cast<size_t>(m) * m, 0.0);
  double max_cost = 0;
  for (int a = 0; a < m; ++a)
    for (int b = a + 1; b < m; ++b) {
      const double cab = inst.Cost(nodes[a], nodes[b]);
      c[static_cast<size_t>(a) * m + b] = c[static_cast<size_t>(b) * m + a] = cab;
      max_cost = std::max(max_cost, cab);
    }
  const double scale = max_cost > 0 ? 1e6 / max_cost : 1.0;
  std::vector<tsp::Cost> d(c.size());
  for (size_t k = 0; k < c.size(); ++k) d[k] = std::llround(c[k] * scale);
  int end_pos = -1;
  if (!inst.Closed()) {
    end_pos = static_cast<int>(std::find(nodes.begin(), nodes.end(), inst.end) - nodes.begin());
    // The path home..end is a tour with the end->home edge fixed at cost 0.
    d[static_cast<size_t>(end_pos) * m] = d[end_pos] = 0;
  }
  tsp::MatrixProblem p(m, std::move(d));
  if (end_pos > 0) p.AddFixedEdge(0, end_pos);
  tsp::SolverOptions opt;
  opt.seed = seed;
  opt.max_trials = std::max(options.min_trials, m / std::max(1, options.trials_divisor));
  opt.ascent.initial_period = std::max(10, m / std::max(1, options.initial_period_divisor));
  opt.ascent.max_iterations = options.max_ascent_iterations;
  opt.move_k = m <= options.small_route_nodes ? options.small_route_move_k : options.move_k;
  if (stats->pi.empty()) stats->pi.assign(inst.Size(), 0);
  opt.ascent.initial_pi.resize(m);
  for (int i = 0; i < m; ++i) opt.ascent.initial_pi[i] = stats->pi[nodes[i]];
  const tsp::TspResult r = tsp::SolveTsp(p, opt);
  ++stats->lkh_calls;
  if (static_cast<int>(r.pi.size()) == m)  // empty when solved exactly (m <= 8)
    for (int i = 0; i < m; ++i) stats->pi[nodes[i]] = r.pi[i];
  stats->lkh_max_nodes = std::max(stats->lkh_max_nodes, m);

  // Rotate to start at home (position 0); orient a path so it ends at the end node.
  std::vector<int> order = r.tour;
  std::rotate(order.begin(), std::find(order.begin(), order.end(), 0), order.end());
  if (end_pos > 0 && order[1] == end_pos) std::reverse(order.begin() + 1, order.end());
  std::vector<int> candidate;
  candidate.reserve(route->size());
  for (int i : order) candidate.push_back(nodes[i]);
  if (inst.Closed()) candidate.push_back(OpInstance::kHome);  // a path already ends at end
  if (inst.RouteCost(candidate) < inst.RouteCost(*route) - 1e-12) {
    *route = std::move(candidate);
    return true;
  }
  return false;
}

int InsertByRatio(const OpInstance& inst, std::vector<int>* route, std::vector<char>* in_route,
                  RouteOpsStats* stats, const std::vector<char>* blocked) {
  const int n = inst.Size();
  const double inf = std::numeric_limits<double>::infinity();
  // The route as a linked list: next[v] follows v; the last node has next -1.
  std::vector<int> next(n, -1);
  for (size_t i = 0; i + 1 < route->size(); ++i) next[(*route)[i]] = (*route)[i + 1];
  // For a closed tour the route is home..home: the final edge returns to home, which we
  // represent by the last site pointing to home (home is the list head as well).
  double cost = inst.RouteCost(*route);
  const double limit = inst.budget_m + BudgetSlack(inst.budget_m);

  std::vector<int> candidates;
  for (int v = inst.FirstSite(); v < n; ++v)
    if (!(*in_route)[v] && inst.nodes[v].reward > 0 && !(blocked && (*blocked)[v]))
      candidates.push_back(v);
  std::vector<double> delta(n, inf);
  std::vector<int> after(n, -1);
  int inserted = 0;
  auto full_scan = [&](int v) {
    delta[v] = inf;
    after[v] = -1;
    int a = OpInstance::kHome;
    // Walk the edges (a, next[a]) of the route as it is now (the sites inserted so far
    // included); for a closed tour the last edge ends at home.
    const size_t edges = route->size() - 1 + static_cast<size_t>(inserted);
    for (size_t k = 0; k < edges; ++k) {
      const int b = next[a];
      const double dlt = inst.Cost(a, v) + inst.Cost(v, b) - inst.Cost(a, b);
      if (dlt < delta[v]) {
        delta[v] = dlt;
        after[v] = a;
      }
      a = b;
    }
  };
  for (int v : candidates) full_scan(v);

  for (;;) {
    int best = -1;
    double best_ratio = -1;
    for (int v : candidates) {
      if ((*in_route)[v] || cost + delta[v] > limit) continue;
      const double ratio = inst.nodes[v].reward / std::max(delta[v], 1e-12);
      if (ratio > best_ratio) {
        best_ratio = ratio;
        best = v;
      }
    }
    if (best < 0) break;
    const int a = after[best], b = next[a];
    next[a] = best;
    next[best] = b;
    (*in_route)[best] = 1;
    cost += delta[best];
    ++inserted;
    for (int v : candidates) {
      if ((*in_route)[v]) continue;
      if (after[v] == a) {
        full_scan(v);
        continue;
      }
      for (const auto& [x, y] : {std::pair{a, best}, std::pair{best, b}}) {
        const double dlt = inst.Cost(x, v) + inst.Cost(v, y) - inst.Cost(x, y);
        if (dlt < delta[v]) {
          delta[v] = dlt;
          after[v] = x;
        }
      }
    }
  }
  if (inserted > 0) {
    // Read the route back from the linked list: home, then next[] up to the end node.
    const size_t length = route->size() + inserted;
    route->assign(1, OpInstance::kHome);
    for (int v = next[OpInstance::kHome]; route->size() < length; v = next[v]) route->push_back(v);
  }
  stats->inserted += inserted;
  return inserted;
}

}  // namespace mound::plan
