// NewAlg's two building blocks on their own: ReorderWithLkh (step 2) keeps the route's
// nodes and its ends, never lengthens it, and finds the optimal order of small routes
// (checked by enumeration); InsertByRatio (step 3) inserts by reward per insertion cost,
// cheapest position first, within the budget, skipping blocked sites (checked by hand on a
// constructed instance and against a plain re-implementation on random ones; that
// comparison found the incremental version scanning only the route's first edges).
#include "plan/route_ops.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <set>

#include "plan/test_instances.h"

namespace mound::plan {
namespace {

using test_instances::IndependentCost;
using test_instances::RandomInstance;

OpNode Site(const std::string& id, double x, double y, double reward) {
  return {id, x, y, reward, 0.0};
}

TEST(ReorderWithLkh, KeepsNodesAndEndsAndFindsTheBestOrderOfSmallRoutes) {
  for (unsigned seed = 0; seed < 12; ++seed) {
    const bool closed = seed % 2 == 0;
    const OpInstance inst = RandomInstance(8, closed, 1e9, 300 + seed);
    std::vector<int> route{0};
    for (int v = inst.FirstSite(); v < inst.Size(); ++v) route.push_back(v);
    route.push_back(inst.end);
    std::mt19937 rng(seed);
    std::shuffle(route.begin() + 1, route.end() - 1, rng);
    const double before = inst.RouteCost(route);
    // The optimum over every order of the sites between the fixed ends.
    std::vector<int> inner(route.begin() + 1, route.end() - 1);
    std::sort(inner.begin(), inner.end());
    double best = before;
    do {
      std::vector<int> r{0};
      r.insert(r.end(), inner.begin(), inner.end());
      r.push_back(inst.end);
      best = std::min(best, inst.RouteCost(r));
    } while (std::next_permutation(inner.begin(), inner.end()));
    RouteOpsStats stats;
    std::vector<int> after = route;
    const bool shorter = ReorderWithLkh(inst, &after, seed, &stats);
    EXPECT_EQ(after.front(), 0);
    EXPECT_EQ(after.back(), inst.end);
    EXPECT_EQ(std::multiset<int>(after.begin(), after.end()),
              std::multiset<int>(route.begin(), route.end()));
    const double cost = inst.RouteCost(after);
    EXPECT_LE(cost, before + 1e-9);
    EXPECT_EQ(shorter, cost < before - 1e-9);
    EXPECT_NEAR(cost, best, 1e-6 * best) << "seed " << seed;
    EXPECT_NEAR(cost, IndependentCost(inst, after), 1e-6);
    EXPECT_EQ(stats.lkh_calls, 1);
    EXPECT_EQ(static_cast<int>(stats.pi.size()), inst.Size());  // warm start kept
  }
}

TEST(InsertByRatio, InsertsTheBestRatioFirstAtItsCheapestPlaceWithinTheBudget) {
  // Home at the origin; A 10 m east (reward 5); C 1 m north of A (reward 1); B 100 m north
  // (reward 6). Round trips: A 20 m (ratio 0.25), B 200 m (0.03), C ~20.1 m (0.05).
  OpInstance inst;
  inst.nodes = {Site("home", 0, 0, 0), Site("A", 10, 0, 5), Site("B", 0, 100, 6),
                Site("C", 10, 1, 1)};
  inst.budget_m = 60;
  std::vector<int> route{0, 0};
  std::vector<char> in_route(4, 0);
  in_route[0] = 1;
  RouteOpsStats stats;
  // A first (best ratio); then C beside it (1 m detour and back: 0 -> A -> C -> 0 costs
  // 10 + 1 + 10.05, either way round); B no longer fits 60 m.
  EXPECT_EQ(InsertByRatio(inst, &route, &in_route, &stats), 2);
  EXPECT_TRUE(route == (std::vector<int>{0, 1, 3, 0}) || route == (std::vector<int>{0, 3, 1, 0}));
  EXPECT_NEAR(inst.RouteCost(route), 11 + std::hypot(10, 1), 1e-9);
  EXPECT_TRUE(in_route[1] && in_route[3] && !in_route[2]);
  EXPECT_EQ(stats.inserted, 2);
  EXPECT_LE(inst.RouteCost(route), inst.budget_m);
  // With A blocked: C (ratio 1 / 20.1) goes in, and B still does not fit.
  std::vector<int> r2{0, 0};
  std::vector<char> in2(4, 0), blocked(4, 0);
  in2[0] = 1;
  blocked[1] = 1;
  EXPECT_EQ(InsertByRatio(inst, &r2, &in2, &stats, &blocked), 1);
  EXPECT_EQ(r2, (std::vector<int>{0, 3, 0}));
  // A budget of 250 m takes all three: B's ratio then beats nothing, but it fits.
  inst.budget_m = 250;
  std::vector<int> r3{0, 0};
  std::vector<char> in3(4, 0);
  in3[0] = 1;
  EXPECT_EQ(InsertByRatio(inst, &r3, &in3, &stats), 3);
  EXPECT_LE(inst.RouteCost(r3), 250 + 1e-9);
}

// A plain O(n^2 m) re-implementation of the rule: the unvisited site with the highest
// reward / cheapest insertion cost that fits, inserted at that cheapest place.
int ReferenceInsert(const OpInstance& inst, std::vector<int>* route, std::vector<char>* in) {
  int inserted = 0;
  for (;;) {
    double best_ratio = -1, best_delta = 0;
    int best_v = -1, best_pos = -1;
    const double cost = inst.RouteCost(*route);
    for (int v = inst.FirstSite(); v < inst.Size(); ++v) {
      if ((*in)[v]) continue;
      double delta = 1e300;
      int pos = -1;
      for (size_t k = 0; k + 1 < route->size(); ++k) {
        const int a = (*route)[k], b = (*route)[k + 1];
        const double d = inst.Cost(a, v) + inst.Cost(v, b) - inst.Cost(a, b);
        if (d < delta) {
          delta = d;
          pos = static_cast<int>(k) + 1;
        }
      }
      if (cost + delta > inst.budget_m + BudgetSlack(inst.budget_m)) continue;
      const double ratio = inst.nodes[v].reward / std::max(delta, 1e-12);
      if (ratio > best_ratio) {
        best_ratio = ratio;
        best_v = v;
        best_pos = pos;
        best_delta = delta;
      }
    }
    if (best_v < 0) return inserted;
    (void)best_delta;
    route->insert(route->begin() + best_pos, best_v);
    (*in)[best_v] = 1;
    ++inserted;
  }
}

TEST(InsertByRatio, AgreesWithAPlainReimplementationOnRandomInstances) {
  for (unsigned seed = 0; seed < 20; ++seed) {
    const bool closed = seed % 2 == 1;
    const OpInstance inst = RandomInstance(40, closed, 150 + 10 * seed, 900 + seed);
    std::vector<int> route{0, inst.end}, ref = route;
    std::vector<char> in(inst.Size(), 0), in_ref;
    in[0] = in[inst.end] = 1;
    in_ref = in;
    RouteOpsStats stats;
    const int n = InsertByRatio(inst, &route, &in, &stats);
    EXPECT_EQ(n, ReferenceInsert(inst, &ref, &in_ref)) << "seed " << seed;
    EXPECT_EQ(route, ref) << "seed " << seed;
    EXPECT_LE(inst.RouteCost(route), inst.budget_m + BudgetSlack(inst.budget_m));
  }
}

}  // namespace
}  // namespace mound::plan
