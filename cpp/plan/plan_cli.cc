#include "plan/plan_cli.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <map>
#include <optional>

#include "common/atomic_file.h"
#include "common/cli_args.h"
#include "common/error.h"
#include "plan/alns.h"
#include "plan/baselines.h"
#include "plan/exact_small.h"
#include "plan/flights.h"
#include "plan/newalg.h"
#include "plan/sites_io.h"
#include "tsp/solver.h"
#include "tsp/tsplib.h"

namespace mound::plan {
namespace {

constexpr const char* kVersion = "mound_plan " MOUND_VERSION;  // pyproject.toml's, from CMake

constexpr const char* kUsage =
    "usage: mound_plan SITES.json [BUDGET] [--algo NAME] [--seed N] [--iterations N]\n"
    "                  [--time-limit S] [--routes N] [--flights K] [--out PLAN.json]\n"
    "       mound_plan tsp FILE.tsp [--seed N] [--runs N] [--trials N] [--time-limit S]\n"
    "                  [--optimum L] [--kick-segment K] [--initial-period P]\n"
    "                  [--ascent-candidates K] [--out FILE.json]\n"
    "       mound_plan op FILE.oplib [--algo NAME] [--seed N] [--iterations N]\n"
    "                  [--time-limit S] [--routes N] [--out FILE.json]\n"
    "       mound_plan --help | --version\n"
    "\n"
    "Plans a UAV tour over candidate sites (orienteering): from the home node back home (or\n"
    "to the end node) collecting the most reward within the budget (metres).\n"
    "  BUDGET             overrides budget_m of SITES.json\n"
    "  --algo NAME        alns (alias best: adaptive large-neighbourhood search, the state\n"
    "                     of the art here), newalg (the paper's algorithm), newalg-ls (NewAlg\n"
    "                     plus an iterated local search), greedy (BenAlg), tsiligirides\n"
    "                     (1984), glv (Golden-Levy-Vohra 1987), exact (<= 16 sites, dynamic\n"
    "                     programme). Default: alns up to 1000 sites, newalg above\n"
    "  --seed N           random seed (default 1); equal seeds and limits give equal plans\n"
    "                     on any machine load\n"
    "  --iterations N     newalg-ls iterations (default 300); alns: at most N iterations\n"
    "  --time-limit S     newalg-ls: stop after S seconds (default: none); alns (default 1):\n"
    "                     S seconds of work counted in cost lookups (about S s on the\n"
    "                     reference machine, the same plan under load; a wall-clock guard\n"
    "                     stops it at 10 S, and solver.stopped_by says so)\n"
    "  --routes N         tsiligirides: routes built (default 3000, as in the original)\n"
    "  --flights K        K flights from home (batteries or aircraft), each within the\n"
    "                     budget, no site in two, the most reward in all (the team\n"
    "                     orienteering problem): alns on K routes with moves between them,\n"
    "                     exact (<= 14 sites), any other algorithm flight by flight;\n"
    "                     plan.json's flights[] ordered by reward (default 1)\n"
    "  --out FILE         write the result there (atomically) instead of stdout\n"
    "The tsp command solves a TSPLIB instance with the built-in Lin-Kernighan-Helsgaun\n"
    "engine and prints {\"length\", \"tour\" (1-based ids), ...}:\n"
    "  --runs N           independent runs, the best kept (default 1)\n"
    "  --trials N         trials per run (default: the number of nodes)\n"
    "  --time-limit S     stop after S seconds (the whole solve, the ascent included)\n"
    "  --optimum L        stop as soon as a tour of length L is found\n"
    "  --kick-segment K   longest segment of a double-bridge kick (default max(50, n/4))\n"
    "  --initial-period P subgradient ascent: first period (default max(n/2, 100); 300\n"
    "                     above 5000 nodes)\n"
    "  --ascent-candidates K  ascent: sparse graph of the K alpha-nearest neighbours\n"
    "                     (default 50; 15 above 5000 nodes)\n"
    "The op command solves an OPLib instance (TSPLIB metric, closed tour at the depot,\n"
    "COST_LIMIT) and prints {\"reward\" (OPLib's: the depot's score included), \"cost\",\n"
    "\"tour\" (1-based ids), ...}.\n"
    "--help anywhere on the command line prints this text.\n"
    "Exit codes: 0 ok, 1 internal error, 2 bad input or usage (one line naming it).\n";

void Emit(const nlohmann::json& j, const std::map<std::string, std::string>& options,
          std::ostream& out) {
  const std::string text = j.dump(2) + "\n";
  auto it = options.find("--out");
  if (it != options.end()) {
    WriteFileAtomic(it->second, text);
  } else {
    out << text;
  }
}

// Large instances report progress on stderr (one line each, prefixed with the command), so
// that a long solve is visibly alive; small ones stay quiet.
constexpr int kProgressTspNodes = 5000;
constexpr int kProgressSites = 10000;
constexpr int kMaxOpNodes = 10000;  // the op command builds an n x n matrix of doubles

std::function<void(const std::string&)> Reporter(std::ostream& err, const std::string& what,
                                                 std::chrono::steady_clock::time_point t0) {
  return [&err, what, t0](const std::string& line) {
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    char stamp[32];
    std::snprintf(stamp, sizeof(stamp), "[%.1f s] ", s);
    err << what << ": " << stamp << line << "\n" << std::flush;
  };
}

int RunTsp(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const Args a = ParseArgs(args, 1,
                           {"--seed", "--runs", "--trials", "--time-limit", "--out", "--optimum",
                            "--kick-segment", "--initial-period", "--ascent-candidates"});
  if (a.positional.size() != 1) throw InputError("tsp: expected exactly one FILE.tsp");
  const std::string& path = a.positional[0];
  tsp::SolverOptions opt;
  if (a.options.count("--seed"))
    opt.seed = ParseInt(a.options.at("--seed"), "--seed", 0, 1LL << 62);
  if (a.options.count("--runs")) opt.runs = ParseInt(a.options.at("--runs"), "--runs", 1, 1000000);
  if (a.options.count("--trials"))
    opt.max_trials = ParseInt(a.options.at("--trials"), "--trials", 1, 1LL << 30);
  if (a.options.count("--time-limit"))
    opt.time_limit_s = ParseNumber(a.options.at("--time-limit"), "--time-limit");
  if (a.options.count("--kick-segment"))
    opt.kick_segment = ParseInt(a.options.at("--kick-segment"), "--kick-segment", 1, 1 << 30);
  if (a.options.count("--initial-period"))
    opt.ascent.initial_period =
        ParseInt(a.options.at("--initial-period"), "--initial-period", 1, 1 << 30);
  if (a.options.count("--ascent-candidates"))
    opt.ascent.ascent_candidates =
        ParseInt(a.options.at("--ascent-candidates"), "--ascent-candidates", 5, 1000);
  if (a.options.count("--optimum"))
    opt.optimum = ParseInt(a.options.at("--optimum"), "--optimum", 0, 1LL << 62);
  const auto t0 = std::chrono::steady_clock::now();
  const tsp::TsplibInstance inst = tsp::ReadTsplib(path);
  if (inst.dimension < 1) throw InputError(path + ": DIMENSION must be >= 1");
  if (inst.dimension >= kProgressTspNodes) opt.progress = Reporter(err, "mound_plan tsp", t0);
  const tsp::TspResult r = tsp::SolveTsp(*inst.problem, opt);
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  nlohmann::json tour = nlohmann::json::array();
  for (int v : r.tour) tour.push_back(v + 1);
  nlohmann::json j = {{"schema", "mound.tsp_result"},
                      {"version", 1},
                      {"name", inst.name},
                      {"n", inst.dimension},
                      {"length", r.length},
                      {"tour", tour},
                      {"elapsed_s", elapsed},
                      {"lower_bound", r.stats.lower_bound},
                      {"seed", opt.seed},
                      {"stats",
                       {{"ascent_iterations", r.stats.ascent_iterations},
                        {"ascent_s", r.stats.ascent_s},
                        {"candidates_s", r.stats.candidates_s},
                        {"search_s", r.stats.search_s},
                        {"runs", r.stats.runs},
                        {"trials", r.stats.trials},
                        {"improving_trials", r.stats.improving_trials},
                        {"lk_moves", r.stats.lk_moves},
                        {"exact", r.stats.exact}}}};
  Emit(j, a.options, out);
  return kExitOk;
}

const std::vector<std::string> kAlgos = {"newalg", "newalg-ls",    "alns", "best",
                                         "greedy", "tsiligirides", "glv",  "exact"};

struct AlgoOptions {
  NewAlgOptions newalg;
  AlnsOptions alns;
  BaselineOptions baseline;
};

AlgoOptions ParseAlgoOptions(const Args& a) {
  AlgoOptions o;
  if (a.options.count("--seed"))
    o.newalg.seed = ParseInt(a.options.at("--seed"), "--seed", 0, 1LL << 62);
  if (a.options.count("--iterations"))
    o.newalg.ls_iterations = ParseInt(a.options.at("--iterations"), "--iterations", 0, 1 << 30);
  if (a.options.count("--time-limit")) {
    const double t = ParseNumber(a.options.at("--time-limit"), "--time-limit");
    if (!(t >= 0 && t <= 1e6)) {
      throw InputError("--time-limit: expected seconds in [0, 1e6] (0: no limit), got " +
                       a.options.at("--time-limit"));
    }
    o.newalg.ls_time_limit_s = o.alns.time_limit_s = t;
  }
  o.alns.seed = o.baseline.seed = o.newalg.seed;
  if (a.options.count("--iterations")) o.alns.max_iterations = o.newalg.ls_iterations;
  if (a.options.count("--routes"))
    o.baseline.tsiligirides_routes = ParseInt(a.options.at("--routes"), "--routes", 1, 1 << 30);
  return o;
}

// Without --algo: ALNS-OP up to this many sites (about 1 s), NewAlg above (ALNS-OP's
// neighbour lists and cost matrix are built for instances of this size).
constexpr int kDefaultAlnsMaxSites = 1000;
constexpr const char* kDefaultRule = "default: alns up to 1000 sites, newalg above";

std::string DefaultAlgo(int n_sites) { return n_sites <= kDefaultAlnsMaxSites ? "alns" : "newalg"; }

// The --algo given ("best" read as "alns"), or "" when none was given (see DefaultAlgo).
std::string ParseAlgo(const Args& a) {
  if (!a.options.count("--algo")) return "";
  const std::string algo = a.options.at("--algo");
  if (std::find(kAlgos.begin(), kAlgos.end(), algo) == kAlgos.end()) {
    throw InputError("--algo: unknown algorithm '" + algo +
                     "' (newalg, newalg-ls, alns, best, greedy, tsiligirides, glv, exact)");
  }
  return algo == "best" ? "alns" : algo;
}

PlanResult Solve(const std::string& algo, const OpInstance& inst, const AlgoOptions& o) {
  if (algo == "exact" && inst.Size() - inst.FirstSite() > kMaxExactSites) {
    throw InputError("--algo exact: at most " + std::to_string(kMaxExactSites) + " sites, got " +
                     std::to_string(inst.Size() - inst.FirstSite()));
  }
  PlanResult r = algo == "newalg"         ? SolveNewAlg(inst, o.newalg)
                 : algo == "newalg-ls"    ? SolveNewAlgLs(inst, o.newalg)
                 : algo == "alns"         ? SolveAlns(inst, o.alns)
                 : algo == "greedy"       ? SolveGreedy(inst)
                 : algo == "tsiligirides" ? SolveTsiligirides(inst, o.baseline)
                 : algo == "glv"          ? SolveGlv(inst, o.baseline)
                                          : SolveExactSmall(inst);
  const std::string defect = inst.CheckRoute(r.route);
  if (!defect.empty()) throw std::logic_error("planner produced an invalid route: " + defect);
  return r;
}

int RunOp(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const Args a =
      ParseArgs(args, 1, {"--algo", "--seed", "--out", "--iterations", "--time-limit", "--routes"});
  if (a.positional.size() != 1) throw InputError("op: expected exactly one FILE.oplib");
  const std::string& path = a.positional[0];
  std::string algo = ParseAlgo(a);
  AlgoOptions o = ParseAlgoOptions(a);
  const auto t_read = std::chrono::steady_clock::now();
  const tsp::TsplibInstance t = tsp::ReadTsplib(path);
  if (t.type != "OP" || t.scores.empty() || t.cost_limit < 0) {
    throw InputError(path + ": not an OP instance (TYPE: OP, COST_LIMIT, NODE_SCORE_SECTION)");
  }
  if (t.dimension > kMaxOpNodes) {
    throw InputError(path + ": DIMENSION " + std::to_string(t.dimension) +
                     ": the op command takes at most " + std::to_string(kMaxOpNodes) + " nodes");
  }
  if (t.dimension >= kProgressSites) o.newalg.progress = Reporter(err, "mound_plan op", t_read);
  if (algo == "glv") throw InputError("--algo glv: needs planar coordinates, not " + path);
  const bool by_default = algo.empty();
  if (by_default) algo = DefaultAlgo(t.dimension - 1);
  // Node order: the depot (home) first, then the others in file order.
  std::vector<int> order{t.depot};
  for (int v = 0; v < t.dimension; ++v)
    if (v != t.depot) order.push_back(v);
  OpInstance inst;
  for (int v : order)
    inst.nodes.push_back({std::to_string(v + 1), 0, 0, v == t.depot ? 0 : t.scores[v], 0});
  inst.budget_m = t.cost_limit;
  const size_t n = order.size();
  inst.dist_matrix.resize(n * n);
  for (size_t i = 0; i < n; ++i)
    for (size_t j = 0; j < n; ++j)
      inst.dist_matrix[i * n + j] = static_cast<double>(t.problem->Dist(order[i], order[j]));
  const auto t0 = std::chrono::steady_clock::now();
  PlanResult r = Solve(algo, inst, o);
  if (by_default) r.stats["algo_chosen"] = kDefaultRule;
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  nlohmann::json tour = nlohmann::json::array();
  for (int v : r.route) tour.push_back(order[v] + 1);
  Emit({{"schema", "mound.op_result"},
        {"version", 1},
        {"name", t.name},
        {"n", t.dimension},
        {"algo", algo},
        {"cost_limit", t.cost_limit},
        // OPLib's objective: the scores of the nodes on the tour, the depot's included
        // (a constant the planners leave out).
        {"reward", r.reward + t.scores[t.depot]},
        {"depot_score", t.scores[t.depot]},
        {"cost", r.cost},
        {"tour", tour},
        {"elapsed_s", elapsed},
        {"solver", r.stats}},
       a.options, out);
  return kExitOk;
}

// Several flights: ALNS-OP on K routes, the exact DP on small instances, and any other
// algorithm flight by flight on the sites the earlier flights left (the paper's baseline).
FlightsResult SolveFlights(const std::string& algo, const OpInstance& inst, int flights,
                           const AlgoOptions& o) {
  const int n_sites = inst.Size() - inst.FirstSite();
  if (algo == "exact" && n_sites > kMaxExactFlightSites) {
    throw InputError("--algo exact --flights: at most " + std::to_string(kMaxExactFlightSites) +
                     " sites, got " + std::to_string(n_sites));
  }
  FlightsResult r = algo == "alns" ? SolveAlnsFlights(inst, flights, o.alns)
                    : algo == "exact"
                        ? SolveExactFlights(inst, flights)
                        : SequentialFlights(inst, flights, [&](const OpInstance& sub, int k) {
                            AlgoOptions ok = o;
                            ok.newalg.seed += k;
                            ok.alns.seed += k;
                            ok.baseline.seed += k;
                            return Solve(algo, sub, ok);
                          });
  if (algo != "alns" && algo != "exact") r.stats["name"] = algo + " flight by flight";
  const std::string defect = CheckFlights(inst, r.routes);
  if (!defect.empty()) throw std::logic_error("planner produced invalid flights: " + defect);
  return r;
}

int RunPlan(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const Args a = ParseArgs(
      args, 0,
      {"--algo", "--seed", "--out", "--iterations", "--time-limit", "--routes", "--flights"});
  if (a.positional.empty() || a.positional.size() > 2) {
    throw InputError("usage: mound_plan SITES.json [BUDGET] [options] (see --help)");
  }
  std::optional<double> budget;
  if (a.positional.size() == 2) budget = ParseNumber(a.positional[1], "BUDGET");
  std::string algo = ParseAlgo(a);
  AlgoOptions o = ParseAlgoOptions(a);
  const auto t_read = std::chrono::steady_clock::now();
  const SitesFile sites = ReadSites(a.positional[0], budget);
  const int n_sites = sites.instance.Size() - sites.instance.FirstSite();
  const bool by_default = algo.empty();
  if (by_default) algo = DefaultAlgo(n_sites);
  if (n_sites >= kProgressSites) {
    o.newalg.progress = Reporter(err, "mound_plan", t_read);
    o.newalg.progress("read " + std::to_string(n_sites) + " sites; planning with " + algo);
  }
  const int flights =
      a.options.count("--flights")
          ? static_cast<int>(ParseInt(a.options.at("--flights"), "--flights", 1, kMaxFlights))
          : 1;
  const auto t0 = std::chrono::steady_clock::now();
  PlanSummary summary;
  if (flights == 1) {
    PlanResult r = Solve(algo, sites.instance, o);
    if (by_default) r.stats["algo_chosen"] = kDefaultRule;
    summary = {algo, r.route, 0, o.newalg.seed, r.stats, {}};
  } else {
    FlightsResult r = SolveFlights(algo, sites.instance, flights, o);
    if (by_default) r.stats["algo_chosen"] = kDefaultRule;
    summary = {algo, r.routes[0], 0, o.newalg.seed, r.stats, r.routes};
  }
  summary.elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  Emit(PlanToJson(sites, summary), a.options, out);
  return kExitOk;
}

}  // namespace

int RunMoundPlan(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  return RunTool("mound_plan", kUsage, kVersion, args, out, err, [&]() {
    if (args.empty()) throw InputError("missing SITES.json (see --help)");
    if (args[0] == "tsp") return RunTsp(args, out, err);
    if (args[0] == "op") return RunOp(args, out, err);
    return RunPlan(args, out, err);
  });
}

}  // namespace mound::plan
