#include "plan/newalg.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <random>

#include "plan/route_ops.h"

namespace mound::plan {
namespace {

constexpr double kTinyCost = 1e-12;

struct Tree {
  std::vector<int> parent;  // -1: not in the tree
  std::vector<std::vector<int>> children;
  std::vector<char> in;
  double cost = 0;
};

// Depth-first route over the tree from home. For a path, the child whose subtree holds
// the end node is visited last and the end node after its own children, so the walk
// finishes at the end node.
std::vector<int> DfsRoute(const OpInstance& inst, const Tree& t,
                          const std::vector<char>& toward_end) {
  std::vector<int> route;
  std::vector<std::pair<int, bool>> stack{{OpInstance::kHome, false}};
  while (!stack.empty()) {
    auto [v, done] = stack.back();
    stack.pop_back();
    const bool is_end = !inst.Closed() && v == inst.end;
    if (done) {
      route.push_back(v);  // the end node, after its subtree
      continue;
    }
    if (!is_end)
      route.push_back(v);
    else
      stack.emplace_back(v, true);
    // Push children in reverse so that the first-added child is visited first; the child
    // toward the end goes to the bottom (visited last).
    const auto& ch = t.children[v];
    int last = -1;
    for (int c : ch)
      if (toward_end[c]) last = c;
    if (last >= 0) stack.emplace_back(last, false);
    for (auto it = ch.rbegin(); it != ch.rend(); ++it)
      if (*it != last) stack.emplace_back(*it, false);
  }
  if (inst.Closed()) route.push_back(OpInstance::kHome);
  return route;
}

// Paper, NewAlg step 1: the two rounds of tree growth. Returns the depth-first route of the tree.
std::vector<int> GrowTree(const OpInstance& inst, nlohmann::json* stats,
                          const std::function<void(const std::string&)>& progress) {
  auto last_report = std::chrono::steady_clock::now();
  auto report = [&](const char* round, int added, int rejected) {
    if (!progress || std::chrono::steady_clock::now() - last_report < std::chrono::seconds(2)) {
      return;
    }
    last_report = std::chrono::steady_clock::now();
    progress(std::string("growing the tree, ") + round + ": " + std::to_string(added) +
             " sites added, " + std::to_string(rejected) + " did not fit");
  };
  const int n = inst.Size();
  const double inf = std::numeric_limits<double>::infinity();
  Tree t;
  t.parent.assign(n, -1);
  t.children.assign(n, {});
  t.in.assign(n, 0);
  std::vector<double> conn(n, inf);
  std::vector<int> conn_to(n, -1);
  std::vector<char> toward_end(n, 0);  // on the tree path home..end (paths only)
  auto attach = [&](int v, int parent, double c) {
    t.in[v] = 1;
    t.parent[v] = parent;
    t.children[parent].push_back(v);
    t.cost += c;
  };
  auto detach = [&](int v, double c) {
    t.children[t.parent[v]].pop_back();
    t.in[v] = 0;
    t.parent[v] = -1;
    t.cost -= c;
  };
  // Connection costs of the sites outside the tree after `v` joined it.
  auto update_conn = [&](int v) {
    for (int u = inst.FirstSite(); u < n; ++u) {
      if (t.in[u]) continue;
      const double cu = inst.Cost(v, u);
      if (cu < conn[u]) {
        conn[u] = cu;
        conn_to[u] = v;
      }
    }
  };
  auto add = [&](int v, int parent, double c) {
    if (parent >= 0) attach(v, parent, c);
    t.in[v] = 1;
    update_conn(v);
  };
  add(OpInstance::kHome, -1, 0);
  double limit1 = inst.budget_m / 2;
  if (!inst.Closed()) {
    const double he = inst.Cost(OpInstance::kHome, inst.end);
    add(inst.end, OpInstance::kHome, he);
    toward_end[inst.end] = 1;
    limit1 = (inst.budget_m + he) / 2;
  }
  auto best_by_ratio = [&](auto&& admissible) {
    int best = -1;
    double best_ratio = -1;
    for (int v = inst.FirstSite(); v < n; ++v) {
      if (t.in[v] || inst.nodes[v].reward <= 0 || !admissible(v)) continue;
      const double ratio = inst.nodes[v].reward / std::max(conn[v], kTinyCost);
      if (ratio > best_ratio) {
        best_ratio = ratio;
        best = v;
      }
    }
    return best;
  };
  // Round 1: tree cost <= B/2.
  int round1 = 0;
  for (;;) {
    const int v = best_by_ratio([&](int u) { return t.cost + conn[u] <= limit1; });
    if (v < 0) break;
    add(v, conn_to[v], conn[v]);
    ++round1;
    report("round 1", round1, 0);
  }
  // Round 2: the depth-first route must stay within B. A site that does not fit is not
  // tried again.
  const double limit2 = inst.budget_m + BudgetSlack(inst.budget_m);
  std::vector<char> rejected(n, 0);
  std::vector<int> route = DfsRoute(inst, t, toward_end);
  // Round 1's bound (route <= 2 x tree) needs the triangle inequality, which costs over
  // terrain (climbs round a ridge) need not satisfy: then the tree starts again and every
  // site joins it through round 2's check.
  if (inst.RouteCost(route) > limit2) {
    for (auto& c : t.children) c.clear();
    std::fill(t.parent.begin(), t.parent.end(), -1);
    std::fill(conn.begin(), conn.end(), inf);
    std::fill(conn_to.begin(), conn_to.end(), -1);
    t.cost = 0;
    t.in.assign(n, 0);
    add(OpInstance::kHome, -1, 0);
    if (!inst.Closed()) add(inst.end, OpInstance::kHome, inst.Cost(OpInstance::kHome, inst.end));
    round1 = 0;
    route = DfsRoute(inst, t, toward_end);
    (*stats)["tree_round1_undone"] = true;
  }
  int round2 = 0, rejections = 0;
  for (;;) {
    report("round 2", round2, rejections);
    const int v = best_by_ratio([&](int u) { return !rejected[u]; });
    if (v < 0) break;
    const double c = conn[v];
    attach(v, conn_to[v], c);
    std::vector<int> trial = DfsRoute(inst, t, toward_end);
    if (inst.RouteCost(trial) <= limit2) {
      update_conn(v);
      route = std::move(trial);
      ++round2;
    } else {
      detach(v, c);
      rejected[v] = 1;
      ++rejections;
    }
  }
  (*stats)["tree_round1"] = round1;
  (*stats)["tree_round2"] = round2;
  (*stats)["tree_cost_m"] = t.cost;
  return route;
}

// Paper, NewAlg step 4: steps 2-3 repeated until no site is inserted.
void ImproveLoop(const OpInstance& inst, std::vector<int>* route, std::vector<char>* in_route,
                 uint64_t seed, int max_rounds, RouteOpsStats* ops, int* rounds,
                 const std::function<void(const std::string&)>& progress = {}) {
  for (int r = 0; r < max_rounds; ++r) {
    ++*rounds;
    ReorderWithLkh(inst, route, seed + static_cast<uint64_t>(r), ops);
    const int inserted = InsertByRatio(inst, route, in_route, ops);
    if (progress) {
      progress("round " + std::to_string(r + 1) + ": " + std::to_string(route->size() - 2) +
               " sites on the route, " + std::to_string(inserted) + " inserted");
    }
    if (inserted == 0) break;
  }
}

std::vector<char> Membership(const OpInstance& inst, const std::vector<int>& route) {
  std::vector<char> in(inst.Size(), 0);
  for (int v : route) in[v] = 1;
  return in;
}

void Finish(const OpInstance& inst, PlanResult* res, const RouteOpsStats& ops, int rounds) {
  res->reward = inst.RouteReward(res->route);
  res->cost = inst.RouteCost(res->route);
  res->stats["rounds"] = rounds;
  res->stats["lkh_calls"] = ops.lkh_calls;
  res->stats["lkh_max_nodes"] = ops.lkh_max_nodes;
  res->stats["inserted"] = ops.inserted;
}

// NewAlg with the caller's statistics (and LKH warm-start penalties).
PlanResult RunNewAlg(const OpInstance& inst, const NewAlgOptions& opt, RouteOpsStats* ops) {
  PlanResult res;
  res.stats = nlohmann::json::object();
  res.stats["name"] = "newalg";
  res.route = GrowTree(inst, &res.stats, opt.progress);
  if (opt.progress) {
    opt.progress("tree grown: " + std::to_string(res.route.size() - 2) + " sites on its route");
  }
  std::vector<char> in_route = Membership(inst, res.route);
  int rounds = 0;
  ImproveLoop(inst, &res.route, &in_route, opt.seed, opt.max_rounds, ops, &rounds, opt.progress);
  Finish(inst, &res, *ops, rounds);
  return res;
}

}  // namespace

PlanResult SolveNewAlg(const OpInstance& inst, const NewAlgOptions& opt) {
  RouteOpsStats ops;
  return RunNewAlg(inst, opt, &ops);
}

PlanResult SolveNewAlgLs(const OpInstance& inst, const NewAlgOptions& opt) {
  const auto start = std::chrono::steady_clock::now();
  RouteOpsStats ops;
  PlanResult res = RunNewAlg(inst, opt, &ops);
  const double newalg_reward = res.reward;
  res.stats["name"] = "newalg-ls";
  std::mt19937_64 rng(opt.seed ^ 0xA5A5A5A5ULL);
  int rounds = res.stats["rounds"].get<int>(), accepted = 0, iterations = 0;
  int rewarded = 0;
  for (int v = inst.FirstSite(); v < inst.Size(); ++v) rewarded += inst.nodes[v].reward > 0;
  for (int it = 0; it < opt.ls_iterations; ++it) {
    // Nothing left to gain once every site with a reward is on the route.
    int on_route = 0;
    for (int v : res.route) on_route += inst.IsSite(v) && inst.nodes[v].reward > 0;
    if (on_route == rewarded) break;
    if (opt.ls_time_limit_s > 0 &&
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() >
            opt.ls_time_limit_s) {
      break;
    }
    ++iterations;
    std::vector<int> route = res.route;
    const std::vector<int> before = route;
    const int sites = static_cast<int>(route.size()) - 2;
    if (sites > 0) {
      const int k = 1 + static_cast<int>(rng() % std::max(1, std::min(4, (sites + 2) / 3)));
      if (rng() % 2 == 0) {
        // A run of k consecutive sites.
        const int first = 1 + static_cast<int>(rng() % sites);
        const int last = std::min(first + k, static_cast<int>(route.size()) - 1);
        route.erase(route.begin() + first, route.begin() + last);
      } else {
        for (int j = 0; j < k && route.size() > 2; ++j) {
          const int pos = 1 + static_cast<int>(rng() % (route.size() - 2));
          route.erase(route.begin() + pos);
        }
      }
    }
    // Repair: first without the removed sites (otherwise the greedy puts them straight
    // back), then with everything.
    std::vector<char> in_route = Membership(inst, route);
    std::vector<char> removed(inst.Size(), 0);
    for (int v : before)
      if (!in_route[v]) removed[v] = 1;
    ReorderWithLkh(inst, &route, opt.seed + 1000 + static_cast<uint64_t>(it), &ops);
    InsertByRatio(inst, &route, &in_route, &ops, &removed);
    ImproveLoop(inst, &route, &in_route, opt.seed + 2000 + static_cast<uint64_t>(it),
                opt.max_rounds, &ops, &rounds);
    if (inst.Better(route, inst.RouteCost(route), res.route, inst.RouteCost(res.route))) {
      res.route = std::move(route);
      ++accepted;
    }
  }
  res.stats["ls_iterations"] = iterations;
  res.stats["ls_accepted"] = accepted;
  res.stats["newalg_reward"] = newalg_reward;
  Finish(inst, &res, ops, rounds);
  return res;
}

}  // namespace mound::plan
