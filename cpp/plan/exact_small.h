// Exact orienteering for small instances (at most kMaxExactSites sites): one Held-Karp
// dynamic programme over all subsets (dp[mask][j] = cheapest route from home through the
// sites of mask ending at site j), then the best-reward subset whose route fits.
// O(2^n n^2) time, O(2^n n) memory. Used as ground truth in tests and as --algo exact.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "plan/newalg.h"
#include "plan/op_instance.h"

namespace mound::plan {

constexpr int kMaxExactSites = 16;

// The Held-Karp table: for every subset of the sites (bit j: site FirstSite() + j) the
// cheapest route from home through all of them to the end node, when one fits the budget.
class SubsetRoutes {
 public:
  // Throws std::invalid_argument above kMaxExactSites sites.
  explicit SubsetRoutes(const OpInstance& inst);
  size_t Subsets() const { return tour_.size(); }
  bool Fits(size_t mask) const { return tour_[mask] <= limit_; }
  double Cost(size_t mask) const { return tour_[mask]; }  // +inf: no route within the budget
  double Reward(size_t mask) const { return reward_[mask]; }
  std::vector<int> Route(size_t mask) const;  // home ... end

 private:
  const OpInstance& inst_;
  int first_, m_;
  double limit_;
  std::vector<double> tour_, reward_;
  std::vector<int8_t> from_, last_;
};

// Throws std::invalid_argument if the instance has more than kMaxExactSites sites.
PlanResult SolveExactSmall(const OpInstance& inst);

}  // namespace mound::plan
