// Lower bound and candidate sets (Helsgaun 2000, sections 4.1-4.3).
//
// 1-tree: a minimum spanning tree plus one edge from a leaf, chosen as in LKH: the leaf
// whose cheapest non-tree edge is longest. With penalties pi the transformed costs are
// d(i,j) = P*D(i,j) + pi_i + pi_j (P = precision); the 1-tree cost minus 2*sum(pi) is a
// lower bound on P times the optimal tour length (Held & Karp 1970).
//
// Ascent: subgradient optimisation of pi with Helsgaun's step rule (pi += t*(0.7 v + 0.3
// v_prev), v = degree - 2; doubling t in the initial phase, halving period and step).
// The first 1-tree is computed on the complete graph; the rest of the ascent works on a
// sparse graph of the `ascent_candidates` alpha-nearest neighbours (LKH's
// ASCENT_CANDIDATES), which contains the minimum spanning tree, stored in compressed
// rows. A 1-tree of that graph may cost more than the minimum 1-tree, so the reported
// lower bound comes from one 1-tree of the complete graph under the best penalties.
//
// Alpha-nearness: alpha(i,j) = d(i,j) - beta(i,j), beta the largest edge on the tree path
// between i and j, computed for all pairs in O(n^2) time and O(n) space with the
// topological order of the tree.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "tsp/problem.h"

namespace mound::tsp {

struct Candidate {
  int node;
  Cost cost;  // transformed cost d(from, node)
  Cost alpha;
};
using CandidateSet = std::vector<std::vector<Candidate>>;

// Above this many nodes the ascent is bounded (kLargeAscentPeriod, kLargeAscentCandidates
// unless set): LKH's full ascent (INITIAL_PERIOD n/2 on 50 candidates) takes 12,522
// iterations and 269 s at 10,000 nodes, the bounded one ~1,400 iterations and 12 s for a
// bound 0.1 % lower (docs/results.md, "LKH at 10,000 nodes").
constexpr int kLargeAscentNodes = 5000;
constexpr int kLargeAscentPeriod = 300;
constexpr int kLargeAscentCandidates = 15;

struct AscentOptions {
  int precision = 100;
  int ascent_candidates = -1;  // <= 0: 50 as in LKH (15 above kLargeAscentNodes)
  int initial_period = -1;     // <= 0: max(n/2, 100) as in LKH (300 above kLargeAscentNodes)
  int max_iterations = 1 << 30;
  bool subgradient = true;  // false: pi = initial_pi (plain alpha of that 1-tree)
  // Warm start (LKH's PI_FILE): penalties from an earlier, similar instance. Empty: zeros.
  std::vector<Cost> initial_pi;
  // Checked every iteration: true ends the ascent with the best penalties so far (the
  // solver's time limit). Empty: never.
  std::function<bool()> should_stop;
  // Called about every 2 s with a one-line account of the ascent. Empty: silent.
  std::function<void(const std::string&)> progress;
};

struct AscentResult {
  std::vector<Cost> pi;
  double lower_bound = 0;  // in units of D
  int iterations = 0;
  bool tour_found = false;  // the best 1-tree was a tour (lower bound is optimal)
};

// Distances with a dense cache for small n, so that the search pays no recomputation.
class CostCache {
 public:
  explicit CostCache(const Problem& p, int dense_limit = 3000);
  int Size() const { return n_; }
  Cost D(int i, int j) const {
    return dense_.empty() ? p_.Dist(i, j) : dense_[static_cast<size_t>(i) * n_ + j];
  }

 private:
  const Problem& p_;
  int n_;
  std::vector<Cost> dense_;
};

AscentResult Ascent(const CostCache& d, const AscentOptions& opt);

// The `max_candidates` alpha-nearest neighbours of each node under penalties `pi`,
// sorted by (alpha, cost). Fixed-edge partners are always included.
CandidateSet AlphaCandidates(const CostCache& d, const std::vector<Cost>& pi, int precision,
                             int max_candidates,
                             const std::vector<std::pair<int, int>>& fixed_edges);

}  // namespace mound::tsp
