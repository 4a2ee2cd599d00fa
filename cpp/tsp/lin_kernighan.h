// The Lin-Kernighan local search of LKH (Helsgaun 2000, section 3; Helsgaun 2009).
//
// Each step is a sequential k-opt move (k = 5 by default, LKH's MOVE_TYPE) built from
// t1, t2 = a tour neighbour of t1, and for i >= 1: t(2i+1) among the candidates of t(2i)
// (the alpha-nearest neighbours), t(2i+2) a tour neighbour of t(2i+1). The partial gain
// G(2i+1) = G(2i) - d(t2i, t2i+1) must stay positive (the gain criterion). The first
// feasible closing with positive gain, at any depth 2..k, is made at once. Otherwise the
// best feasible non-gainful k-opt move (largest G(2k)) is made and the search goes on from
// t1 and t2 := t(2k), as in LKH's LinKernighan.c; if that chain ends without gain, all of
// its moves are undone. Edges added in a chain are never removed and removed edges never
// added again (LKH's Added/Deleted), fixed edges are never removed, and a node whose
// neighbourhood is unchanged is not re-examined (don't-look bits as an active queue).
#pragma once

#include <deque>
#include <utility>
#include <vector>

#include "tsp/candidates.h"
#include "tsp/kopt.h"
#include "tsp/tour.h"

namespace mound::tsp {

struct LkStats {
  long long moves = 0;             // improving moves made
  long long nongainful_steps = 0;  // non-gainful k-opt steps made (later kept or undone)
};

class LinKernighan {
 public:
  LinKernighan(const CostCache& d, const std::vector<Cost>& pi, int precision,
               const CandidateSet& cands, const std::vector<std::pair<int, int>>& fixed,
               int move_k);

  // Transformed cost P*D(i,j) + pi_i + pi_j: a tour's transformed length is P*length +
  // 2*sum(pi), so gains in either are the same up to the factor P.
  Cost C(int i, int j) const { return p_ * d_.D(i, j) + pi_[i] + pi_[j]; }
  bool IsFixed(int a, int b) const { return fixed_partner_[a] == b; }

  // Improves `tour` from the nodes in `active` (and the nodes each improvement touches)
  // until no improving move is found. Returns the total gain in transformed units.
  // The tour must journal its reversals (non-gainful chains are undone through it).
  Cost Optimize(Tour& tour, const std::vector<int>& active);

  const LkStats& Stats() const { return stats_; }

 private:
  bool ImproveFrom(Tour& tour, int t1, Cost* gain);
  int BestKOptMove(Tour& tour, int t1, int t2, Cost* g0, Cost* gain);
  bool Search(Tour& tour, int i, Cost g);
  bool InMove(int v, int upto) const;
  bool WasAdded(int a, int b) const;
  bool WasDeleted(int a, int b) const;
  void Activate(int v);

  const CostCache& d_;
  const std::vector<Cost>& pi_;
  const Cost p_;
  const CandidateSet& cands_;
  const int k_;
  std::vector<int> fixed_partner_;

  std::deque<int> queue_;
  std::vector<char> in_queue_;
  std::vector<std::pair<int, int>> added_, deleted_;
  std::vector<int> touched_;

  int t_[2 * kMaxK + 1] = {};
  int best_t_[2 * kMaxK + 1] = {};
  Cost best_g_ = 0;
  Cost found_gain_ = 0;
  int t1_other_ = -1;  // the tour neighbour of t1 that is not t2
  LkStats stats_;
};

}  // namespace mound::tsp
