// Helpers shared by the planner tests (not part of the library).
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "plan/newalg.h"
#include "plan/op_instance.h"

namespace mound::plan::test_instances {

// Sites uniform in a 10 x 10 m square with rewards and scan costs in [0, 1]; home at the
// origin or random; a path gets a random end node. The budget is raised to the direct
// home->end trip + 1 m where needed, so the instance is always valid.
inline OpInstance RandomInstance(int sites, bool closed, double budget, unsigned seed,
                                 bool random_home = false) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 10), unit(0, 1);
  OpInstance inst;
  const double hx = random_home ? u(rng) : 0.0, hy = random_home ? u(rng) : 0.0;
  inst.nodes.push_back({"home", hx, hy, 0, 0});
  if (!closed) {
    inst.nodes.push_back({"end", u(rng), u(rng), 0, 0});
    inst.end = 1;
  }
  for (int i = 0; i < sites; ++i) {
    const double x = u(rng), y = u(rng), r = unit(rng), s = unit(rng);
    inst.nodes.push_back({"s" + std::to_string(i), x, y, r, s});
  }
  inst.budget_m = std::max(budget, closed ? 0.0 : inst.Cost(0, 1) + 1.0);
  return inst;
}

// Multiplies every node's coordinates by `factor` (sparser layouts of the same instance).
inline void ScaleCoordinates(OpInstance* inst, double factor) {
  for (auto& n : inst->nodes) {
    n.x_m *= factor;
    n.y_m *= factor;
  }
}

// Symmetric climb costs over a random terrain (terrain.extra_m): a height per node and
// per pair a ridge between them, so that the costs break the triangle inequality.
inline void AddRandomTerrain(OpInstance* inst, unsigned seed, double scale) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  const size_t n = inst->nodes.size();
  std::vector<double> h(n);
  for (auto& v : h) v = scale * u(rng);
  inst->extra_m.assign(n * n, 0.0);
  for (size_t i = 0; i < n; ++i)
    for (size_t j = 0; j < i; ++j) {
      const double ridge = u(rng) < 0.2 ? 3 * scale * u(rng) : 0.0;
      const double top = std::max(std::max(h[i], h[j]), ridge);
      inst->extra_m[i * n + j] = inst->extra_m[j * n + i] = 2.5 * (2 * top - h[i] - h[j]);
    }
}

// The cost formula of INTERFACES.md written out again, independent of OpInstance::Cost.
inline double IndependentCost(const OpInstance& inst, const std::vector<int>& route) {
  double c = 0;
  for (size_t i = 0; i + 1 < route.size(); ++i) {
    const OpNode& a = inst.nodes[route[i]];
    const OpNode& b = inst.nodes[route[i + 1]];
    const double sa = inst.IsSite(route[i]) ? a.scan_cost_m : 0.0;
    const double sb = inst.IsSite(route[i + 1]) ? b.scan_cost_m : 0.0;
    c += std::sqrt((a.x_m - b.x_m) * (a.x_m - b.x_m) + (a.y_m - b.y_m) * (a.y_m - b.y_m)) +
         (sa + sb) / 2;
    if (!inst.extra_m.empty()) c += inst.extra_m[route[i] * inst.nodes.size() + route[i + 1]];
  }
  return c;
}

// Home first, end last, sites only once, cost within budget, reported cost and reward
// equal to the recomputed ones.
inline void ExpectValidRoute(const OpInstance& inst, const PlanResult& r, const std::string& what) {
  ASSERT_GE(r.route.size(), 2u) << what;
  EXPECT_EQ(r.route.front(), 0) << what;
  EXPECT_EQ(r.route.back(), inst.end) << what;
  std::set<int> seen;
  double reward = 0;
  for (size_t i = 1; i + 1 < r.route.size(); ++i) {
    const int v = r.route[i];
    ASSERT_TRUE(v >= inst.FirstSite() && v < inst.Size()) << what;
    EXPECT_TRUE(seen.insert(v).second) << what << ": site twice: " << v;
    reward += inst.nodes[v].reward;
  }
  const double cost = IndependentCost(inst, r.route);
  EXPECT_LE(cost, inst.budget_m + 1e-9) << what;
  EXPECT_NEAR(r.cost, cost, 1e-9) << what;
  EXPECT_NEAR(r.reward, reward, 1e-9) << what;
}

}  // namespace mound::plan::test_instances
