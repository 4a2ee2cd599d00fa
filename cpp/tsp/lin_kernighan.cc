#include "tsp/lin_kernighan.h"

#include <limits>

namespace mound::tsp {
namespace {
constexpr Cost kNone = std::numeric_limits<Cost>::min();

bool SameEdge(const std::pair<int, int>& e, int a, int b) {
  return (e.first == a && e.second == b) || (e.first == b && e.second == a);
}
}  // namespace

LinKernighan::LinKernighan(const CostCache& d, const std::vector<Cost>& pi, int precision,
                           const CandidateSet& cands, const std::vector<std::pair<int, int>>& fixed,
                           int move_k)
    : d_(d),
      pi_(pi),
      p_(precision),
      cands_(cands),
      k_(std::max(2, std::min(move_k, kMaxK))),
      fixed_partner_(d.Size(), -1),
      in_queue_(d.Size(), 0) {
  for (const auto& [a, b] : fixed) {
    fixed_partner_[a] = b;
    fixed_partner_[b] = a;
  }
}

void LinKernighan::Activate(int v) {
  if (!in_queue_[v]) {
    in_queue_[v] = 1;
    queue_.push_back(v);
  }
}

Cost LinKernighan::Optimize(Tour& tour, const std::vector<int>& active) {
  for (int v : active) Activate(v);
  Cost total = 0;
  while (!queue_.empty()) {
    const int t1 = queue_.front();
    queue_.pop_front();
    in_queue_[t1] = 0;
    Cost gain = 0;
    if (ImproveFrom(tour, t1, &gain)) {
      total += gain;
      ++stats_.moves;
      for (int v : touched_) Activate(v);
    }
  }
  return total;
}

bool LinKernighan::ImproveFrom(Tour& tour, int t1, Cost* gain) {
  for (int x2 = 0; x2 < 2; ++x2) {
    int t2 = x2 == 0 ? tour.Next(t1) : tour.Prev(t1);
    if (IsFixed(t1, t2)) continue;
    const size_t mark = tour.Mark();
    added_.clear();
    deleted_.clear();
    touched_.clear();
    Cost g0 = C(t1, t2);
    const int max_steps = tour.Size();
    for (int step = 0; step < max_steps; ++step) {
      Cost g = 0;
      const int t2k = BestKOptMove(tour, t1, t2, &g0, &g);
      if (g > 0) {
        *gain = g;
        return true;
      }
      if (t2k < 0) break;
      t2 = t2k;
    }
    tour.UndoTo(mark);
  }
  return false;
}

bool LinKernighan::InMove(int v, int upto) const {
  for (int i = 1; i <= upto; ++i)
    if (t_[i] == v) return true;
  return false;
}

bool LinKernighan::WasAdded(int a, int b) const {
  for (const auto& e : added_)
    if (SameEdge(e, a, b)) return true;
  return false;
}

bool LinKernighan::WasDeleted(int a, int b) const {
  for (const auto& e : deleted_)
    if (SameEdge(e, a, b)) return true;
  return false;
}

int LinKernighan::BestKOptMove(Tour& tour, int t1, int t2, Cost* g0, Cost* gain) {
  t_[1] = t1;
  t_[2] = t2;
  t1_other_ = tour.Next(t1) == t2 ? tour.Prev(t1) : tour.Next(t1);
  best_g_ = kNone;
  found_gain_ = 0;
  if (Search(tour, 1, *g0)) {
    *gain = found_gain_;
    return -1;
  }
  if (best_g_ == kNone) return -1;
  // Make the best non-gainful move and continue the chain from t(2k).
  MakeKOptMove(tour, best_t_, k_);
  ++stats_.nongainful_steps;
  for (int i = 1; i <= 2 * k_; ++i) touched_.push_back(best_t_[i]);
  for (int i = 1; i < 2 * k_; i += 2) deleted_.emplace_back(best_t_[i], best_t_[i + 1]);
  for (int i = 2; i < 2 * k_; i += 2) added_.emplace_back(best_t_[i], best_t_[i + 1]);
  *g0 = best_g_;
  return best_t_[2 * k_];
}

// t_[1..2i] are chosen (i edges removed); g = removed minus added costs so far.
bool LinKernighan::Search(Tour& tour, int i, Cost g) {
  const int t2i = t_[2 * i];
  for (const Candidate& cand : cands_[t2i]) {
    const int t3 = cand.node;
    if (tour.Adjacent(t2i, t3)) continue;  // the added edge must be new
    const Cost g1 = g - cand.cost;
    if (g1 <= 0) continue;  // gain criterion
    if (InMove(t3, 2 * i) || WasDeleted(t2i, t3)) continue;
    for (int dir = 0; dir < 2; ++dir) {
      const int t4 = dir == 0 ? tour.Next(t3) : tour.Prev(t3);
      if (InMove(t4, 2 * i) || IsFixed(t3, t4) || WasAdded(t3, t4)) continue;
      const Cost g2 = g1 + C(t3, t4);
      t_[2 * i + 1] = t3;
      t_[2 * i + 2] = t4;
      const int k = i + 1;
      if (t4 != t1_other_) {
        const Cost closing = g2 - C(t4, t_[1]);
        if (closing > 0 && FeasibleKOptMove(tour, t_, k)) {
          MakeKOptMove(tour, t_, k);
          for (int j = 1; j <= 2 * k; ++j) touched_.push_back(t_[j]);
          found_gain_ = closing;
          return true;
        }
      }
      if (k < k_) {
        if (Search(tour, k, g2)) return true;
      } else if (g2 > best_g_ && t4 != t1_other_ && FeasibleKOptMove(tour, t_, k)) {
        best_g_ = g2;
        for (int j = 1; j <= 2 * k; ++j) best_t_[j] = t_[j];
      }
    }
  }
  return false;
}

}  // namespace mound::tsp
