// libFuzzer target: TSPLIB/OPLib text -> instance, and for small instances one LKH run
// (its 1-tree code crashed on a coordinate of 1e18 that the reader accepted).
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>

#include "common/fuzz_check.h"
#include "tsp/solver.h"
#include "tsp/tsplib.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  mound::fuzz::ExpectValueOrInputError([&] {
    const mound::tsp::TsplibInstance inst = mound::tsp::ParseTsplib(text, "fuzz.tsp");
    if (inst.depot < 0 || inst.depot >= inst.dimension) std::abort();
    if (inst.dimension > 16) return;
    mound::tsp::SolverOptions o;
    o.max_trials = 2;
    const auto r = mound::tsp::SolveTsp(*inst.problem, o);
    std::vector<int> t = r.tour;
    std::sort(t.begin(), t.end());
    for (int i = 0; i < inst.dimension; ++i)
      if (t[i] != i) std::abort();
    if (r.length < 0) std::abort();
  });
  return 0;
}
