#include "tsp/solver.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "tsp/tsplib.h"

namespace mound::tsp {
namespace {

const std::string kShared = MOUND_SHARED_DATA;

void ExpectPermutation(const std::vector<int>& tour, int n) {
  std::vector<int> s = tour;
  std::sort(s.begin(), s.end());
  ASSERT_EQ(static_cast<int>(s.size()), n);
  for (int i = 0; i < n; ++i) ASSERT_EQ(s[i], i);
}

struct Known {
  const char* path;
  Cost optimum;
};

class KnownOptimumTest : public ::testing::TestWithParam<Known> {};

// LKH must reach the proven optimum of every TSPLIB instance up to 150 nodes, with the
// default settings (one run, n trials) and a fixed seed.
TEST_P(KnownOptimumTest, ReachesOptimum) {
  const Known k = GetParam();
  const TsplibInstance inst = ReadTsplib(kShared + "/" + k.path);
  SolverOptions opt;
  opt.seed = 1;
  const TspResult r = SolveTsp(*inst.problem, opt);
  ExpectPermutation(r.tour, inst.dimension);
  EXPECT_EQ(r.length, TourLength(*inst.problem, r.tour));
  EXPECT_EQ(r.length, k.optimum) << k.path;
  EXPECT_LE(r.stats.lower_bound, static_cast<double>(k.optimum) + 1e-9);
}

INSTANTIATE_TEST_SUITE_P(
    Tsplib, KnownOptimumTest,
    ::testing::Values(Known{"tsplib/eil51.tsp", 426}, Known{"tsplib/berlin52.tsp", 7542},
                      Known{"tsplib/st70.tsp", 675}, Known{"tsplib/eil76.tsp", 538},
                      Known{"tsplib/kroA100.tsp", 21282}, Known{"tsplib/kroC100.tsp", 20749},
                      Known{"tsplib/lin105.tsp", 14379}, Known{"tsplib/ch130.tsp", 6110},
                      Known{"tsplib/ch150.tsp", 6528},
                      // ATT, GEO and EXPLICIT metrics (TSPLIB optima; the OPLib files
                      // carry the same nodes with COST_LIMIT = ceil(optimum / 2)).
                      Known{"oplib/instances/gen1/att48-gen1-50.oplib", 10628},
                      Known{"oplib/instances/gen1/gr96-gen1-50.oplib", 55209},
                      Known{"oplib/instances/gen1/gr48-gen1-50.oplib", 5046},
                      Known{"oplib/instances/gen1/brazil58-gen1-50.oplib", 25395},
                      Known{"oplib/instances/gen1/hk48-gen1-50.oplib", 11461},
                      Known{"oplib/instances/gen1/gr120-gen1-50.oplib", 6942},
                      Known{"oplib/instances/gen1/gr137-gen1-50.oplib", 69853}),
    [](const ::testing::TestParamInfo<Known>& info) {
      std::string s = info.param.path;
      s = s.substr(s.rfind('/') + 1);
      s = s.substr(0, s.find_first_of(".-"));
      return s;
    });

TEST(SolverTest, SmallInstancesAreExactAndFixedEdgesAreKept) {
  std::mt19937 rng(5);
  for (int n : {1, 2, 3, 5, 8, 9, 12, 20}) {
    std::vector<double> x(n), y(n);
    for (int i = 0; i < n; ++i) {
      x[i] = rng() % 100;
      y[i] = rng() % 100;
    }
    CoordProblem p(Metric::kEuc2D, x, y);
    if (n >= 4) p.AddFixedEdge(0, n - 1);
    const TspResult r = SolveTsp(p, SolverOptions{});
    ExpectPermutation(r.tour, n);
    if (n >= 4) {
      const auto it = std::find(r.tour.begin(), r.tour.end(), 0);
      const size_t i = it - r.tour.begin();
      const int nxt = r.tour[(i + 1) % n], prv = r.tour[(i + n - 1) % n];
      EXPECT_TRUE(nxt == n - 1 || prv == n - 1) << "n=" << n;
    }
  }
}

TEST(SolverTest, SameSeedSameTour) {
  const TsplibInstance inst = ReadTsplib(kShared + "/tsplib/kroA100.tsp");
  SolverOptions opt;
  opt.max_trials = 20;
  opt.seed = 42;
  const TspResult a = SolveTsp(*inst.problem, opt);
  const TspResult b = SolveTsp(*inst.problem, opt);
  EXPECT_EQ(a.tour, b.tour);
}

}  // namespace
}  // namespace mound::tsp
