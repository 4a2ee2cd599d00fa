// Instances for the tests of the TSP engine (not for production code).
#pragma once

#include <random>
#include <vector>

#include "tsp/problem.h"

namespace mound::tsp::testing {

// n points uniform in a 1000 x 1000 square, TSPLIB's rounded Euclidean distances.
inline CoordProblem RandomProblem(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1000);
  std::vector<double> x(n), y(n);
  for (int i = 0; i < n; ++i) {
    x[i] = u(rng);
    y[i] = u(rng);
  }
  return CoordProblem(Metric::kEuc2D, x, y);
}

}  // namespace mound::tsp::testing
