#include "plan/flights.h"

#include <gtest/gtest.h>

#include <iostream>
#include <set>

#include "plan/alns.h"
#include "plan/exact_small.h"
#include "plan/test_instances.h"

namespace mound::plan {
namespace {

using test_instances::RandomInstance;

// Each flight valid by the independent cost formula, no site in two flights, totals and
// the order (best reward first) as reported.
void ExpectValidFlights(const OpInstance& inst, const FlightsResult& r, int flights,
                        const std::string& what) {
  ASSERT_EQ(static_cast<int>(r.routes.size()), flights) << what;
  std::set<int> seen;
  double reward = 0, cost = 0, prev = 1e300;
  for (const auto& route : r.routes) {
    PlanResult one;
    one.route = route;
    one.cost = test_instances::IndependentCost(inst, route);
    one.reward = 0;
    for (size_t i = 1; i + 1 < route.size(); ++i) {
      one.reward += inst.nodes[route[i]].reward;
      EXPECT_TRUE(seen.insert(route[i]).second) << what << ": site in two flights";
    }
    test_instances::ExpectValidRoute(inst, one, what);
    EXPECT_LE(one.reward, prev + 1e-12) << what << ": flights not ordered by reward";
    prev = one.reward;
    reward += one.reward;
    cost += one.cost;
  }
  EXPECT_NEAR(r.reward, reward, 1e-9) << what;
  EXPECT_NEAR(r.cost, cost, 1e-6) << what;
  EXPECT_EQ(CheckFlights(inst, r.routes), "") << what;
}

AlnsOptions Fixed(uint64_t seed, int iterations) {
  AlnsOptions o;
  o.seed = seed;
  o.max_iterations = iterations;
  o.time_limit_s = 0;
  return o;
}

// One flight: the exact DP for K flights agrees with Held-Karp, and ALNS-K is ALNS.
TEST(FlightsTest, OneFlightIsTodaysPlan) {
  for (unsigned seed = 0; seed < 20; ++seed) {
    const OpInstance inst = RandomInstance(5 + seed % 8, seed % 2 == 0, 10 + seed, 300 + seed);
    EXPECT_NEAR(SolveExactFlights(inst, 1).reward, SolveExactSmall(inst).reward, 1e-9);
    const PlanResult one = SolveAlns(inst, Fixed(seed, 300));
    const FlightsResult k1 = SolveAlnsFlights(inst, 1, Fixed(seed, 300));
    ASSERT_EQ(k1.routes.size(), 1u);
    EXPECT_EQ(k1.routes[0], one.route) << seed;
  }
}

// On random closed tours and paths of <= 12 sites with 2-4 flights: ALNS-K at the exact
// optimum on every instance, flight-by-flight NewAlg never above it.
TEST(FlightsTest, AlnsReachesTheExactOptimumWithSeveralFlights) {
  int optimal = 0, count = 0, newalg_optimal = 0;
  double newalg_ratio = 0;
  for (unsigned seed = 0; seed < 60; ++seed) {
    const bool closed = seed % 3 != 0;
    const int k = 2 + seed % 3;
    OpInstance inst = RandomInstance(7 + seed % 6, closed, 0, 9100 + seed);
    inst.budget_m = (closed ? 9.0 : inst.Cost(0, 1) + 5.0) + seed % 7;
    if (seed % 4 == 1) test_instances::AddRandomTerrain(&inst, seed, 1.0);
    const std::string what = "seed " + std::to_string(seed) + ", " + std::to_string(k) + " flights";
    const FlightsResult exact = SolveExactFlights(inst, k);
    ExpectValidFlights(inst, exact, k, what + " exact");
    const FlightsResult a = SolveAlnsFlights(inst, k, Fixed(seed, 400));
    ExpectValidFlights(inst, a, k, what + " alns");
    NewAlgOptions no;
    const FlightsResult nf = SequentialFlights(
        inst, k, [&](const OpInstance& sub, int) { return SolveNewAlg(sub, no); });
    ExpectValidFlights(inst, nf, k, what + " newalg");
    EXPECT_LE(a.reward, exact.reward + 1e-9) << what;
    EXPECT_LE(nf.reward, exact.reward + 1e-9) << what;
    EXPECT_GE(a.reward, exact.reward - 1e-9) << what << " (optimum " << exact.reward << ")";
    optimal += a.reward >= exact.reward - 1e-9;
    newalg_optimal += nf.reward >= exact.reward - 1e-9;
    newalg_ratio += exact.reward > 0 ? nf.reward / exact.reward : 1.0;
    ++count;
  }
  std::cout << "[ flights ] ALNS-K optimal on " << optimal << " of " << count
            << "; NewAlg flight by flight on " << newalg_optimal << ", mean "
            << 100 * newalg_ratio / count << " % of the optimum\n";
}

// Equal seeds and the default time limit: equal flights.
TEST(FlightsTest, RepeatableAtTheDefaultTimeLimit) {
  OpInstance inst = RandomInstance(200, true, 0, 77);
  test_instances::ScaleCoordinates(&inst, 20);
  inst.budget_m = 300;
  AlnsOptions o;
  o.wall_factor = 100;  // sanitizers
  AlnsStats st;
  const FlightsResult a = SolveAlnsFlights(inst, 3, o, &st);
  const FlightsResult b = SolveAlnsFlights(inst, 3, o);
  ExpectValidFlights(inst, a, 3, "200 sites");
  EXPECT_EQ(a.routes, b.routes);
  EXPECT_GT(a.reward, 0);
  std::cout << "[ flights ] 200 sites, 3 flights: reward " << a.reward << " (flight by flight "
            << st.start_reward << "), " << st.iterations << " iterations, " << st.elapsed_s
            << " s\n";
  EXPECT_EQ(st.flights, 3);
  EXPECT_EQ(a.stats, st.ToJson());
}

}  // namespace
}  // namespace mound::plan
