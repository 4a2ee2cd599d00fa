// Building blocks shared by the orienteering algorithms.
#pragma once

#include <cstdint>
#include <vector>

#include "plan/op_instance.h"
#include "tsp/solver.h"

namespace mound::plan {

struct RouteOpsStats {
  int lkh_calls = 0;
  int lkh_max_nodes = 0;
  int inserted = 0;
};

// Step 2 of NewAlg: re-orders the nodes of `route` with the LKH engine (a closed tour, or
// a path with the end->home edge fixed). Costs are scaled to integers with a resolution of
// 1e-6 of the longest edge. Keeps the old order unless the new one is shorter.
// Returns true if the route got shorter.
bool ReorderWithLkh(const OpInstance& inst, std::vector<int>* route, uint64_t seed,
                    RouteOpsStats* stats);

// Step 3 of NewAlg: repeatedly inserts the unvisited site with the best ratio of reward to
// cheapest-insertion cost that still fits the budget. `in_route` marks visited nodes and
// is updated; sites marked in `blocked` (may be null) are not inserted. Returns the number
// of sites inserted. O(n*m) per call plus O(n) per insertion (insertion costs are updated
// incrementally).
int InsertByRatio(const OpInstance& inst, std::vector<int>* route, std::vector<char>* in_route,
                  RouteOpsStats* stats, const std::vector<char>* blocked = nullptr);

}  // namespace mound::plan
