// Several flights from the same home: the team orienteering problem (Chao, Golden &
// Wasil 1996). K routes, each from home to the end node within the budget, each site in
// at most one, the most reward in all.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "plan/newalg.h"
#include "plan/op_instance.h"

namespace mound::plan {

constexpr int kMaxFlights = 64;

struct FlightsResult {
  std::vector<std::vector<int>> routes;  // home ... end each, best reward first
  double reward = 0;                     // all flights
  double cost = 0;
  nlohmann::json stats;
};

// Empty string if the flights are valid (each a valid route within the budget, no site
// in two), else the reason.
std::string CheckFlights(const OpInstance& inst, const std::vector<std::vector<int>>& routes);

// Flights in order of reward (then of cost), totals filled in.
void OrderFlights(const OpInstance& inst, FlightsResult* r);

// The paper's baseline for several flights: one planner flight by flight, each on the
// sites the flights before it left (greedy: the first flight takes the best it can).
FlightsResult SequentialFlights(
    const OpInstance& inst, int flights,
    const std::function<PlanResult(const OpInstance&, int flight)>& solve_one);

// The exact optimum for small instances (at most kMaxExactFlightSites sites): the
// Held-Karp route of every subset, then the best K disjoint subsets whose routes fit,
// by dynamic programming over subsets (O(3^n K)). Tests' ground truth and --algo exact.
constexpr int kMaxExactFlightSites = 14;
FlightsResult SolveExactFlights(const OpInstance& inst, int flights);

}  // namespace mound::plan
