// libFuzzer target: the verdict model reader (mound.verdict_model JSON, outside files that
// `mound_recon verdict --model` reads) and the first look's reader (the verdict.json that
// `verdict --second-look` reads): each a value or an InputError; a read model's
// probabilities, and a read first look's p, are finite numbers in [0, 1], and so is the
// second look's p from them; a read terrain domain's ranges are ordered and what it names
// outside lies outside.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "common/fuzz_check.h"
#include "terrain/verdict_model.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception&) {
    return 0;  // not JSON: the loaders' InputError
  }
  auto in_unit = [](double p) {
    if (!(p >= 0 && p <= 1)) std::abort();
  };
  std::optional<double> first;
  mound::fuzz::ExpectValueOrInputError([&] {
    first = mound::terrain::FirstLookP(doc, "verdict.json");
    in_unit(*first);
  });
  mound::fuzz::ExpectValueOrInputError([&] {
    const mound::terrain::VerdictModel m = mound::terrain::ParseVerdictModel(doc, "model.json");
    const std::vector<double> f(mound::terrain::VerdictFeatureNames().size(), 0.5);
    const double p = m.Probability(f);
    in_unit(p);
    if (m.second_look) {
      const double q = first.value_or(p);
      (void)m.SecondLookAdvised(q);
      in_unit(m.SecondLookProbability(q, p));
      in_unit(m.SecondLookProbability(0.0, 1.0));
      in_unit(m.SecondLookProbability(1.0, 0.0));
    }
    // three answers by the site's slope: every band (one or by slope) lies in (0, 1)
    if (m.undecided)
      for (const double slope : {-2.0, 0.0, 0.3, 1.0, 2.0, std::nan("")}) {
        const mound::terrain::UndecidedBand b = m.BandFor(slope);
        if (!(b.p_low > 0 && b.p_low <= b.p_high && b.p_high < 1)) std::abort();
        (void)m.Label(p, m.threshold, slope);
      }
    // the terrain domain: each excess names a descriptor whose value lies outside its range
    mound::terrain::Detection d;
    d.site_slope_rad = 0.6;
    d.site_relief_m = -1;
    for (const mound::terrain::TerrainExcess& e : m.OutsideTerrain(d))
      if (!(e.low <= e.high) || (e.value >= e.low && e.value <= e.high)) std::abort();
  });
  return 0;
}
