// Benchmark (not a test): NewAlg and newalg-ls run time at 100, 1,000 and 10,000 random
// sites, against the paper's reported 5-16 s for NewAlg in MATLAB on 100-site fields.
//
// Instances keep the density of the paper's fields (100 sites on a 10 x 10 grid, i.e. one
// site per square metre) in a square of side sqrt(n), rewards uniform in [0, 1], a node
// (scan) cost of 1 m per site, home at the corner, and a budget of 12 * sqrt(n) (120 at
// n = 100, the middle of the paper's budgets 40-200). Each size runs `reps` seeds; the
// median time is printed.
//
//   build/tools/bench/mound_bench_plan [--max-n N] [--reps R]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "plan/newalg.h"

namespace {

mound::plan::OpInstance Field(int n, unsigned seed) {
  std::mt19937 rng(seed);
  const double side = std::sqrt(static_cast<double>(n));
  std::uniform_real_distribution<double> u(0, side), r(0, 1);
  mound::plan::OpInstance inst;
  inst.nodes.push_back({"home", 0, 0, 0, 0});
  for (int i = 0; i < n; ++i)
    inst.nodes.push_back({"s" + std::to_string(i), u(rng), u(rng), r(rng), 1.0});
  inst.budget_m = 12.0 * side;
  return inst;
}

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  int max_n = 10000, reps = 5;
  std::string only;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--max-n") max_n = std::atoi(argv[i + 1]);
    if (a == "--reps") reps = std::atoi(argv[i + 1]);
    if (a == "--algo") only = argv[i + 1];
  }
  const double paper_low_s = 5.0, paper_high_s = 16.0;
  std::printf("%-7s %-10s %8s %8s %8s %9s %10s %12s %13s\n", "n", "algo", "budget", "visited",
              "reward", "min_ms", "median_ms", "vs_paper_5s", "vs_paper_16s");
  for (int n : {100, 1000, 10000}) {
    if (n > max_n) break;
    for (const char* algo : {"newalg", "newalg-ls"}) {
      if (n >= 10000 && std::string(algo) == "newalg-ls") continue;
      if (!only.empty() && only != algo) continue;
      const int r = n >= 10000 ? std::max(1, reps / 3) : reps;
      std::vector<double> ms;
      double reward = 0;
      size_t visited = 0;
      mound::plan::OpInstance inst;
      for (int k = 0; k < r; ++k) {
        inst = Field(n, 100 + k);
        mound::plan::NewAlgOptions opt;
        opt.seed = k + 1;
        const auto t0 = std::chrono::steady_clock::now();
        const auto res = std::string(algo) == "newalg" ? mound::plan::SolveNewAlg(inst, opt)
                                                       : mound::plan::SolveNewAlgLs(inst, opt);
        ms.push_back(
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                .count());
        reward += res.reward / r;
        visited += (res.route.size() - 2);
      }
      const double med = Median(ms);
      std::printf("%-7d %-10s %8.1f %8.1f %8.2f %9.3f %10.3f %11.0fx %12.0fx\n", n, algo,
                  inst.budget_m, static_cast<double>(visited) / r, reward,
                  *std::min_element(ms.begin(), ms.end()), med, paper_low_s * 1000 / med,
                  paper_high_s * 1000 / med);
      std::fflush(stdout);
    }
  }
  return 0;
}
