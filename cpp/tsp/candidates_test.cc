#include "tsp/candidates.h"

#include <gtest/gtest.h>

#include <random>

#include "tsp/problem.h"
#include "tsp/test_problems.h"

namespace mound::tsp {
namespace {

using testing::RandomProblem;

TEST(CandidatesTest, AscentRaisesTheBoundAndStaysBelowAKnownTour) {
  const CoordProblem p = RandomProblem(120, 1);
  CostCache d(p);
  AscentOptions plain;
  plain.subgradient = false;
  const AscentResult r0 = Ascent(d, plain);
  const AscentResult r1 = Ascent(d, AscentOptions{});
  EXPECT_GT(r1.lower_bound, r0.lower_bound);
  // Any tour is an upper bound; the identity tour is a (bad) one.
  std::vector<int> ident(120);
  for (int i = 0; i < 120; ++i) ident[i] = i;
  EXPECT_LT(r1.lower_bound, static_cast<double>(TourLength(p, ident)));
  EXPECT_GT(r1.iterations, 10);
}

TEST(CandidatesTest, SparseAscentReportsTheCompleteGraphBoundOfItsPenalties) {
  // A small ascent graph (5 alpha-nearest) and a short first period, as for large
  // instances: the bound is that of a 1-tree of the complete graph under the penalties
  // found (a 1-tree of the sparse graph may cost more), and close to the full ascent's.
  const CoordProblem p = RandomProblem(300, 3);
  CostCache d(p);
  AscentOptions bounded;
  bounded.ascent_candidates = 5;
  bounded.initial_period = 30;
  const AscentResult sparse = Ascent(d, bounded);
  AscentOptions recheck;
  recheck.subgradient = false;
  recheck.initial_pi = sparse.pi;
  EXPECT_DOUBLE_EQ(sparse.lower_bound, Ascent(d, recheck).lower_bound);
  const AscentResult full = Ascent(d, AscentOptions{});
  EXPECT_LE(sparse.lower_bound, full.lower_bound * 1.0001);
  EXPECT_GT(sparse.lower_bound, full.lower_bound * 0.99);
  EXPECT_LT(sparse.iterations, full.iterations);
}

TEST(CandidatesTest, FiveAlphaNearestSortedWithZeroAlphaTreeEdges) {
  const CoordProblem p = RandomProblem(80, 2);
  CostCache d(p);
  const AscentResult r = Ascent(d, AscentOptions{});
  const CandidateSet c = AlphaCandidates(d, r.pi, 100, 5, {});
  ASSERT_EQ(c.size(), 80u);
  int zero_alpha = 0;
  for (int v = 0; v < 80; ++v) {
    ASSERT_EQ(c[v].size(), 5u);
    for (size_t i = 0; i + 1 < c[v].size(); ++i) EXPECT_LE(c[v][i].alpha, c[v][i + 1].alpha);
    for (const Candidate& x : c[v]) {
      EXPECT_NE(x.node, v);
      EXPECT_GE(x.alpha, 0);
      zero_alpha += x.alpha == 0;
    }
  }
  // Every 1-tree edge has alpha 0 and appears from both ends: n edges, 2n entries.
  EXPECT_GE(zero_alpha, 2 * 80 - 2);
}

}  // namespace
}  // namespace mound::tsp
