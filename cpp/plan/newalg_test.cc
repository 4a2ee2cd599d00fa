#include "plan/newalg.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <numeric>
#include <random>
#include <set>

#include "plan/exact_small.h"
#include "plan/test_instances.h"

namespace mound::plan {
namespace {

using test_instances::IndependentCost;
using test_instances::RandomInstance;

void ExpectValid(const OpInstance& inst, const PlanResult& r) {
  test_instances::ExpectValidRoute(inst, r, "route");
}

// Reference optimum by plain enumeration of every ordered selection (<= 7 sites).
double EnumeratedOptimum(const OpInstance& inst) {
  const int first = inst.FirstSite(), m = inst.Size() - first;
  double best = 0;
  for (int mask = 0; mask < (1 << m); ++mask) {
    std::vector<int> sel;
    for (int j = 0; j < m; ++j)
      if (mask >> j & 1) sel.push_back(first + j);
    double reward = 0;
    for (int v : sel) reward += inst.nodes[v].reward;
    if (reward <= best) continue;
    do {
      std::vector<int> route{0};
      route.insert(route.end(), sel.begin(), sel.end());
      route.push_back(inst.end);
      if (IndependentCost(inst, route) <= inst.budget_m + 1e-9) {
        best = reward;
        break;
      }
    } while (std::next_permutation(sel.begin(), sel.end()));
  }
  return best;
}

TEST(ExactSmallTest, AgreesWithEnumeration) {
  for (unsigned seed = 0; seed < 40; ++seed) {
    const bool closed = seed % 2 == 0;
    const OpInstance inst = RandomInstance(3 + seed % 5, closed, 8 + seed % 17, seed);
    const PlanResult r = SolveExactSmall(inst);
    ExpectValid(inst, r);
    EXPECT_NEAR(r.reward, EnumeratedOptimum(inst), 1e-9) << "seed " << seed;
  }
}

// NewAlg and NewAlg-LS on random instances of <= 10 sites: valid, never above the
// optimum; the mean gap is printed.
TEST(NewAlgTest, NeverAboveOptimumOnSmallInstancesAndGapIsReported) {
  double gap_newalg = 0, gap_ls = 0;
  int count = 0, optimal_newalg = 0, optimal_ls = 0;
  for (unsigned seed = 0; seed < 200; ++seed) {
    const bool closed = seed % 3 != 0;
    const OpInstance inst = RandomInstance(4 + seed % 7, closed, 10 + seed % 25, 1000 + seed);
    const PlanResult exact = SolveExactSmall(inst);
    NewAlgOptions opt;
    opt.seed = seed;
    opt.ls_iterations = 50;
    const PlanResult a = SolveNewAlg(inst, opt);
    const PlanResult b = SolveNewAlgLs(inst, opt);
    ExpectValid(inst, a);
    ExpectValid(inst, b);
    EXPECT_LE(a.reward, exact.reward + 1e-9);
    EXPECT_LE(b.reward, exact.reward + 1e-9);
    EXPECT_GE(b.reward, a.reward - 1e-9);  // the local search starts from NewAlg
    if (exact.reward > 0) {
      gap_newalg += (exact.reward - a.reward) / exact.reward;
      gap_ls += (exact.reward - b.reward) / exact.reward;
      ++count;
    }
    optimal_newalg += a.reward >= exact.reward - 1e-9;
    optimal_ls += b.reward >= exact.reward - 1e-9;
  }
  std::cout << "[ gap     ] 200 instances <= 10 sites: NewAlg mean gap " << 100 * gap_newalg / count
            << "%, optimal in " << optimal_newalg << "; newalg-ls mean gap " << 100 * gap_ls / count
            << "%, optimal in " << optimal_ls << "\n";
  RecordProperty("newalg_mean_gap_pct", std::to_string(100 * gap_newalg / count));
  RecordProperty("newalg_ls_mean_gap_pct", std::to_string(100 * gap_ls / count));
  EXPECT_LT(gap_ls / count, 0.02);
}

TEST(NewAlgTest, LargerInstancesAreValidAndDeterministic) {
  for (bool closed : {true, false}) {
    OpInstance inst = RandomInstance(300, closed, 0, 7);
    test_instances::ScaleCoordinates(&inst, 100);
    inst.budget_m = 3000;
    NewAlgOptions opt;
    opt.seed = 3;
    const PlanResult a = SolveNewAlg(inst, opt);
    const PlanResult b = SolveNewAlg(inst, opt);
    ExpectValid(inst, a);
    EXPECT_EQ(a.route, b.route);
    EXPECT_GT(a.route.size(), 10u);
    // Nothing left out would still fit by cheapest insertion (step 3 ran to the end).
    std::vector<char> in(inst.Size(), 0);
    for (int v : a.route) in[v] = 1;
    for (int v = inst.FirstSite(); v < inst.Size(); ++v) {
      if (in[v] || inst.nodes[v].reward <= 0) continue;
      for (size_t i = 0; i + 1 < a.route.size(); ++i) {
        const int x = a.route[i], y = a.route[i + 1];
        const double d = inst.Cost(x, v) + inst.Cost(v, y) - inst.Cost(x, y);
        EXPECT_GT(a.cost + d, inst.budget_m - 1e-9);
      }
    }
  }
}

}  // namespace
}  // namespace mound::plan
