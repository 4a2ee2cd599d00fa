// ALNS-OP: an adaptive large-neighbourhood search for the orienteering problem, the
// planner's state-of-the-art heuristic (`mound_plan --algo alns`, alias `best`).
//
// After Ropke & Pisinger (2006) for the search frame, Kobeaga, Merino & Lozano (2018,
// EA4OP) for the OP moves (add by ratio, drop, the budget kept as a hard constraint, route
// lengths kept short by a Lin-Kernighan engine) and Vidal (2022, HGS) for cheap 2-opt /
// Or-opt in between and restarts from an elite route:
//
//  1. Start from NewAlg (the paper's algorithm) and a local search.
//  2. Each iteration ruins the current route (k sites removed by one of four operators:
//     random, a run of consecutive sites, the worst reward per saved metre, the sites
//     nearest a random one) and recreates it by noisy ratio insertion (first without the
//     removed sites, then with all), followed by the local search: 2-opt and Or-opt (runs
//     of 1-3 sites, both orientations) to shorten the route, insertion by ratio into the
//     freed budget, and 1-1 replacements of a visited site by an unvisited one of more
//     reward, until none applies.
//  3. Operators are chosen by roulette on weights that adapt to their success (new best,
//     better than current, accepted). Acceptance is record-to-record travel on reward
//     (the threshold shrinks to zero over the run); after a stretch without a new best the
//     search restarts from the best route.
//  4. Every new best route is re-ordered by the project's LKH engine and refilled.
//
// Routes are always within the budget. Deterministic for a seed and limits on any machine
// load: the acceptance schedule, the restarts and the time limit all run on work ticks
// (cost lookups, LKH charged by its size; kAlnsTicksPerSecond of them make a second on the
// reference machine). The wall clock only stops a search that runs kAlnsWallFactor times
// over its limit (a machine far slower than the reference); stats say so when it did.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "plan/flights.h"
#include "plan/newalg.h"
#include "plan/op_instance.h"

namespace mound::plan {

// Work ticks per second of the time limit, measured on the reference machine (2 cores of
// the CI runner) over the standard fields and OPLib: about 1 s of search per second.
constexpr double kAlnsTicksPerSecond = 5.0e8;
constexpr double kAlnsWallFactor = 10.0;

struct AlnsOptions {
  uint64_t seed = 1;
  int max_iterations = 1 << 30;          // ruin-and-recreate iterations
  int stagnation = 0;                    // stop after this many without a new best; 0: automatic
  double time_limit_s = 1.0;             // in work ticks (see above); <= 0: no limit
  double wall_factor = kAlnsWallFactor;  // wall-clock guard: time_limit_s * wall_factor
};

// What a search did, typed (PlanResult::stats / FlightsResult::stats hold ToJson()).
struct AlnsStats {
  int flights = 1;
  double start_reward = 0;  // K = 1: NewAlg's route; K > 1: ALNS-OP flight by flight
  int iterations = 0, new_bests = 0;
  int lkh_polishes = 0, restarts = 0, spread_starts_won = 0;  // K = 1
  std::string stopped_by;  // "time limit (work ticks)", "all sites visited", ...
  uint64_t work_ticks = 0;
  struct Ruin {
    std::string name;   // random | segment | worst | related
    double weight = 0;  // the roulette's at the end
    int new_bests = 0;
  };
  std::vector<Ruin> ruins;  // K = 1
  double elapsed_s = 0;

  // The plan file's `solver` object: name "alns", newalg_reward or (K > 1) flights and
  // sequential_start_reward, the counts, stopped_by, work_ticks, ruins, elapsed_s.
  nlohmann::json ToJson() const;
};

// `stats`, when given, receives the typed statistics.
PlanResult SolveAlns(const OpInstance& inst, const AlnsOptions& opt, AlnsStats* stats = nullptr);

// Several flights from the same home (the team orienteering problem): K routes, each
// within the budget, no site in two, the most reward in all. K = 1 is SolveAlns. For
// K > 1 the same search on K routes: the start is ALNS-OP flight by flight on the sites
// left (a quarter of the work), then each iteration ruins one flight or all of them,
// recreates each flight in a random order (the other flights' sites excluded), runs each
// flight's local search and the moves between flights (relocate, exchange, cross), and
// refills the budget they free. Flights are returned in order of reward, best first.
FlightsResult SolveAlnsFlights(const OpInstance& inst, int flights, const AlnsOptions& opt,
                               AlnsStats* stats = nullptr);

}  // namespace mound::plan
