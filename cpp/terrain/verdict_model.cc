#include "terrain/verdict_model.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <sstream>
#include <tuple>

#include "common/error.h"
#include "common/json_util.h"
#include "terrain/default_verdict_model.h"

namespace mound::terrain {
namespace {

double Number(const nlohmann::json& doc, const std::string& key, const std::string& source) {
  if (!doc.contains(key)) throw InputError(source + ": " + key + ": missing required field");
  const nlohmann::json& v = doc[key];
  if (!v.is_number() || !std::isfinite(v.get<double>()))
    throw InputError(source + ": " + key + ": expected a finite number");
  return v.get<double>();
}

std::vector<double> Numbers(const nlohmann::json& doc, const std::string& key, size_t n,
                            const std::string& source) {
  if (!doc.contains(key)) throw InputError(source + ": " + key + ": missing required field");
  const nlohmann::json& v = doc[key];
  if (!v.is_array() || v.size() != n)
    throw InputError(source + ": " + key + ": expected " + std::to_string(n) + " numbers");
  std::vector<double> out;
  for (const auto& x : v) {
    if (!x.is_number() || !std::isfinite(x.get<double>()))
      throw InputError(source + ": " + key + ": expected finite numbers");
    out.push_back(x.get<double>());
  }
  return out;
}

// Two numbers of an object, `low_key` and `high_key`, with 0 < low <= high < ceiling (the
// Python reader's _ordered_pair).
std::pair<double, double> OrderedPair(const nlohmann::json& doc, const std::string& low_key,
                                      const std::string& high_key, double ceiling,
                                      const std::string& at) {
  if (!doc.is_object()) throw InputError(at + ": expected {" + low_key + ", " + high_key + "}");
  const double lo = Number(doc, low_key, at), hi = Number(doc, high_key, at);
  if (!(lo > 0 && lo <= hi && hi < ceiling)) {
    std::ostringstream why;
    why << at << ": " << low_key << ", " << high_key << ": must be 0 < " << low_key
        << " <= " << high_key << " < " << ceiling;
    throw InputError(why.str());
  }
  return {lo, hi};
}

// undecided.by_slope: 2 to 8 bands {site_slope_rad: [low, high), p_low, p_high}, ascending
// and contiguous within [-pi/2, pi/2] (the Python reader's _check_slope_bands).
std::vector<SlopeBand> ParseSlopeBands(const nlohmann::json& doc, const std::string& at) {
  if (!doc.is_array() || doc.size() < 2 || doc.size() > 8)
    throw InputError(at + ": expected 2 to 8 bands");
  std::vector<SlopeBand> out;
  double end = -M_PI / 2;
  for (size_t k = 0; k < doc.size(); ++k) {
    const std::string where = at + "[" + std::to_string(k) + "]";
    const nlohmann::json& b = doc[k];
    if (!b.is_object()) throw InputError(where + ": expected {site_slope_rad, p_low, p_high}");
    const std::vector<double> r = Numbers(b, "site_slope_rad", 2, where);
    SlopeBand s;
    s.slope_low = r[0];
    s.slope_high = r[1];
    if (!(-M_PI / 2 - 1e-9 <= s.slope_low && s.slope_low < s.slope_high &&
          s.slope_high <= M_PI / 2 + 1e-9))
      throw InputError(where + ": site_slope_rad: must be low < high within [-pi/2, pi/2]");
    if (k && std::fabs(s.slope_low - end) > 1e-9)
      throw InputError(where + ": site_slope_rad: must start where the last ended");
    end = s.slope_high;
    std::tie(s.band.p_low, s.band.p_high) = OrderedPair(b, "p_low", "p_high", 1, where);
    out.push_back(s);
  }
  return out;
}

// terrain_domain.neighbours (see verdict_model.h; the Python reader's _check_neighbours).
TerrainNeighbours ParseTerrainNeighbours(const nlohmann::json& doc, const std::string& at) {
  const size_t n = TerrainDescriptorNames().size();
  if (!doc.is_object())
    throw InputError(at + ": expected {k, centre, scale, points, max_distance}");
  TerrainNeighbours t;
  if (!doc.contains("k") || !doc["k"].is_number_integer() || doc["k"].get<int64_t>() < 1 ||
      doc["k"].get<int64_t>() > 50)
    throw InputError(at + ": k: expected an integer in 1..50");
  t.k = doc["k"].get<int>();
  t.centre = Numbers(doc, "centre", n, at);
  t.scale = Numbers(doc, "scale", n, at);
  for (size_t j = 0; j < n; ++j)
    if (!(std::fabs(t.centre[j]) <= 1e9) || !(t.scale[j] >= 1e-9 && t.scale[j] <= 1e9))
      throw InputError(at + ": centre within +-1e9, scale in [1e-9, 1e9]");
  const auto p = doc.find("points");
  if (p == doc.end() || !p->is_array() || p->size() < static_cast<size_t>(t.k) ||
      p->size() > 100000)
    throw InputError(at + ": points: expected k to 100,000 points");
  for (size_t j = 0; j < p->size(); ++j) {
    const nlohmann::json& q = (*p)[j];
    const std::string where = at + ": points[" + std::to_string(j) + "]";
    if (!q.is_array() || q.size() != n)
      throw InputError(where + ": expected " + std::to_string(n) + " finite numbers");
    std::vector<double> row;
    for (const auto& x : q) {
      if (!x.is_number() || !std::isfinite(x.get<double>()) || std::fabs(x.get<double>()) > 1e9)
        throw InputError(where + ": expected " + std::to_string(n) + " finite numbers");
      row.push_back(x.get<double>());
    }
    t.points.push_back(std::move(row));
  }
  t.max_distance = Number(doc, "max_distance", at);
  if (!(t.max_distance >= 0 && t.max_distance <= 1e9))
    throw InputError(at + ": max_distance: must be in [0, 1e9]");
  return t;
}

}  // namespace

double VerdictModel::Score(const std::vector<double>& f) const {
  const size_t n = mean.size();
  if (f.size() != n || index.size() != n) throw InternalError("VerdictModel: feature count");
  double s = bias;
  std::vector<double> zs(n);
  for (size_t k = 0; k < n; ++k) {
    double z = (f[index[k]] - mean[k]) / std[k];
    if (z_clip > 0) z = std::clamp(z, -z_clip, z_clip);
    zs[k] = z;
    s += weights[k] * z;
    if (hinge)
      s += weights[n + k] * std::max(z - 1, 0.0) + weights[2 * n + k] * std::max(-z - 1, 0.0);
  }
  for (size_t p = 0; p < products.size(); ++p)
    s += weights[3 * n + p] * std::clamp(zs[products[p].first], -product_clip, product_clip) *
         std::clamp(zs[products[p].second], -product_clip, product_clip);
  return s;
}

double VerdictModel::Calibrated(double s) const {
  if (!beta) return s;
  // softplus(x) = ln(1 + e^x), without overflow
  auto softplus = [](double x) { return std::max(x, 0.0) + std::log1p(std::exp(-std::fabs(x))); };
  return beta_b * softplus(s) - beta_a * softplus(-s) + beta_c;
}

double VerdictModel::Probability(const std::vector<double>& f) const {
  return 1 / (1 + std::exp(-Calibrated(Score(f))));
}

double VerdictModel::Probability(const Detection& d, size_t* best) const {
  if (d.judged.empty()) return p_no_rise;
  double top = -std::numeric_limits<double>::infinity();
  for (size_t k = 0; k < d.judged.size(); ++k) {
    const double s = Score(VerdictFeatures(d, d.judged[k]));
    if (s > top) {
      top = s;
      if (best) *best = k;
    }
  }
  return 1 / (1 + std::exp(-Calibrated(top)));  // g increasing: the highest rise's p
}

UndecidedBand VerdictModel::BandFor(double slope_rad) const {
  if (!undecided) throw InternalError("BandFor: the model has no undecided band");
  if (slope_bands.empty() || !std::isfinite(slope_rad)) return *undecided;
  for (const SlopeBand& b : slope_bands)
    if (slope_rad < b.slope_high) return b.band;
  return slope_bands.back().band;
}

std::string VerdictModel::Label(double p, double two_answer_at, double slope_rad) const {
  if (undecided) {
    const UndecidedBand b = BandFor(slope_rad);
    return p >= b.p_high ? "mound" : p < b.p_low ? "no_mound" : "undecided";
  }
  return p >= two_answer_at ? "mound" : "no_mound";
}

bool VerdictModel::SecondLookAdvised(double p, double slope_rad) const {
  if (!second_look) return false;
  if (undecided) {
    const UndecidedBand b = BandFor(slope_rad);
    return p >= b.p_low && p < b.p_high;
  }
  return p >= second_look->p_low && p < threshold;
}

double VerdictModel::SecondLookProbability(double p_first, double p_second) const {
  auto logit = [](double p) {
    const double q = std::clamp(p, 1e-12, 1 - 1e-12);
    return std::log(q / (1 - q));
  };
  const SecondLook& l = *second_look;
  return 1 / (1 + std::exp(-(l.first * logit(p_first) + l.second * logit(p_second) + l.bias)));
}

double TerrainNeighbours::Distance(const std::vector<double>& descriptors) const {
  std::vector<double> z(centre.size());  // the site's ground, standardised once
  for (size_t j = 0; j < z.size(); ++j) z[j] = (descriptors[j] - centre[j]) / scale[j];
  std::vector<double> d;
  d.reserve(points.size());
  for (const std::vector<double>& q : points) {
    double s = 0;
    for (size_t j = 0; j < q.size(); ++j) s += (z[j] - q[j]) * (z[j] - q[j]);
    d.push_back(std::sqrt(s));
  }
  const size_t n = std::min(static_cast<size_t>(k), d.size());
  std::partial_sort(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(n), d.end());
  double sum = 0;
  for (size_t j = 0; j < n; ++j) sum += d[j];
  return n ? sum / static_cast<double>(n) : 0.0;
}

std::vector<TerrainExcess> VerdictModel::OutsideTerrain(const Detection& d) const {
  std::vector<TerrainExcess> out;
  const std::vector<double> v = TerrainDescriptors(d);
  for (const auto& [at, range] : terrain_ranges)
    if (!(v[at] >= range.first && v[at] <= range.second))
      out.push_back({TerrainDescriptorNames()[at], v[at], range.first, range.second});
  if (terrain_neighbours) {
    const double far = terrain_neighbours->Distance(v);
    if (!(far <= terrain_neighbours->max_distance))
      out.push_back({"training_distance", far, 0.0, terrain_neighbours->max_distance});
  }
  return out;
}

namespace {

// The model's features in any order, but exactly the detector's (`index`).
void ParseFeatureNames(const nlohmann::json& doc, const std::string& source, VerdictModel* m) {
  if (!doc.contains("features") || !doc["features"].is_array())
    throw InputError(source + ": features: expected a list of names");
  for (const auto& n : doc["features"]) {
    if (!n.is_string()) throw InputError(source + ": features: expected a list of names");
    m->features.push_back(n.get<std::string>());
  }
  // The model's features in any order, but exactly the detector's: `index[k]` is the
  // detector's position of the model's k-th feature.
  const std::vector<std::string>& mine = VerdictFeatureNames();
  std::vector<size_t> index;
  for (const std::string& name : m->features) {
    const auto it = std::find(mine.begin(), mine.end(), name);
    if (it == mine.end() || std::count(m->features.begin(), m->features.end(), name) > 1) break;
    index.push_back(static_cast<size_t>(it - mine.begin()));
  }
  if (index.size() != m->features.size() || index.size() != mine.size()) {
    std::string want;
    for (const auto& n : mine) want += (want.empty() ? "" : ",") + n;
    throw InputError(source + ": features: made for other features than this detector's (" + want +
                     ")");
  }
  m->index = index;
}

// The basis (linear, hinge, hinge_products with its products) and z_clip.
void ParseBasis(const nlohmann::json& doc, const std::string& source, VerdictModel* m) {
  const size_t n = m->features.size();
  std::string basis = "linear";  // absent: linear; present, it must be a known name
  if (doc.contains("basis"))
    basis = doc["basis"].is_string() ? doc["basis"].get<std::string>() : "";
  if (basis != "linear" && basis != "hinge" && basis != "hinge_products")
    throw InputError(source + ": basis: expected \"linear\", \"hinge\" or \"hinge_products\"");
  m->hinge = basis != "linear";
  if (basis == "hinge_products") {
    if (!doc.contains("products") || !doc["products"].is_array() || doc["products"].empty())
      throw InputError(source + ": products: expected a list of pairs of feature names");
    for (const auto& pair : doc["products"]) {
      size_t at[2] = {n, n};
      for (int e = 0; e < 2 && pair.is_array() && pair.size() == 2; ++e)
        if (pair[e].is_string()) {
          const auto it =
              std::find(m->features.begin(), m->features.end(), pair[e].get<std::string>());
          at[e] = static_cast<size_t>(it - m->features.begin());
        }
      if (at[0] >= n || at[1] >= n || at[0] == at[1])
        throw InputError(source + ": products: each a pair of two of the model's features");
      m->products.emplace_back(at[0], at[1]);
    }
    m->product_clip = Number(doc, "product_clip", source);
    if (!(m->product_clip > 0 && m->product_clip <= 1e6))
      throw InputError(source + ": product_clip: must be > 0 (within 1e6)");
  } else if (doc.contains("products")) {
    throw InputError(source + ": products: only with basis \"hinge_products\"");
  }
  if (doc.contains("z_clip") && !doc["z_clip"].is_null()) {
    m->z_clip = Number(doc, "z_clip", source);
    if (!(m->z_clip > 0 && m->z_clip <= 1e6))
      throw InputError(source + ": z_clip: must be > 0 (within 1e6), or absent");
  }
}

// The standardisation, weights, bias, threshold and p_no_rise, bounded.
void ParseWeights(const nlohmann::json& doc, const std::string& source, VerdictModel* m) {
  const size_t n = m->features.size();
  m->mean = Numbers(doc, "mean", n, source);
  m->std = Numbers(doc, "std", n, source);
  m->weights = Numbers(doc, "weights", (m->hinge ? 3 * n : n) + m->products.size(), source);
  // Bounded, so that every score is a finite number (huge weights of both signs would
  // make inf - inf).
  for (double s : m->std)
    if (!(s >= 1e-9 && s <= 1e9))
      throw InputError(source + ": std: must be > 0 (within 1e-9 .. 1e9)");
  for (const auto* v : {&m->mean, &m->weights})
    for (double x : *v)
      if (!(std::fabs(x) <= 1e6))
        throw InputError(source + ": " + (v == &m->mean ? "mean" : "weights") +
                         ": must be within +-1e6");
  m->bias = Number(doc, "bias", source);
  if (!(std::fabs(m->bias) <= 1e6)) throw InputError(source + ": bias: must be within +-1e6");
  m->threshold = Number(doc, "threshold", source);
  m->p_no_rise = Number(doc, "p_no_rise", source);
  if (!(m->threshold > 0 && m->threshold < 1))
    throw InputError(source + ": threshold: must be in (0, 1)");
  if (!(m->p_no_rise >= 0 && m->p_no_rise <= 1))
    throw InputError(source + ": p_no_rise: must be in [0, 1]");
}

// The beta calibration of the p (`calibration`).
void ParseCalibration(const nlohmann::json& c, const std::string& at, VerdictModel* m) {
  if (!c.is_object() || !c.contains("method") || c["method"] != "beta")
    throw InputError(at + ": expected {\"method\": \"beta\", \"a\", \"b\", \"c\"}");
  m->beta = true;
  m->beta_a = Number(c, "a", at);
  m->beta_b = Number(c, "b", at);
  m->beta_c = Number(c, "c", at);
  if (!(m->beta_a >= 0 && m->beta_b >= 0 && m->beta_a + m->beta_b > 0 && m->beta_a <= 1e6 &&
        m->beta_b <= 1e6))
    throw InputError(at + ": a, b: must be >= 0 (within 1e6), a + b > 0");
  if (!(std::fabs(m->beta_c) <= 1e6)) throw InputError(at + ": c: must be within +-1e6");
}

// The second look's rule (`second_look`).
void ParseSecondLook(const nlohmann::json& sl, const std::string& at, VerdictModel* m) {
  if (!sl.is_object() || !sl.contains("combine") || !sl["combine"].is_object())
    throw InputError(at +
                     ": expected {p_low, threshold, scan_factor, combine: {first, "
                     "second, bias}}");
  SecondLook l;
  l.p_low = Number(sl, "p_low", at);
  l.threshold = Number(sl, "threshold", at);
  l.scan_factor = Number(sl, "scan_factor", at);
  l.first = Number(sl["combine"], "first", at + ".combine");
  l.second = Number(sl["combine"], "second", at + ".combine");
  l.bias = Number(sl["combine"], "bias", at + ".combine");
  if (!(l.p_low > 0 && l.p_low < m->threshold))
    throw InputError(at + ": p_low: must be in (0, threshold)");
  if (!(l.threshold > 0 && l.threshold < 1))
    throw InputError(at + ": threshold: must be in (0, 1)");
  if (!(l.scan_factor > 1 && l.scan_factor <= 100))
    throw InputError(at + ": scan_factor: must be in (1, 100]");
  if (!(l.second > 0 && l.second <= 1e6))
    throw InputError(at + ".combine: second: must be in (0, 1e6]");
  if (!(std::fabs(l.first) <= 1e6) || !(std::fabs(l.bias) <= 1e6))
    throw InputError(at + ".combine: first, bias: must be within +-1e6");
  m->second_look = l;
}

// The cloud the model was trained on (`cloud_settings`).
void ParseCloudSettings(const nlohmann::json& c, const std::string& at, VerdictModel* m) {
  if (!c.is_object() || !c.contains("cloud") || !c["cloud"].is_string() ||
      (c["cloud"] != "dense" && c["cloud"] != "sparse"))
    throw InputError(at + ": expected {\"cloud\": \"dense\" | \"sparse\", options...}");
  CloudSettings cs;
  cs.cloud = c["cloud"].get<std::string>();
  for (const auto& [name, value] : c.items()) {
    if (name == "cloud") continue;
    if (!value.is_number() || !std::isfinite(value.get<double>()) ||
        std::fabs(value.get<double>()) > 1e9)
      throw InputError(at + ": " + name.substr(0, 40) + ": expected a finite number");
    if (cs.options.size() >= 64) throw InputError(at + ": more than 64 settings");
    cs.options.emplace_back(name, value.get<double>());
  }
  if (cs.cloud == "sparse" && !cs.options.empty())
    throw InputError(at + ": a sparse cloud has no densify options");
  m->cloud_settings = cs;
}

// The detector's candidates (`detector`).
void ParseDetector(const nlohmann::json& t, const std::string& at, VerdictModel* m) {
  if (!t.is_object() || t.size() != 1 || !t.contains("candidates") || !t["candidates"].is_string())
    throw InputError(at + ": expected {\"candidates\": \"site_ground\" | \"local_relief\"}");
  const auto c = CandidatesFromName(t["candidates"].get<std::string>());
  if (!c) throw InputError(at + ".candidates: site_ground or local_relief");
  m->candidates = *c;
}

// The terrain the model was trained on (`terrain_domain`).
void ParseTerrainDomain(const nlohmann::json& t, const std::string& at, VerdictModel* m) {
  if (!t.is_object() || !t.contains("ranges") || !t["ranges"].is_object() || t["ranges"].empty())
    throw InputError(at + ": expected {\"ranges\": {descriptor: [low, high], ...}}");
  const std::vector<std::string>& names = TerrainDescriptorNames();
  for (const auto& [name, range] : t["ranges"].items()) {
    const auto it = std::find(names.begin(), names.end(), name);
    if (it == names.end())
      throw InputError(at + ".ranges: " + name.substr(0, 40) +
                       ": not a terrain descriptor of this detector");
    const std::vector<double> lh = Numbers(t["ranges"], name, 2, at + ".ranges");
    if (!(lh[0] <= lh[1]) || std::fabs(lh[0]) > 1e9 || std::fabs(lh[1]) > 1e9)
      throw InputError(at + ".ranges: " + name + ": expected [low, high], low <= high");
    m->terrain_ranges.push_back({static_cast<size_t>(it - names.begin()), {lh[0], lh[1]}});
  }
  if (t.contains("neighbours"))
    m->terrain_neighbours = ParseTerrainNeighbours(t["neighbours"], at + ".neighbours");
}

}  // namespace

VerdictModel ParseVerdictModel(const nlohmann::json& doc, const std::string& source) {
  if (!doc.is_object()) throw InputError(source + ": expected a JSON object");
  if (!doc.contains("schema") || doc["schema"] != "mound.verdict_model")
    throw InputError(source + ": schema: expected \"mound.verdict_model\"");
  if (!doc.contains("version") || !doc["version"].is_number_integer() || doc["version"] != 1)
    throw InputError(source + ": version: expected 1");
  VerdictModel m;
  ParseFeatureNames(doc, source, &m);
  ParseBasis(doc, source, &m);
  ParseWeights(doc, source, &m);
  if (doc.contains("calibration"))
    ParseCalibration(doc["calibration"], source + ": calibration", &m);
  if (doc.contains("second_look"))
    ParseSecondLook(doc["second_look"], source + ": second_look", &m);
  if (doc.contains("undecided")) {
    const nlohmann::json& u = doc["undecided"];
    const std::string at = source + ": undecided";
    UndecidedBand band;
    std::tie(band.p_low, band.p_high) = OrderedPair(u, "p_low", "p_high", 1, at);
    m.undecided = band;
    if (u.contains("by_slope")) m.slope_bands = ParseSlopeBands(u["by_slope"], at + ".by_slope");
  }
  if (doc.contains("cloud_settings"))
    ParseCloudSettings(doc["cloud_settings"], source + ": cloud_settings", &m);
  if (doc.contains("detector")) ParseDetector(doc["detector"], source + ": detector", &m);
  if (doc.contains("reasons")) {
    ReasonThresholds t;
    std::tie(t.cut_roughness, t.irregular_roughness) = OrderedPair(
        doc["reasons"], "cut_roughness", "irregular_roughness", 1000, source + ": reasons");
    m.reasons = t;
  }
  if (doc.contains("terrain_domain"))
    ParseTerrainDomain(doc["terrain_domain"], source + ": terrain_domain", &m);
  m.doc = doc;
  return m;
}

void CheckCloudSettings(const CloudSettings& model, const std::string& cloud,
                        const nlohmann::json& options, const std::string& where) {
  if (cloud != model.cloud)
    throw InputError(where + ": a " + cloud + " cloud, and the model was trained on " +
                     model.cloud + " clouds (--model " + model.cloud + ", or the model of " +
                     cloud + " clouds)");
  for (const auto& [name, want] : model.options) {
    std::string flag = "--" + name;  // densify's option: max_image_size -> --max-image-size
    std::replace(flag.begin(), flag.end(), '_', '-');
    if (!options.is_object() || !options.contains(name) || !options[name].is_number())
      throw InputError(where + ": options." + name +
                       ": missing: cannot tell whether the cloud was made as the model's "
                       "training clouds were (mound_recon densify " +
                       flag + " " + FormatNumber(want) + ")");
    const double got = options[name].get<double>();
    if (!(std::fabs(got - want) <= 1e-9 * std::max(1.0, std::fabs(want))))
      throw InputError(where + ": options." + name + " is " + FormatNumber(got) +
                       ", the model was trained on clouds made with " + FormatNumber(want) +
                       ": a model judges only clouds like its training clouds (mound_recon "
                       "densify " +
                       flag + " " + FormatNumber(want) + ")");
  }
}

VerdictModel LoadVerdictModel(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open the verdict model");
  std::stringstream ss;
  ss << in.rdbuf();
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(ss.str());
  } catch (const nlohmann::json::exception& e) {
    throw InputError(path + ": not JSON (" + std::string(e.what()).substr(0, 120) + ")");
  }
  return ParseVerdictModel(doc, path);
}

