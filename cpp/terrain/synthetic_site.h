// A constructed site for the tests of the detector and the verdict (not for production
// code): undulating ground sloping 3 % and 2 % over a 120 m square (80,000 points,
// 3 cm noise), optionally with a paraboloid tumulus of height dome_h and base diameter
// dome_d centred at (5, -3), and optionally an 80 m long, 6 m wide, 2 m high ridge.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

namespace mound::terrain::testing {

inline std::vector<Eigen::Vector3d> SyntheticSite(double dome_h, double dome_d, bool ridge,
                                                  uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-60, 60);
  std::normal_distribution<double> g(0, 0.03);
  std::vector<Eigen::Vector3d> p;
  for (int i = 0; i < 80000; ++i) {
    const double x = u(rng), y = u(rng);
    double z =
        50 + 0.03 * x - 0.02 * y + 0.4 * std::sin(x / 23.0 + 1) * std::cos(y / 31.0) + g(rng);
    const double r = std::hypot(x - 5, y + 3);
    if (dome_h > 0 && r < dome_d / 2) z += dome_h * (1 - 4 * r * r / (dome_d * dome_d));
    if (ridge && std::fabs(y) < 3 && std::fabs(x) < 40) z += 2.0 * (1 - y * y / 9);
    p.emplace_back(x, y, z);
  }
  return p;
}

}  // namespace mound::terrain::testing
