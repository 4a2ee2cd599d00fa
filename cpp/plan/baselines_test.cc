#include "plan/baselines.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>
#include <set>
#include <utility>

#include "plan/alns.h"
#include "plan/exact_small.h"
#include "plan/test_instances.h"

namespace mound::plan {
namespace {

OpInstance RandomInstance(int sites, bool closed, double budget, unsigned seed) {
  return test_instances::RandomInstance(sites, closed, budget, seed, /*random_home=*/true);
}

void ExpectFeasible(const OpInstance& inst, const PlanResult& r, const char* what) {
  test_instances::ExpectValidRoute(inst, r, what);
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
    const PlanResult g = SolveGreedy(inst), t = SolveTsiligirides(inst, opt),
                     v = SolveGlv(inst, opt);
    ExpectFeasible(inst, g, "greedy");
    ExpectFeasible(inst, t, "tsiligirides");
    ExpectFeasible(inst, v, "glv");
    for (const PlanResult* r : {&g, &t, &v}) EXPECT_LE(r->reward, exact.reward + 1e-9);
    sum[0] += g.reward;
    sum[1] += t.reward;
    sum[2] += v.reward;
    sum_exact += exact.reward;
  }
  std::cout << "[ reward  ] share of the optimum over 120 instances: greedy " << sum[0] / sum_exact
            << ", tsiligirides " << sum[1] / sum_exact << ", glv " << sum[2] / sum_exact << "\n";
  EXPECT_GT(sum[1], sum[0]);  // 200 randomised routes beat the single greedy route
}

TEST(BaselinesTest, LargerInstancesStayFeasibleAndCollectReward) {
  for (bool closed : {true, false}) {
    OpInstance inst = RandomInstance(150, closed, 0, 9);
    test_instances::ScaleCoordinates(&inst, 10);
    inst.budget_m = std::max(300.0, inst.Cost(0, inst.end) + 10);
    BaselineOptions opt;
    AlnsOptions ao;
    ao.time_limit_s = 0.5;
    const PlanResult best = SolveAlns(inst, ao);
    ExpectFeasible(inst, best, "alns");
    ASSERT_GT(best.route.size(), 12u);  // the budget reaches many of the 150 sites
    for (const auto& [name, r] : {std::pair{"greedy", SolveGreedy(inst)},
                                  std::pair{"tsiligirides", SolveTsiligirides(inst, opt)},
                                  std::pair{"glv", SolveGlv(inst, opt)}}) {
      ExpectFeasible(inst, r, name);
      // Not an empty route: each heuristic collects a fair share of what ALNS finds.
      EXPECT_GT(r.route.size(), 4u) << name;
      EXPECT_GT(r.reward, 0.5 * best.reward) << name;
      EXPECT_LE(r.reward, best.reward * 1.05) << name;
      std::cout << "[ reward  ] " << name << (closed ? " closed" : " path") << ": "
                << r.reward / best.reward << " of ALNS's\n";
    }
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
