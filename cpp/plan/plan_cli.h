// The mound_plan command line (contract: ../shared/INTERFACES.md).
//
//   mound_plan SITES.json [BUDGET] [--algo NAME] [--seed N] [--out PLAN.json]
//   mound_plan tsp FILE.tsp [--seed N] [--runs N] [--trials N] [--time-limit S]
//
// Lives in the library so tests run it in-process. Returns the exit code: 0 ok, 2 bad
// input or usage (one line on `err` naming the problem), 1 internal failure.
#pragma once

#include <ostream>
#include <string>
#include <vector>

namespace mound::plan {

int RunMoundPlan(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace mound::plan
