#include "plan/sites_io.h"

#include <cmath>
#include <limits>
#include <unordered_map>

#include "common/atomic_file.h"
#include "common/error.h"
#include "common/json_util.h"

namespace mound::plan {
namespace {

// Magnitudes a survey can have, checked before any arithmetic: coordinates of a local
// frame within 10^8 m (the Earth's circumference is 4 * 10^7 m), scan and take-off costs
// within 10^8 m, budgets within 10^12 m, rewards within 10^12, latitudes and longitudes
// in degrees. Beyond them, squared distances and sums lose all precision or overflow.
constexpr double kMaxCoordM = 1e8;
constexpr double kMaxCostM = 1e8;
constexpr double kMaxBudgetM = 1e12;
constexpr double kMaxReward = 1e12;

// `terrain` (written by mound field make --dem): extra_m, an n x n symmetric matrix of
// non-negative climb costs in the planner's node order (home, the end of a path, the sites
// in file order; `nodes[].id` in that order when given), and path_offset_m.
void ReadTerrain(const nlohmann::json& t, SitesFile* out) {
  OpInstance& inst = out->instance;
  if (!t.is_object()) throw InputError("terrain: must be an object");
  if (t.contains("version")) {
    const auto& v = t["version"];
    if (!v.is_number_integer() || v.get<int64_t>() != 1) {
      throw InputError("terrain.version: this mound_plan reads version 1");
    }
  }
  const size_t n = inst.nodes.size();
  if (t.contains("nodes")) {
    const auto& ns = t["nodes"];
    if (!ns.is_array() || ns.size() != n) {
      throw InputError("terrain.nodes: expected " + std::to_string(n) +
                       " entries (home, end, sites in file order)");
    }
    for (size_t i = 0; i < n; ++i) {
      const std::string p = "terrain.nodes[" + std::to_string(i) + "]";
      if (!ns[i].is_object()) throw InputError(p + ": must be an object");
      if (RequireId(ns[i], "id", p) != inst.nodes[i].id) {
        throw InputError(p + ".id: expected \"" + inst.nodes[i].id +
                         "\" (the planner's node order)");
      }
    }
  }
  const auto& m = RequireField(t, "extra_m", "terrain");
  if (!m.is_array() || m.size() != n) {
    throw InputError("terrain.extra_m: expected " + std::to_string(n) + " rows of " +
                     std::to_string(n) + " numbers");
  }
  inst.extra_m.assign(n * n, 0.0);
  for (size_t i = 0; i < n; ++i) {
    const std::string p = "terrain.extra_m[" + std::to_string(i) + "]";
    if (!m[i].is_array() || m[i].size() != n) {
      throw InputError(p + ": expected " + std::to_string(n) + " numbers");
    }
    for (size_t j = 0; j < n; ++j) {
      const auto& v = m[i][j];
      if (!v.is_number() || !std::isfinite(v.get<double>()) || v.get<double>() < 0 ||
          v.get<double>() > kMaxCostM) {
        throw InputError(p + "[" + std::to_string(j) + "]: expected a number in [0, 1e8]");
      }
      inst.extra_m[i * n + j] = v.get<double>();
    }
  }
  for (size_t i = 0; i < n; ++i) {
    if (inst.extra_m[i * n + i] != 0) {
      throw InputError("terrain.extra_m[" + std::to_string(i) + "][" + std::to_string(i) +
                       "]: the diagonal must be 0");
    }
    for (size_t j = 0; j < i; ++j) {
      const double a = inst.extra_m[i * n + j], b = inst.extra_m[j * n + i];
      if (std::abs(a - b) > 1e-6 * (1.0 + std::abs(a))) {
        throw InputError("terrain.extra_m[" + std::to_string(i) + "][" + std::to_string(j) +
                         "]: not symmetric (" + FormatNumber(a) + " vs " + FormatNumber(b) + ")");
      }
      inst.extra_m[i * n + j] = inst.extra_m[j * n + i] = std::max(a, b);
    }
  }
  out->path_offset_m =
      OptionalInRange(t, "path_offset_m", "terrain", -kMaxCostM, kMaxCostM).value_or(0.0);
  out->terrain = t;
  out->terrain.erase("extra_m");
}

}  // namespace

SitesFile ParseSites(const std::string& text, const std::string& path,
                     std::optional<double> budget_override) {
  const nlohmann::json doc = ParseJson(text, path);
  CheckSchema(doc, "mound.sites", 1, path);
  SitesFile out;
  out.path = path;
  OpInstance& inst = out.instance;
  if (doc.contains("origin") && !doc["origin"].is_null()) {
    const auto& o = doc["origin"];
    if (!o.is_object()) throw InputError("origin: must be an object");
    RequireInRange(o, "lat", "origin", -90, 90);
    RequireInRange(o, "lon", "origin", -180, 180);
    OptionalInRange(o, "alt_m", "origin", -1e5, 1e5);
    out.origin = o;
  }
  if (doc.contains("scan") && !doc["scan"].is_null()) {
    if (!doc["scan"].is_object()) throw InputError("scan: must be an object");
    out.scan = doc["scan"];
  }
  out.takeoff_landing_m = OptionalInRange(doc, "takeoff_landing_m", "", 0, kMaxCostM).value_or(0.0);
  const nlohmann::json& home = RequireField(doc, "home", "");
  OpNode h;
  h.id = RequireId(home, "id", "home");
  h.x_m = RequireInRange(home, "x_m", "home", -kMaxCoordM, kMaxCoordM);
  h.y_m = RequireInRange(home, "y_m", "home", -kMaxCoordM, kMaxCoordM);
  h.scan_cost_m = out.takeoff_landing_m;
  inst.nodes.push_back(h);

  if (doc.contains("end") && !doc["end"].is_null()) {
    const nlohmann::json& end = doc["end"];
    const std::string id = RequireId(end, "id", "end");
    if (id != h.id) {
      OpNode e;
      e.id = id;
      e.x_m = RequireInRange(end, "x_m", "end", -kMaxCoordM, kMaxCoordM);
      e.y_m = RequireInRange(end, "y_m", "end", -kMaxCoordM, kMaxCoordM);
      e.scan_cost_m = out.takeoff_landing_m;
      inst.nodes.push_back(e);
      inst.end = 1;
    }
  }

  const nlohmann::json& sites = RequireField(doc, "sites", "");
  if (!sites.is_array()) throw InputError("sites: must be an array");
  if (sites.empty()) throw InputError("sites: must not be empty");
  std::unordered_map<std::string, size_t> seen;
  for (const OpNode& n : inst.nodes) seen[n.id] = std::numeric_limits<size_t>::max();
  for (size_t i = 0; i < sites.size(); ++i) {
    const std::string p = "sites[" + std::to_string(i) + "]";
    const nlohmann::json& s = sites[i];
    if (!s.is_object()) throw InputError(p + ": must be an object");
    OpNode n;
    n.id = RequireId(s, "id", p);
    auto [it, inserted] = seen.emplace(n.id, i);
    if (!inserted) {
      const std::string other = it->second == std::numeric_limits<size_t>::max()
                                    ? "the home/end node"
                                    : "sites[" + std::to_string(it->second) + "]";
      throw InputError(p + ".id: duplicate id \"" + n.id + "\" (also " + other + ")");
    }
    n.x_m = RequireInRange(s, "x_m", p, -kMaxCoordM, kMaxCoordM);
    n.y_m = RequireInRange(s, "y_m", p, -kMaxCoordM, kMaxCoordM);
    n.reward = RequireInRange(s, "reward", p, 0, kMaxReward);
    n.scan_cost_m = OptionalInRange(s, "scan_cost_m", p, 0, kMaxCostM).value_or(0.0);
    inst.nodes.push_back(n);
  }

  if (doc.contains("terrain") && !doc["terrain"].is_null()) ReadTerrain(doc["terrain"], &out);

  if (budget_override) {
    if (!std::isfinite(*budget_override) || *budget_override < 0 ||
        *budget_override > kMaxBudgetM) {
      throw InputError("BUDGET: must be a finite number in [0, 1e12]");
    }
    inst.budget_m = *budget_override;
    if (doc.contains("budget_m"))
      RequireInRange(doc, "budget_m", "", 0, kMaxBudgetM);  // still validated
  } else {
    if (!doc.contains("budget_m")) {
      throw InputError("budget_m: missing (give it in " + path +
                       " or as BUDGET on the command line)");
    }
    inst.budget_m = RequireInRange(doc, "budget_m", "", 0, kMaxBudgetM);
    out.budget_in_file = true;
  }

  if (out.path_offset_m != 0) {
    if (inst.Closed()) throw InputError("terrain.path_offset_m: must be 0 for a closed tour");
    if (inst.budget_m - out.path_offset_m < 0) {
      throw InputError("budget_m: " + FormatNumber(inst.budget_m) +
                       " m is less than the "
                       "climb from home to the end node (terrain.path_offset_m " +
                       FormatNumber(out.path_offset_m) + " m)");
    }
    inst.budget_m -= out.path_offset_m;
  }

  // A budget that cannot even leave home is an input error, not an empty plan.
  const double slack = BudgetSlack(inst.budget_m);
  if (!inst.Closed()) {
    const double direct = inst.Cost(OpInstance::kHome, inst.end);
    if (direct > inst.budget_m + slack) {
      throw InputError("budget_m: " + FormatNumber(inst.budget_m) +
                       " m is less than the direct home->end trip of " + FormatNumber(direct) +
                       " m");
    }
  } else {
    double cheapest = std::numeric_limits<double>::infinity();
    for (int v = inst.FirstSite(); v < inst.Size(); ++v) {
      cheapest = std::min(cheapest, 2 * inst.Cost(OpInstance::kHome, v));
    }
    if (cheapest > inst.budget_m + slack) {
      throw InputError("budget_m: " + FormatNumber(inst.budget_m) +
                       " m is too small to leave home (the cheapest round trip to a site costs " +
                       FormatNumber(cheapest) + " m)");
    }
  }
  return out;
}

SitesFile ReadSites(const std::string& path, std::optional<double> budget_override) {
  return ParseSites(ReadFile(path), path, budget_override);
}

nlohmann::json PlanToJson(const SitesFile& sites, const PlanSummary& plan) {
  const OpInstance& inst = sites.instance;
  const std::vector<std::vector<int>> flights =
      plan.flights.empty() ? std::vector<std::vector<int>>{plan.route} : plan.flights;
  const double budget = inst.budget_m + sites.path_offset_m;
  nlohmann::json j;
  j["schema"] = "mound.plan";
  j["version"] = 1;
  j["status"] = "ok";
  j["algo"] = plan.algo;
  j["sites_file"] = sites.path;
  j["closed"] = inst.Closed();
  nlohmann::json wps = nlohmann::json::array();
  nlohmann::json fl = nlohmann::json::array();
  std::vector<char> listed(inst.Size(), 0);
  double reward = 0, cost = 0;
  int visited = 0;
  for (size_t k = 0; k < flights.size(); ++k) {
    const std::vector<int>& route = flights[k];
    nlohmann::json tour = nlohmann::json::array();
    double cum = 0;
    for (size_t i = 0; i < route.size(); ++i) {
      const OpNode& n = inst.nodes[route[i]];
      if (i > 0) cum += inst.Cost(route[i - 1], route[i]);
      tour.push_back(n.id);
      const bool site = inst.IsSite(route[i]);
      visited += site;
      // The first flight's nodes in its order (home twice on a closed tour), then the
      // sites of the others.
      if (k > 0 && listed[route[i]]) continue;
      listed[route[i]] = 1;
      wps.push_back({{"id", n.id},
                     {"x_m", n.x_m},
                     {"y_m", n.y_m},
                     {"kind", site ? "site" : (i == 0 ? "home" : "end")},
                     {"reward", site ? n.reward : 0.0},
                     {"scan_cost_m", site ? n.scan_cost_m : 0.0},
                     {"cum_cost_m", cum},
                     {"flight", k + 1}});
    }
    const double c = inst.RouteCost(route) + sites.path_offset_m;
    const double r = inst.RouteReward(route);
    fl.push_back({{"flight", k + 1},
                  {"tour", tour},
                  {"reward", r},
                  {"cost_m", c},
                  {"budget_left_m", budget - c}});
    reward += r;
    cost += c;
  }
  j["tour"] = fl[0]["tour"];
  j["reward"] = reward;
  j["cost_m"] = cost;
  j["budget_m"] = budget;
  j["budget_source"] = sites.budget_in_file ? "file" : "command line";
  // One flight: what it leaves; several: what they leave together.
  j["budget_left_m"] = budget * static_cast<double>(flights.size()) - cost;
  j["flights"] = fl;
  j["elapsed_s"] = plan.elapsed_s;
  j["n_sites"] = inst.Size() - inst.FirstSite();
  j["n_visited"] = visited;
  j["seed"] = plan.seed;
  j["waypoints"] = wps;
  j["solver"] = plan.solver;
  if (!sites.origin.is_null()) j["origin"] = sites.origin;
  if (!sites.scan.is_null()) j["scan"] = sites.scan;
  j["takeoff_landing_m"] = sites.takeoff_landing_m;
  if (!sites.terrain.is_null()) j["terrain"] = sites.terrain;
  return j;
}

}  // namespace mound::plan
