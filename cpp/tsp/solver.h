// SolveTsp: the LKH driver (Helsgaun 2000, section 5; LKH's LKHmain.c/FindTour.c).
//
//   CreateCandidateSet: subgradient ascent (pi), then the alpha-nearest candidates.
//   for each run:   an initial tour by a walk over the candidate edges,
//                   Lin-Kernighan to a local optimum,
//                   trials: a random segment double-bridge kick (a non-sequential 4-opt
//                   move LK cannot undo), LK from the kicked nodes, keep the tour if it
//                   is no longer, otherwise undo everything since the kick.
//   keep the best tour over runs; stop early when it meets the 1-tree lower bound or a
//   given optimum, or when the time limit is spent (the limit covers the whole solve: the
//   ascent stops at half of it with the best penalties so far, the search uses the rest;
//   the first LK descent always completes, so a tour is always returned).
// Instances of at most 8 nodes are solved exactly by enumeration.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "tsp/candidates.h"
#include "tsp/problem.h"

namespace mound::tsp {

struct SolverOptions {
  int runs = 1;
  int max_trials = -1;  // trials per run (LK descents); <= 0: n, as LKH's MAX_TRIALS
  uint64_t seed = 1;
  int max_candidates = 5;   // alpha-nearest candidates per node
  int move_k = 5;           // basis move: sequential k-opt, 2..5
  int kick_segment = 0;     // longest segment of a double-bridge kick; <= 0: max(50, n/4)
  double time_limit_s = 0;  // <= 0: none
  Cost optimum = -1;        // stop when a tour this short is found (benchmarks)
  AscentOptions ascent;
  // One-line accounts of a long solve (ascent, candidates, runs, trials), about every 2 s.
  std::function<void(const std::string&)> progress;
};

struct SolverStats {
  double lower_bound = 0;  // Held-Karp 1-tree bound (units of D)
  int ascent_iterations = 0;
  double ascent_s = 0, candidates_s = 0, search_s = 0;
  int runs = 0;
  long long trials = 0;
  long long improving_trials = 0;
  long long lk_moves = 0;
  bool exact = false;  // solved by enumeration
};

struct TspResult {
  std::vector<int> tour;  // a permutation of 0..n-1
  Cost length = 0;
  std::vector<Cost> pi;  // the ascent's penalties (a warm start for similar instances)
  SolverStats stats;
};

TspResult SolveTsp(const Problem& problem, const SolverOptions& options);

}  // namespace mound::tsp
