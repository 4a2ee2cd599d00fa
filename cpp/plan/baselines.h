// The paper's baseline orienteering heuristics, each from its original description.
//
// greedy ("BenAlg"): grow a path from home; among the sites that still leave enough budget
//   to reach the end node, add the one with the highest reward per incremental cost from
//   the last added node; go to the end node when none fits.
// tsiligirides: Tsiligirides (1984), "Heuristic methods applied to orienteering", J. Oper.
//   Res. Soc. 35(9):797-809, the stochastic S-algorithm: build `routes` routes (3,000 in the
//   original); each step scores the feasible sites by desirability A_j = (S_j / C_last,j)^4,
//   keeps the four best and picks one of them at random with probability proportional to
//   A_j; the best route is kept. Deterministic for a seed.
// glv: Golden, Levy & Vohra (1987), "The orienteering problem", Naval Res. Logistics
//   34:307-318, the centre-of-gravity heuristic: (1) centre of gravity g of all sites
//   weighted by reward; (2) route construction: sites in decreasing order of reward /
//   distance to g, each put at its cheapest insertion position if the budget allows;
//   (3) route improvement: 2-opt, then cheapest insertion of the remaining sites;
//   (4) g := the reward-weighted centre of the route's sites, back to (2); stop when the
//   route repeats or after `iterations`; keep the best route.
#pragma once

#include <cstdint>

#include "plan/newalg.h"
#include "plan/op_instance.h"

namespace mound::plan {

struct BaselineOptions {
  uint64_t seed = 1;
  int tsiligirides_routes = 3000;
  int tsiligirides_candidates = 4;
  double tsiligirides_exponent = 4.0;
  int glv_iterations = 20;
};

PlanResult SolveGreedy(const OpInstance& inst);
PlanResult SolveTsiligirides(const OpInstance& inst, const BaselineOptions& opt);
PlanResult SolveGlv(const OpInstance& inst, const BaselineOptions& opt);

// 2-opt on a route with fixed first and last node, first improvement until no gain.
// Returns the number of improving moves.
int TwoOptRoute(const OpInstance& inst, std::vector<int>* route);

}  // namespace mound::plan
