#include "tsp/tour.h"

#include <stdexcept>

namespace mound::tsp {

Tour::Tour(const std::vector<int>& order)
    : n_(static_cast<int>(order.size())), order_(order), pos_(order.size(), -1) {
  for (int i = 0; i < n_; ++i) {
    const int v = order_[i];
    if (v < 0 || v >= n_ || pos_[v] != -1) throw std::invalid_argument("tour is not a permutation");
    pos_[v] = i;
  }
}

void Tour::ReversePhysical(int i, int j, int len) {
  for (int k = 0; k < len / 2; ++k) {
    const int a = order_[i], b = order_[j];
    order_[i] = b;
    pos_[b] = i;
    order_[j] = a;
    pos_[a] = j;
    if (++i == n_) i = 0;
    if (--j < 0) j = n_ - 1;
  }
}

void Tour::Reverse(int a, int b) {
  if (journaling_) journal_.emplace_back(a, b);
  // Physical range [i..j] (cyclic, forward in the array) that holds the path a..b.
  const int i = reversed_ ? pos_[b] : pos_[a];
  const int j = reversed_ ? pos_[a] : pos_[b];
  int len = j - i;
  if (len < 0) len += n_;
  len += 1;
  if (2 * len <= n_) {
    ReversePhysical(i, j, len);
  } else {
    if (len < n_) ReversePhysical(j + 1 == n_ ? 0 : j + 1, i == 0 ? n_ - 1 : i - 1, n_ - len);
    reversed_ = !reversed_;
  }
}

void Tour::UndoTo(size_t mark) {
  const bool was = journaling_;
  journaling_ = false;
  while (journal_.size() > mark) {
    const auto [a, b] = journal_.back();
    journal_.pop_back();
    Reverse(b, a);  // after Reverse(a, b) the path reads b..a
  }
  journaling_ = was;
}

std::vector<int> Tour::Order(int start) const {
  std::vector<int> out;
  out.reserve(n_);
  if (n_ == 0) return out;
  int v = start < 0 ? order_[0] : start;
  for (int k = 0; k < n_; ++k) {
    out.push_back(v);
    v = Next(v);
  }
  return out;
}

}  // namespace mound::tsp
