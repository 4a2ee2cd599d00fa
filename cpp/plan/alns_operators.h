// The operators of ALNS-OP (plan/alns.h), each a small class over a route as PyVRP's
// operators are, with its own scratch space: the ruins, 2-opt and Or-opt (shorten), ratio
// insertion (fill), 1-1 replacement, and the moves between two flights (relocate,
// exchange, cross). They share, read-only, a Neighbourhood (the instance's expanded costs
// as a ticking view, each node's nearest nodes, the budget) and, per route, a RouteState
// (which sites are on it and where). Private to mound_plan.
//
// Every cost lookup counts one tick of work: the search's deterministic clock (alns.h).
#pragma once

#include <cstdint>
#include <random>
#include <utility>
#include <vector>

#include "plan/op_instance.h"

namespace mound::plan::alns {

// Expanded edge costs; a matrix up to this many nodes (32 MiB), computed on the fly above.
constexpr int kMaxMatrixNodes = 2048;
// 2-opt, Or-opt and replacements are O(m^2) per pass: beyond this route length only LKH.
constexpr int kMaxLocalSearchRoute = 1000;
// Neighbour lists of 2-opt, Or-opt and replacements.
constexpr int kNear = 16;
// Replacements scan every insertion edge up to this route length, beyond it only the
// edges beside a site's nearest nodes (and only sites with a nearest node on the route).
constexpr int kFullScanRoute = 64;

class Costs {
 public:
  explicit Costs(const OpInstance& inst) : inst_(inst), n_(inst.Size()) {
    if (n_ <= kMaxMatrixNodes) {
      m_.resize(static_cast<size_t>(n_) * n_);
      for (int a = 0; a < n_; ++a)
        for (int b = 0; b < n_; ++b) m_[static_cast<size_t>(a) * n_ + b] = inst.Cost(a, b);
    }
  }
  // Every lookup counts one tick of work: the search's deterministic clock.
  double operator()(int a, int b) const {
    ++ticks_;
    return m_.empty() ? inst_.Cost(a, b) : m_[static_cast<size_t>(a) * n_ + b];
  }
  uint64_t Ticks() const { return ticks_; }
  void Charge(uint64_t ticks) const { ticks_ += ticks; }

 private:
  const OpInstance& inst_;
  int n_;
  std::vector<double> m_;
  mutable uint64_t ticks_ = 0;
};

struct Solution {
  std::vector<int> route;  // home ... end
  double cost = 0;
  double reward = 0;
};

// What every operator reads: the instance, its costs (ticking), the kNear nearest nodes of
// each node (nearest first), the budget with its slack, and the sites with a reward.
struct Neighbourhood {
  explicit Neighbourhood(const OpInstance& instance);
  Solution Make(std::vector<int> route) const;  // cost and reward evaluated
  void Evaluate(Solution* s) const;

  const OpInstance& inst;
  Costs costs;
  double limit, eps;
  std::vector<std::vector<int>> near;
  std::vector<int> rewarded;
};

// Which sites a route holds (`in`, set by Mark) and where (`pos`, index in the route; set
// by Positions, kept by Reverse). The operators keep both up to date as they change it.
struct RouteState {
  explicit RouteState(int nodes) : in(nodes, 0), pos(nodes, -1) {}
  void Mark(const std::vector<int>& route);
  void Positions(const std::vector<int>& r);
  void Reverse(std::vector<int>* r, int p, int q);  // r[p..q], positions kept

  std::vector<char> in;
  std::vector<int> pos;
};

enum RuinKind { kRandom = 0, kSegment, kWorst, kRelated, kNumRuins };
inline constexpr const char* kRuinNames[kNumRuins] = {"random", "segment", "worst", "related"};

// Removes k sites by ruin `op` (random; a segment; the worst reward per saving, noisy; a
// random site and the k - 1 nearest to it); `blocked` marks the removed sites.
void Ruin(const Neighbourhood& N, int op, int k, std::mt19937_64& rng, Solution* s,
          std::vector<char>* blocked);

// 2-opt by neighbour lists: an improving reversal of r[p..q] has a new edge shorter than
// the old edge beside it, so it is found from r[p-1] or r[q+1] and one of its nearest
// nodes. True if the route got shorter.
class TwoOpt {
 public:
  bool Apply(const Neighbourhood& N, RouteState& state, Solution* s) const;
};

// Moves runs of 1-3 consecutive sites next to one of the nearest nodes of either end,
// either orientation. True if the route got shorter.
class OrOpt {
 public:
  bool Apply(const Neighbourhood& N, RouteState& state, Solution* s) const;
};

// Ratio insertion (reward over cheapest insertion cost, times a noise factor per site and
// call) while the budget allows, insertion costs updated incrementally; never a site
// marked in `taken` (another flight's) or `blocked` (may be null).
class RatioInsert {
 public:
  void Apply(const Neighbourhood& N, RouteState& state, Solution* s, const std::vector<char>& taken,
             const std::vector<char>* blocked, double noise, std::mt19937_64& rng);

 private:
  void Scan(const Neighbourhood& N, int v);  // v's cheapest edge in the linked route
  std::vector<int> cand_, next_, after_;
  std::vector<double> delta_, factor_, save_;
};

// 1-1 replacements: each unvisited site in turn takes the place of the visited site of
// less reward whose removal (with the unvisited site at its cheapest place in the route
// without it) gains the most reward within the budget, or of equal reward if that
// shortens the route; applied at once. True if any was made.
class Replace {
 public:
  bool Apply(const Neighbourhood& N, RouteState& state, Solution* s,
             const std::vector<char>& taken);

 private:
  std::vector<double> save_, edge_;
};

// Between two flights, within the budget, shortening them together (rewards unchanged):
// a site of a moved into b where that costs less than it saves in a ...
bool Relocate(const Neighbourhood& N, Solution* a, Solution* b);
// ... a site of a and a site of b swapped, each at the other's place ...
bool Exchange(const Neighbourhood& N, Solution* a, Solution* b);
// ... and 2-opt*: a[0..i] + b[j+1..] and b[0..j] + a[i+1..].
bool Cross(const Neighbourhood& N, Solution* a, Solution* b);

}  // namespace mound::plan::alns
