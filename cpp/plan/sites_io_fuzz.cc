// libFuzzer target: mound.sites JSON -> OpInstance, and for small valid instances the
// planners on it (the planner crashed on x_m 1e155 that the reader accepted).
#include <cstddef>
#include <cstdint>
#include <string>

#include "common/fuzz_check.h"
#include "plan/baselines.h"
#include "plan/newalg.h"
#include "plan/sites_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  mound::fuzz::ExpectValueOrInputError([&] {
    const mound::plan::SitesFile s = mound::plan::ParseSites(text, "fuzz.json", std::nullopt);
    const auto& inst = s.instance;
    if (inst.Size() > 24) return;
    mound::plan::NewAlgOptions o;
    o.max_rounds = 3;
    const auto r = mound::plan::SolveNewAlg(inst, o);
    if (!inst.CheckRoute(r.route).empty()) std::abort();
    const auto g = mound::plan::SolveGreedy(inst);
    if (!inst.CheckRoute(g.route).empty()) std::abort();
  });
  return 0;
}
