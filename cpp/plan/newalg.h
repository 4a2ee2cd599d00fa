// NewAlg, the orienteering heuristic of the paper ("A Multi-Resolution Approach for
// Discovery and 3-D Modeling of Archaeological Sites Using Satellite Imagery and a
// UAV-borne Camera"), and a local-search extension of it.
//
// Step 1, tree growth from home. Round 1 adds the site with the best ratio of reward to
// connection cost (its cheapest expanded edge to the tree) while the tree costs at most
// B/2, so that walking the tree in depth-first order costs at most B. (For a path the tree
// starts as home-end and the limit is (B + c(home,end))/2.) Round 2 keeps adding by the
// same ratio while the depth-first-order route itself costs at most B.
// Step 2, the LKH engine re-orders the chosen sites.
// Step 3, sites are inserted by ratio of reward to cheapest insertion cost while the
// budget allows. Steps 2-3 repeat until nothing is inserted.
//
// newalg-ls: NewAlg followed by an iterated local search. Each iteration removes a few
// sites (random ones, or a run of consecutive ones) from the best route, then repeats
// steps 2-3; the result is kept if it collects more reward (or the same for less cost).
#pragma once

#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "plan/op_instance.h"

namespace mound::plan {

struct NewAlgOptions {
  uint64_t seed = 1;
  int max_rounds = 100;        // step 2-3 repetitions
  int ls_iterations = 300;     // newalg-ls only
  double ls_time_limit_s = 0;  // newalg-ls only; <= 0: no limit
  // One-line accounts of a long solve (tree grown, each improvement round). Empty: silent.
  std::function<void(const std::string&)> progress;
};

struct PlanResult {
  std::vector<int> route;  // home ... end (closed: home ... home)
  double reward = 0;
  double cost = 0;
  nlohmann::json stats;
};

PlanResult SolveNewAlg(const OpInstance& inst, const NewAlgOptions& opt);
PlanResult SolveNewAlgLs(const OpInstance& inst, const NewAlgOptions& opt);

}  // namespace mound::plan
