// Building blocks shared by the orienteering algorithms.
#pragma once

#include <cstdint>
#include <vector>

#include "plan/op_instance.h"
#include "tsp/solver.h"

namespace mound::plan {

// LKH settings for the many small tours the planner re-orders: a shorter ascent and
// fewer kicks than LKH's defaults for one-off TSP solving (see the benchmark figures).
struct ReorderOptions {
  int trials_divisor = 8;  // trials = max(min_trials, m / trials_divisor)
  int min_trials = 5;
  int initial_period_divisor = 2;  // ascent INITIAL_PERIOD = max(10, m / divisor)
  int max_ascent_iterations = 30;  // per call; the penalties carry over between calls
  // Basis move of the LK search (LKH's MOVE_TYPE): 3 for routes of up to small_route_nodes
  // nodes, else LKH's default 5. On the paper's unit-grid fields at B = 200 (~100 nodes per
  // re-order, many equal costs) sequential 5-opt spends 3x longer for routes of the same
  // reward; on random fields of 1,000 and 10,000 sites (routes of 200-600 nodes) 3-opt
  // loses 0.4-0.6 % of NewAlg's reward (docs/results.md, "NewAlg speed").
  int move_k = 5;
  int small_route_move_k = 3;
  int small_route_nodes = 128;
};

struct RouteOpsStats {
  int lkh_calls = 0;
  int lkh_max_nodes = 0;
  int inserted = 0;
  // Ascent penalties by instance node, carried from one LKH call to the next (warm start:
  // the planner re-orders many nearly equal node sets). Empty until the first call.
  std::vector<int64_t> pi;
};

// Paper, NewAlg step 2: re-orders the nodes of `route` with the LKH engine (a closed tour, or
// a path with the end->home edge fixed). Costs are scaled to integers with a resolution of
// 1e-6 of the longest edge. Keeps the old order unless the new one is shorter.
// Returns true if the route got shorter.
bool ReorderWithLkh(const OpInstance& inst, std::vector<int>* route, uint64_t seed,
                    RouteOpsStats* stats, const ReorderOptions& options = {});

// Paper, NewAlg step 3: repeatedly inserts the unvisited site with the best ratio of reward to
// cheapest-insertion cost that still fits the budget. `in_route` marks visited nodes and
// is updated; sites marked in `blocked` (may be null) are not inserted. Returns the number
// of sites inserted. O(n*m) per call plus O(n) per insertion (insertion costs are updated
// incrementally).
int InsertByRatio(const OpInstance& inst, std::vector<int>* route, std::vector<char>* in_route,
                  RouteOpsStats* stats, const std::vector<char>* blocked = nullptr);

}  // namespace mound::plan
