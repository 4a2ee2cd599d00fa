// Tour: an oriented Hamiltonian cycle with O(1) Next/Prev/Between and path reversal.
//
// Representation: the node order in an array plus a position index and a global
// orientation bit. Reverse(a, b) reverses the shorter of the path a..b and its complement;
// reversing the complement and flipping the orientation bit gives the same oriented cycle,
// so callers always see "the path a..b is now reversed". The cost of a reversal is
// min(len, n - len), which keeps the local moves of Lin-Kernighan cheap at n = 10,000 (the
// moves and kicks are local, so len is small). Every reversal can be recorded in a journal
// so that a sequence of moves can be undone exactly (LKH's SwapStack).
#pragma once

#include <cstddef>
#include <utility>
#include <vector>

namespace mound::tsp {

class Tour {
 public:
  explicit Tour(const std::vector<int>& order);

  int Size() const { return n_; }
  int Next(int a) const {
    int p = pos_[a] + (reversed_ ? -1 : 1);
    if (p == n_) p = 0;
    if (p < 0) p = n_ - 1;
    return order_[p];
  }
  int Prev(int a) const {
    int p = pos_[a] + (reversed_ ? 1 : -1);
    if (p == n_) p = 0;
    if (p < 0) p = n_ - 1;
    return order_[p];
  }
  // Position of `a` along the oriented cycle, in 0..n-1 (relative to an arbitrary start).
  int Rank(int a) const { return reversed_ ? n_ - 1 - pos_[a] : pos_[a]; }
  // True when b lies on the forward path from a to c (inclusive).
  bool Between(int a, int b, int c) const {
    const int ra = Rank(a);
    int rb = Rank(b) - ra, rc = Rank(c) - ra;
    if (rb < 0) rb += n_;
    if (rc < 0) rc += n_;
    return rb <= rc;
  }
  bool Adjacent(int a, int b) const { return Next(a) == b || Prev(a) == b; }

  // Reverses the forward path a..b (a and b inclusive). Recorded in the journal if set.
  void Reverse(int a, int b);

  // Journal of reversals (LKH's SwapStack): Mark() returns a position, UndoTo() reverts
  // every reversal made after it, in reverse order.
  void SetJournaling(bool on) { journaling_ = on; }
  size_t Mark() const { return journal_.size(); }
  void UndoTo(size_t mark);
  void ClearJournal() { journal_.clear(); }
  const std::vector<std::pair<int, int>>& Journal() const { return journal_; }

  // The cycle in forward order, starting at `start`.
  std::vector<int> Order(int start = -1) const;

 private:
  void ReversePhysical(int i, int j, int len);

  int n_;
  std::vector<int> order_, pos_;
  bool reversed_ = false;
  bool journaling_ = false;
  std::vector<std::pair<int, int>> journal_;
};

}  // namespace mound::tsp
