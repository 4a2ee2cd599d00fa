#include "tsp/kopt.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <deque>
#include <stdexcept>
#include <vector>

namespace mound::tsp {
namespace {

// Segments of a k-opt move and the order in which the new tour visits them.
struct SegmentPlan {
  int k = 0;
  // Segment s runs forward in the current tour from node first[s] to node last[s];
  // segments are numbered in tour order starting with the one that begins at/after t1.
  std::array<int, kMaxK> first{}, last{};
  // New tour: segment order[i], traversed forward iff fwd[i]. order[0] == 0, fwd[0].
  std::array<int, kMaxK> order{}, fwd{};
  int visited = 0;  // number of segments on the cycle that contains segment 0
};

void BuildPlan(const Tour& tour, const int* t, int k, SegmentPlan* plan) {
  const int m = 2 * k;
  const int n = tour.Size();
  const int r1 = tour.Rank(t[1]);
  std::array<int, 2 * kMaxK + 1> rank{};
  std::array<int, 2 * kMaxK> sorted{};  // t-indices sorted by rank relative to t1
  for (int i = 1; i <= m; ++i) {
    int r = tour.Rank(t[i]) - r1;
    if (r < 0) r += n;
    rank[i] = r;
    sorted[i - 1] = i;
  }
  // Insertion sort: at most 10 keys, faster than std::sort here (this is a hot path).
  for (int i = 1; i < m; ++i) {
    const int key = sorted[i];
    int j = i - 1;
    while (j >= 0 && rank[sorted[j]] > rank[key]) {
      sorted[j + 1] = sorted[j];
      --j;
    }
    sorted[j + 1] = key;
  }
  // Removed edges are adjacent pairs in sorted (cyclic) order. If t2 follows t1 the pairs
  // are (0,1),(2,3)...; otherwise (m-1,0),(1,2)... and segments sit between the pairs.
  const int offset = (sorted[1] == 2) ? 1 : 0;
  std::array<int, 2 * kMaxK + 1> seg_of{}, is_start{}, other_end{};
  plan->k = k;
  for (int s = 0; s < k; ++s) {
    const int a = sorted[(2 * s + offset) % m];
    const int b = sorted[(2 * s + 1 + offset) % m];
    seg_of[a] = seg_of[b] = s;
    is_start[a] = 1;
    is_start[b] = 0;
    other_end[a] = b;
    other_end[b] = a;
    plan->first[s] = t[a];
    plan->last[s] = t[b];
  }
  // The added-edge partner of each t-index: (t2,t3), (t4,t5), ..., (t2k,t1).
  auto added_partner = [&](int i) {
    if (i == 1) return m;
    if (i == m) return 1;
    return (i % 2 == 0) ? i + 1 : i - 1;
  };
  // Start at the start entry of segment 0, traverse it forward.
  int entry = sorted[offset % m];
  int count = 0;
  const int start = entry;
  do {
    plan->order[count] = seg_of[entry];
    plan->fwd[count] = is_start[entry];
    ++count;
    const int exit = other_end[entry];
    entry = added_partner(exit);
  } while (entry != start && count < k);
  plan->visited = (entry == start) ? count : -1;
}

// Shortest reversal sequences for signed permutations of k-1 movable segments, from the
// identity. A state packs, per position, (segment index - 1) in 2 bits and the sign bit.
struct ReversalTable {
  // steps[k][code] = list of (i, j) block reversals over positions 1..k-1.
  std::array<std::vector<std::vector<std::pair<int, int>>>, kMaxK + 1> steps;

  static int Encode(const int* seg, const int* fwd, int k) {
    int code = 0;
    for (int p = 1; p < k; ++p) code = (code << 3) | ((seg[p] - 1) << 1) | (fwd[p] ? 0 : 1);
    return code;
  }

  ReversalTable() {
    for (int k = 2; k <= kMaxK; ++k) {
      steps[k].assign(1 << (3 * (k - 1)), {});
      std::vector<bool> seen(1 << (3 * (k - 1)), false);
      std::array<int, kMaxK> seg{}, fwd{};
      for (int p = 0; p < k; ++p) {
        seg[p] = p;
        fwd[p] = 1;
      }
      struct Node {
        std::array<int, kMaxK> seg, fwd;
      };
      std::deque<Node> queue;
      const int start = Encode(seg.data(), fwd.data(), k);
      seen[start] = true;
      queue.push_back({seg, fwd});
      while (!queue.empty()) {
        const Node cur = queue.front();
        queue.pop_front();
        const int code = Encode(cur.seg.data(), cur.fwd.data(), k);
        for (int i = 1; i < k; ++i) {
          for (int j = i; j < k; ++j) {
            Node nxt = cur;
            std::reverse(nxt.seg.begin() + i, nxt.seg.begin() + j + 1);
            std::reverse(nxt.fwd.begin() + i, nxt.fwd.begin() + j + 1);
            for (int p = i; p <= j; ++p) nxt.fwd[p] = !nxt.fwd[p];
            const int c = Encode(nxt.seg.data(), nxt.fwd.data(), k);
            if (seen[c]) continue;
            seen[c] = true;
            steps[k][c] = steps[k][code];
            steps[k][c].emplace_back(i, j);
            queue.push_back(nxt);
          }
        }
      }
    }
  }
};

const ReversalTable& Table() {
  static const ReversalTable table;
  return table;
}

}  // namespace

bool FeasibleKOptMove(const Tour& tour, const int* t, int k) {
  // 2-opt: with added edges (t2,t3) and (t4,t1) the move is feasible iff the removed
  // edges point in opposite directions (t2 = succ(t1) and t4 = pred(t3), or vice versa).
  if (k == 2) return (tour.Next(t[1]) == t[2]) != (tour.Next(t[3]) == t[4]);
  SegmentPlan plan;
  BuildPlan(tour, t, k, &plan);
  return plan.visited == k;
}

void MakeKOptMove(Tour& tour, const int* t, int k) {
  SegmentPlan plan;
  BuildPlan(tour, t, k, &plan);
  if (plan.visited != k) throw std::logic_error("MakeKOptMove: infeasible move");
  const int code = ReversalTable::Encode(plan.order.data(), plan.fwd.data(), k);
  // Current arrangement: segment arr[p] at position p, forward iff dir[p].
  std::array<int, kMaxK> arr{}, dir{};
  for (int p = 0; p < k; ++p) {
    arr[p] = p;
    dir[p] = 1;
  }
  for (const auto& [i, j] : Table().steps[k][code]) {
    const int a = dir[i] ? plan.first[arr[i]] : plan.last[arr[i]];
    const int b = dir[j] ? plan.last[arr[j]] : plan.first[arr[j]];
    tour.Reverse(a, b);
    std::reverse(arr.begin() + i, arr.begin() + j + 1);
    std::reverse(dir.begin() + i, dir.begin() + j + 1);
    for (int p = i; p <= j; ++p) dir[p] = !dir[p];
  }
}

}  // namespace mound::tsp
