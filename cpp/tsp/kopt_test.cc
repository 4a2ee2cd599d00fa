#include "tsp/kopt.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>
#include <set>

namespace mound::tsp {
namespace {

using Edge = std::pair<int, int>;
Edge E(int a, int b) { return {std::min(a, b), std::max(a, b)}; }

std::multiset<Edge> Edges(const Tour& t) {
  std::multiset<Edge> s;
  for (int v = 0; v < t.Size(); ++v) s.insert(E(v, t.Next(v)));
  return s;
}

// Reference: apply the edge exchange to an edge set and test for one Hamiltonian cycle.
bool ReferenceFeasible(const Tour& tour, const int* t, int k, std::multiset<Edge>* result) {
  std::multiset<Edge> edges = Edges(tour);
  for (int i = 1; i <= 2 * k; i += 2) {
    auto it = edges.find(E(t[i], t[i + 1]));
    if (it == edges.end()) return false;
    edges.erase(it);
  }
  for (int i = 2; i <= 2 * k; i += 2) edges.insert(E(t[i], t[i == 2 * k ? 1 : i + 1]));
  const int n = tour.Size();
  std::vector<std::vector<int>> adj(n);
  for (const auto& [a, b] : edges) {
    adj[a].push_back(b);
    adj[b].push_back(a);
  }
  for (const auto& a : adj)
    if (a.size() != 2) return false;
  int prev = -1, cur = 0, count = 0;
  do {
    const int nxt = adj[cur][0] != prev ? adj[cur][0] : adj[cur][1];
    prev = cur;
    cur = nxt;
    ++count;
  } while (cur != 0 && count <= n);
  *result = edges;
  return count == n;
}

TEST(KOptTest, FeasibilityAndExecutionAgreeWithEdgeExchange) {
  std::mt19937 rng(3);
  int feasible_seen[kMaxK + 1] = {};
  for (int n : {12, 20, 60}) {
    std::vector<int> order(n);
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), rng);
    for (int trial = 0; trial < 4000; ++trial) {
      Tour tour(order);
      const int k = 2 + static_cast<int>(rng() % (kMaxK - 1));
      // Random sequential t's: t(2i) a tour neighbour of t(2i-1), all distinct.
      int t[2 * kMaxK + 1];
      std::set<int> used;
      bool ok = true;
      for (int i = 1; i <= 2 * k && ok; i += 2) {
        int a = static_cast<int>(rng() % n);
        const int b = (rng() & 1) ? tour.Next(a) : tour.Prev(a);
        if (used.count(a) || used.count(b)) ok = false;
        used.insert(a);
        used.insert(b);
        t[i] = a;
        t[i + 1] = b;
      }
      if (!ok) continue;
      // Added edges must not be tour edges (the search guarantees this).
      for (int i = 2; i <= 2 * k; i += 2)
        if (tour.Adjacent(t[i], t[i == 2 * k ? 1 : i + 1])) ok = false;
      if (!ok) continue;
      std::multiset<Edge> expected;
      const bool ref = ReferenceFeasible(tour, t, k, &expected);
      ASSERT_EQ(FeasibleKOptMove(tour, t, k), ref) << "n=" << n << " k=" << k;
      if (!ref) continue;
      ++feasible_seen[k];
      MakeKOptMove(tour, t, k);
      ASSERT_EQ(Edges(tour), expected);
    }
  }
  for (int k = 2; k <= kMaxK; ++k) EXPECT_GT(feasible_seen[k], 10) << "k=" << k;
}

}  // namespace
}  // namespace mound::tsp
