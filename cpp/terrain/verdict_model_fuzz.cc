// libFuzzer target: the verdict model reader (mound.verdict_model JSON, outside files that
// `mound_recon verdict --model` reads): a model or an InputError, and a read model's
// probabilities are finite numbers in [0, 1].
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "common/fuzz_check.h"
#include "terrain/verdict_model.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  mound::fuzz::ExpectValueOrInputError([&] {
    nlohmann::json doc;
    try {
      doc = nlohmann::json::parse(text);
    } catch (const nlohmann::json::exception&) {
      return;  // not JSON: LoadVerdictModel's InputError
    }
    const mound::terrain::VerdictModel m = mound::terrain::ParseVerdictModel(doc, "model.json");
    const std::vector<double> f(mound::terrain::VerdictFeatureNames().size(), 0.5);
    const double p = m.Probability(f);
    if (!(p >= 0 && p <= 1)) std::abort();
  });
  return 0;
}
