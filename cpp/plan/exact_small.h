// Exact orienteering for small instances (at most kMaxExactSites sites): one Held-Karp
// dynamic programme over all subsets (dp[mask][j] = cheapest route from home through the
// sites of mask ending at site j), then the best-reward subset whose route fits.
// O(2^n n^2) time, O(2^n n) memory. Used as ground truth in tests and as --algo exact.
#pragma once

#include "plan/newalg.h"
#include "plan/op_instance.h"

namespace mound::plan {

constexpr int kMaxExactSites = 16;

// Throws std::invalid_argument if the instance has more than kMaxExactSites sites.
PlanResult SolveExactSmall(const OpInstance& inst);

}  // namespace mound::plan
