#include "plan/baselines.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>
#include <set>

#include "plan/exact_small.h"

namespace mound::plan {
namespace {

OpInstance RandomInstance(int sites, bool closed, double budget, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 10), rw(0, 1), sc(0, 1);
  OpInstance inst;
  inst.nodes.push_back({"home", u(rng), u(rng), 0, 0});
  if (!closed) {
    inst.nodes.push_back({"end", u(rng), u(rng), 0, 0});
    inst.end = 1;
  }
  for (int i = 0; i < sites; ++i) inst.nodes.push_back({"s" + std::to_string(i), u(rng), u(rng), rw(rng), sc(rng)});
  inst.budget_m = std::max(budget, closed ? 0.0 : inst.Cost(0, 1) + 1.0);
  return inst;
}

// Feasibility recomputed from coordinates, not through OpInstance::Cost.
void ExpectFeasible(const OpInstance& inst, const PlanResult& r, const char* what) {
  ASSERT_GE(r.route.size(), 2u) << what;
  EXPECT_EQ(r.route.front(), 0) << what;
  EXPECT_EQ(r.route.back(), inst.end) << what;
  std::set<int> seen;
  double cost = 0;
  for (size_t i = 0; i + 1 < r.route.size(); ++i) {
    const OpNode& a = inst.nodes[r.route[i]];
    const OpNode& b = inst.nodes[r.route[i + 1]];
    const double sa = inst.IsSite(r.route[i]) ? a.scan_cost_m : 0.0;
    const double sb = inst.IsSite(r.route[i + 1]) ? b.scan_cost_m : 0.0;
    cost += std::sqrt((a.x_m - b.x_m) * (a.x_m - b.x_m) + (a.y_m - b.y_m) * (a.y_m - b.y_m)) +
            (sa + sb) / 2;
    if (i > 0) {
      EXPECT_TRUE(inst.IsSite(r.route[i])) << what;
      EXPECT_TRUE(seen.insert(r.route[i]).second) << what << ": repeated site";
    }
  }
  EXPECT_LE(cost, inst.budget_m + 1e-9) << what;
  EXPECT_NEAR(r.cost, cost, 1e-9) << what;
}

TEST(BaselinesTest, FeasibleAndNeverAboveTheOptimum) {
  BaselineOptions opt;
  opt.tsiligirides_routes = 200;
  double sum[3] = {0, 0, 0}, sum_exact = 0;
  for (unsigned seed = 0; seed < 120; ++seed) {
    const bool closed = seed % 2 == 0;
    const OpInstance inst = RandomInstance(4 + seed % 7, closed, 8 + seed % 23, 500 + seed);
    const PlanResult exact = SolveExactSmall(inst);
    opt.seed = seed;
    const PlanResult g = SolveGreedy(inst), t = SolveTsiligirides(inst, opt), v = SolveGlv(inst, opt);
    ExpectFeasible(inst, g, "greedy");
    ExpectFeasible(inst, t, "tsiligirides");
    ExpectFeasible(inst, v, "glv");
    for (const PlanResult* r : {&g, &t, &v}) EXPECT_LE(r->reward, exact.reward + 1e-9);
    sum[0] += g.reward;
    sum[1] += t.reward;
    sum[2] += v.reward;
    sum_exact += exact.reward;
  }
  std::cout << "[ reward  ] share of the optimum over 120 instances: greedy "
            << sum[0] / sum_exact << ", tsiligirides " << sum[1] / sum_exact << ", glv "
            << sum[2] / sum_exact << "\n";
  EXPECT_GT(sum[1], sum[0]);  // 200 randomised routes beat the single greedy route
}

TEST(BaselinesTest, LargerInstancesStayFeasible) {
  for (bool closed : {true, false}) {
    OpInstance inst = RandomInstance(150, closed, 0, 9);
    for (auto& n : inst.nodes) {
      n.x_m *= 10;
      n.y_m *= 10;
    }
    inst.budget_m = std::max(300.0, inst.Cost(0, inst.end) + 10);
    BaselineOptions opt;
    ExpectFeasible(inst, SolveGreedy(inst), "greedy");
    ExpectFeasible(inst, SolveTsiligirides(inst, opt), "tsiligirides");
    ExpectFeasible(inst, SolveGlv(inst, opt), "glv");
  }
}

TEST(BaselinesTest, TsiligiridesIsDeterministicForASeed) {
  const OpInstance inst = RandomInstance(40, true, 30, 77);
  BaselineOptions a;
  a.seed = 5;
  a.tsiligirides_routes = 100;
  EXPECT_EQ(SolveTsiligirides(inst, a).route, SolveTsiligirides(inst, a).route);
}

TEST(BaselinesTest, GreedyFollowsTheRewardPerStepRule) {
  // home (0,0); a at 1 m with reward 1 (ratio 1); b at 2 m with reward 3 (ratio 1.5).
  // Greedy takes b first; from b, a costs 1 more and still returns within 5 m.
  OpInstance inst;
  inst.nodes = {{"home", 0, 0, 0, 0}, {"a", 1, 0, 1, 0}, {"b", 2, 0, 3, 0}};
  inst.budget_m = 5;
  const PlanResult r = SolveGreedy(inst);
  EXPECT_EQ(r.route, (std::vector<int>{0, 2, 1, 0}));
  inst.budget_m = 3.5;  // b no longer fits (a 4 m round trip); a does
  EXPECT_EQ(SolveGreedy(inst).route, (std::vector<int>{0, 1, 0}));
}

TEST(BaselinesTest, TwoOptUntanglesACrossing) {
  OpInstance inst;
  inst.nodes = {{"home", 0, 0, 0, 0}, {"a", 0, 1, 1, 0}, {"b", 1, 0, 1, 0}, {"c", 1, 1, 1, 0}};
  inst.budget_m = 10;
  std::vector<int> route{0, 3, 1, 2, 0};  // home-c-a-b-home crosses itself
  EXPECT_GT(TwoOptRoute(inst, &route), 0);
  EXPECT_NEAR(inst.RouteCost(route), 4.0, 1e-12);
}

}  // namespace
}  // namespace mound::plan