const VerdictModel& DefaultVerdictModel() {
  static const VerdictModel m =
      ParseVerdictModel(nlohmann::json::parse(kDefaultVerdictModelJson),
                        "the default verdict model (data/verdict_model.json)");
  return m;
}

const VerdictModel& DenseVerdictModel() {
  static const VerdictModel m =
      ParseVerdictModel(nlohmann::json::parse(kDenseVerdictModelJson),
                        "the dense cloud's verdict model (data/verdict_model_dense.json)");
  return m;
}

const VerdictModel* BuiltInVerdictModel(const std::string& name) {
  if (name == "sparse") return &DefaultVerdictModel();
  if (name == "dense") return &DenseVerdictModel();
  return nullptr;
}

double FirstLookP(const nlohmann::json& verdict, const std::string& path) {
  // a field's text; "?" when absent or not a string (`fallback` when absent)
  auto text = [&](const char* key, const char* fallback) -> std::string {
    if (!verdict.is_object() || !verdict.contains(key)) return fallback;
    return verdict[key].is_string() ? verdict[key].get<std::string>() : "?";
  };
  if (text("schema", "?") != "mound.verdict")
    throw InputError(path + ": schema: expected \"mound.verdict\"");
  if (text("status", "?") != "ok")
    throw InputError(path + ": status: the first look was not judged");
  if (text("method", "?") != "reference_free_model")
    throw InputError(path + ": method: expected reference_free_model");
  if (text("look", "first") != "first")
    throw InputError(path + ": look: a second look's verdict, not the first's");
  if (!verdict.contains("p_mound") || !verdict["p_mound"].is_number())
    throw InputError(path + ": p_mound: expected a number");
  const double p = verdict["p_mound"].get<double>();
  if (!(p >= 0 && p <= 1)) throw InputError(path + ": p_mound: must be in [0, 1]");
  return p;
}

}  // namespace mound::terrain
