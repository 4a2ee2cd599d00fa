#include "plan/alns.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <random>
#include <utility>
#include <vector>

#include "plan/alns_operators.h"
#include "plan/route_ops.h"

namespace mound::plan {
namespace {

using alns::kNumRuins;
using alns::kRuinNames;
using alns::Solution;

constexpr int kSpreadStarts = 8;  // multi-start constructions through sites spread out

// One search's state: the shared neighbourhood, the route state and the operators (each
// with its own scratch), the random stream, and the sites other flights hold.
class Search {
 public:
  Search(const OpInstance& inst, uint64_t seed)
      : N_(inst), rng_(seed), state_(inst.Size()), taken_(inst.Size(), 0) {}

  Solution Make(std::vector<int> route) const { return N_.Make(std::move(route)); }
  void Evaluate(Solution* s) const { N_.Evaluate(s); }
  bool Better(const Solution& a, const Solution& b) const {
    return N_.inst.Better(a.route, a.cost, b.route, b.cost);
  }
  bool AllRewardedVisited(const Solution& s) const {
    int on = 0;
    for (int v : s.route) on += N_.inst.IsSite(v) && N_.inst.nodes[v].reward > 0;
    return on == static_cast<int>(N_.rewarded.size());
  }

  // The local search: shorten, fill, replace, until none applies.
  void LocalSearch(Solution* s) {
    state_.Mark(s->route);
    for (int guard = 0; guard < 1000; ++guard) {
      Shorten(s);
      insert_.Apply(N_, state_, s, taken_, nullptr, 0.0, rng_);
      if (!replace_.Apply(N_, state_, s, taken_)) break;
    }
    Evaluate(s);  // drop accumulated rounding
  }

  // Re-orders the route with the LKH engine, then refills it.
  void Polish(Solution* s, uint64_t seed) {
    // LKH's work, charged as its pairwise cost matrix times a few trials' worth.
    const uint64_t m = s->route.size();
    N_.costs.Charge(20 * m * m);
    if (s->route.size() >= 6 && ReorderWithLkh(N_.inst, &s->route, seed, &ops_)) {
      Evaluate(s);
      LocalSearch(s);
    }
  }

  // Removes k sites by ruin `op`; the removed sites are marked in blocked_.
  void Ruin(Solution* s, int op, int k) { alns::Ruin(N_, op, k, rng_, s, &blocked_); }

  // A route from scratch: noisy ratio insertion into home -> (a random site) -> end, then
  // the local search.
  Solution Construct(double noise) {
    // Seeded by a random site that fits, so that restarts reach other parts of the field.
    for (int tries = 0; tries < 20 && !N_.rewarded.empty(); ++tries) {
      const int v = N_.rewarded[rng_() % N_.rewarded.size()];
      if (Fits(v) && !taken_[v]) return ConstructFrom(v, noise);
    }
    return ConstructFrom(-1, noise);
  }

  // The same through a given site (-1: none).
  Solution ConstructFrom(int seed_site, double noise) {
    Solution s = seed_site < 0 ? Make({OpInstance::kHome, N_.inst.end})
                               : Make({OpInstance::kHome, seed_site, N_.inst.end});
    blocked_.assign(N_.inst.Size(), 0);
    Recreate(&s, noise);
    LocalSearch(&s);
    return s;
  }

  // Up to k rewarded sites that fit, spread over the instance: farthest-point order from
  // home in the expanded costs. Multi-start seeds, for fields whose reward lies in
  // clusters away from where NewAlg's route went.
  std::vector<int> SpreadSites(int k) const {
    const alns::Costs& C = N_.costs;
    std::vector<int> out;
    std::vector<double> gap;
    std::vector<int> cand;
    for (int v : N_.rewarded)
      if (Fits(v) && !taken_[v]) {
        cand.push_back(v);
        gap.push_back(C(OpInstance::kHome, v));
      }
    while (static_cast<int>(out.size()) < k && !cand.empty()) {
      const size_t j = std::max_element(gap.begin(), gap.end()) - gap.begin();
      if (gap[j] <= 0) break;
      const int v = cand[j];
      out.push_back(v);
      for (size_t i = 0; i < cand.size(); ++i) gap[i] = std::min(gap[i], C(v, cand[i]));
    }
    return out;
  }

  bool Fits(int v) const {
    return N_.costs(OpInstance::kHome, v) + N_.costs(v, N_.inst.end) <= N_.limit;
  }

  // Recreate: noisy ratio insertion without the removed sites, then with all of them.
  void Recreate(Solution* s, double noise) {
    state_.Mark(s->route);
    insert_.Apply(N_, state_, s, taken_, &blocked_, noise, rng_);
    insert_.Apply(N_, state_, s, taken_, nullptr, noise, rng_);
  }

  std::mt19937_64& Rng() { return rng_; }
  uint64_t Ticks() const { return N_.costs.Ticks(); }
  // Sites flown by the other flights of a multi-flight plan: never inserted into this one.
  void SetTaken(const std::vector<char>& taken) { taken_ = taken; }
  std::vector<char>& Blocked() { return blocked_; }

  // Moves between two flights that keep both within the budget and shorten them together
  // (rewards unchanged; the freed budget is refilled afterwards): relocate a site of a
  // into b, exchange a site of a with one of b, and cross (a's head with b's tail and b's
  // head with a's tail; both end at the same node). Returns true if any was made.
  bool BetweenRoutes(Solution* a, Solution* b) {
    bool any = false;
    for (int round = 0; round < 50; ++round) {
      if (!(alns::Relocate(N_, a, b) || alns::Relocate(N_, b, a) || alns::Exchange(N_, a, b) ||
            alns::Cross(N_, a, b))) {
        break;
      }
      any = true;
    }
    if (any) {
      Evaluate(a);
      Evaluate(b);
    }
    return any;
  }

 private:
  void Shorten(Solution* s) {
    if (s->route.size() > alns::kMaxLocalSearchRoute + 2) return;
    for (int pass = 0; pass < 100; ++pass) {
      const bool a = two_opt_.Apply(N_, state_, s);
      const bool b = or_opt_.Apply(N_, state_, s);
      if (!a && !b) break;
    }
  }

  alns::Neighbourhood N_;
  std::mt19937_64 rng_;
  alns::RouteState state_;
  std::vector<char> blocked_, taken_;
  alns::TwoOpt two_opt_;
  alns::OrOpt or_opt_;
  alns::RatioInsert insert_;
  alns::Replace replace_;
  RouteOpsStats ops_;
};

// Adaptive choice of the ruin operator: roulette on weights that follow each operator's
// success (new best 33, better than current 9, accepted 13), updated every 100 uses.
class Roulette {
 public:
  int Pick(std::mt19937_64& rng) {
    double total = 0;
    for (double w : weight_) total += w;
    double pick = std::uniform_real_distribution<double>(0, total)(rng);
    int op = 0;
    while (op + 1 < kNumRuins && pick >= weight_[op]) pick -= weight_[op++];
    used_[op] += 1;
    return op;
  }
  void Score(int op, double points) { score_[op] += points; }
  // At the end of every iteration.
  void Next() {
    if (++iterations_ % kSegment != 0) return;
    for (int o = 0; o < kNumRuins; ++o) {
      if (used_[o] > 0) weight_[o] = 0.8 * weight_[o] + 0.2 * std::max(0.05, score_[o] / used_[o]);
      score_[o] = used_[o] = 0;
    }
  }
  double Weight(int op) const { return weight_[op]; }

 private:
  static constexpr int kSegment = 100;
  std::array<double, kNumRuins> weight_{1, 1, 1, 1}, score_{}, used_{};
  int iterations_ = 0;
};

// The schedule of a search, one flight or K: its own clock of work ticks (cost lookups,
// LKH charged by its size), so that a time limit gives the same plan on any machine load;
// the wall clock only guards against a machine far slower than the reference one. It
// also says when the search stagnates, when it restarts, and how far the acceptance
// threshold has shrunk.
class Schedule {
 public:
  Schedule(const AlnsOptions& opt, int sites)
      : start_(std::chrono::steady_clock::now()),
        work_(opt.time_limit_s > 0 ? opt.time_limit_s * kAlnsTicksPerSecond : 0),
        wall_(opt.time_limit_s > 0 ? opt.time_limit_s * opt.wall_factor : 0),
        max_iterations_(opt.max_iterations),
        stagnation_(opt.stagnation > 0 ? opt.stagnation : std::max(5000, 50 * sites)),
        restart_(std::clamp(stagnation_ / 10, 100, 400)) {}

  double Elapsed() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
  double WorkLimit() const { return work_; }  // 0: none
  int Restart() const { return restart_; }
  // Neither the iterations nor the patience without a new best are spent.
  bool Going(int it, int since_best) const {
    return it < max_iterations_ && since_best < stagnation_;
  }
  // True (and remembered for Why) once the work or the wall clock is spent.
  bool OutOfTime(double ticks) {
    out_of_work_ = work_ > 0 && ticks >= work_;
    out_of_wall_ = !out_of_work_ && wall_ > 0 && Elapsed() >= wall_;
    return out_of_work_ || out_of_wall_;
  }
  // Record-to-record travel: the threshold shrinks from 5 % to 0 over the run (the work
  // limit's ticks), or over a stretch without a new best when there is no limit.
  double Threshold(double ticks, int since_best) const {
    const double progress =
        work_ > 0 ? ticks / work_ : static_cast<double>(since_best) / stagnation_;
    return 0.05 * std::max(0.0, 1.0 - progress);
  }
  // Why the search ended, in the order the checks are made.
  const char* Why(int it, int since_best) const {
    return out_of_work_                ? "time limit (work ticks)"
           : out_of_wall_              ? "wall clock (not repeatable)"
           : it >= max_iterations_     ? "iterations"
           : since_best >= stagnation_ ? "stagnation"
                                       : "all sites visited";
  }

 private:
  std::chrono::steady_clock::time_point start_;
  double work_, wall_;
  int max_iterations_, stagnation_, restart_;
  bool out_of_work_ = false, out_of_wall_ = false;
};

// How many sites a ruin removes from a route of m sites: 1 to max(4, 2m/5), at most 40.
int RuinSize(int m, std::mt19937_64& rng) {
  const int k_max = std::max(1, std::min(40, std::max(4, (2 * m) / 5)));
  return 1 + static_cast<int>(rng() % k_max);
}

}  // namespace

nlohmann::json AlnsStats::ToJson() const {
  nlohmann::json j = {{"name", "alns"},           {"iterations", iterations},
                      {"new_bests", new_bests},   {"stopped_by", stopped_by},
                      {"work_ticks", work_ticks}, {"elapsed_s", elapsed_s}};
  if (flights > 1) {
    j["flights"] = flights;
    j["sequential_start_reward"] = start_reward;
    return j;
  }
  j["newalg_reward"] = start_reward;
  j["lkh_polishes"] = lkh_polishes;
  j["restarts"] = restarts;
  j["spread_starts_won"] = spread_starts_won;
  nlohmann::json w = nlohmann::json::object();
  for (const Ruin& r : ruins) w[r.name] = {{"weight", r.weight}, {"new_bests", r.new_bests}};
  j["ruins"] = w;
  return j;
}

PlanResult SolveAlns(const OpInstance& inst, const AlnsOptions& opt, AlnsStats* out_stats) {
  Schedule schedule(opt, inst.Size() - inst.FirstSite());
  NewAlgOptions nopt;
  nopt.seed = opt.seed;
  const PlanResult init = SolveNewAlg(inst, nopt);

  Search search(inst, opt.seed ^ 0x5DEECE66DULL);
  std::mt19937_64& rng = search.Rng();
  Solution best = search.Make(init.route);
  search.LocalSearch(&best);
  // Multi-start: constructions through sites spread over the field, the best one kept.
  int starts_won = 0;
  for (int v : search.SpreadSites(kSpreadStarts)) {
    if (schedule.WorkLimit() > 0 && search.Ticks() >= 0.25 * schedule.WorkLimit()) break;
    Solution s = search.ConstructFrom(v, 0.0);
    if (search.Better(s, best)) {
      best = std::move(s);
      ++starts_won;
    }
  }
  search.Polish(&best, opt.seed);
  Solution cur = best;

  const int restart = schedule.Restart();
  Roulette roulette;
  std::array<int, kNumRuins> bests{};
  int it = 0, since_best = 0, new_bests = 0, last_polish = 0, polishes = 1, restarts = 0;
  for (; schedule.Going(it, since_best); ++it) {
    if (schedule.OutOfTime(search.Ticks())) break;
    if (search.AllRewardedVisited(best)) break;
    const int op = roulette.Pick(rng);
    const int k = RuinSize(static_cast<int>(cur.route.size()) - 2, rng);

    Solution cand = cur;
    search.Ruin(&cand, op, k);
    static constexpr double kNoise[] = {0.1, 0.3, 0.6};
    search.Recreate(&cand, kNoise[rng() % 3]);
    search.LocalSearch(&cand);

    const double threshold = schedule.Threshold(search.Ticks(), since_best);
    ++since_best;
    if (search.Better(cand, best)) {
      best = cand;
      ++new_bests;
      ++bests[op];
      since_best = 0;
      roulette.Score(op, 33);
      if (it - last_polish >= 50) {
        search.Polish(&best, opt.seed + static_cast<uint64_t>(it));
        last_polish = it;
        ++polishes;
      }
      cur = best;
    } else if (search.Better(cand, cur)) {
      roulette.Score(op, 9);
      cur = std::move(cand);
    } else if (cand.reward >= best.reward * (1.0 - threshold)) {
      roulette.Score(op, 13);
      cur = std::move(cand);
    }
    if (since_best > 0 && since_best % restart == 0) {
      // Alternately back to the best route and to a new noisy construction from scratch.
      if ((since_best / restart) % 2 == 1) {
        cur = best;
      } else {
        cur = search.Construct(0.6);
        ++restarts;
      }
    }
    roulette.Next();
  }
  search.Polish(&best, opt.seed + 0x9E3779B9ULL);
  ++polishes;

  PlanResult res;
  res.route = best.route;
  res.reward = inst.RouteReward(res.route);
  res.cost = inst.RouteCost(res.route);
  AlnsStats st;
  st.start_reward = init.reward;
  st.iterations = it;
  st.new_bests = new_bests;
  st.lkh_polishes = polishes;
  st.restarts = restarts;
  st.spread_starts_won = starts_won;
  st.stopped_by = schedule.Why(it, since_best);
  st.work_ticks = search.Ticks();
  for (int o = 0; o < kNumRuins; ++o)
    st.ruins.push_back({kRuinNames[o], roulette.Weight(o), bests[o]});
  st.elapsed_s = schedule.Elapsed();
  res.stats = st.ToJson();
  if (out_stats) *out_stats = std::move(st);
  return res;
}

}  // namespace mound::plan

namespace mound::plan {

namespace {

// K flights and their totals.
struct Multi {
  std::vector<Solution> fl;
  double reward = 0, cost = 0;
};

// More reward, or as much for less cost.
bool Better(const Multi& a, const Multi& b) {
  const double eps = 1e-12 * (1.0 + std::abs(b.reward));
  if (a.reward > b.reward + eps) return true;
  return a.reward >= b.reward - eps && a.cost < b.cost - 1e-9;
}

// K flights searched together over one Search, whose `taken` marks the sites the other
// flights visit while one flight is searched.
class FlightsSearch {
 public:
  FlightsSearch(const OpInstance& inst, int flights, uint64_t seed)
      : inst_(inst),
        flights_(flights),
        search_(inst, seed),
        taken_(inst.Size(), 0),
        blocked_(inst.Size(), 0) {}

  Search& search() { return search_; }

  void MarkOthers(const std::vector<Solution>& fl, int k) {
    std::fill(taken_.begin(), taken_.end(), 0);
    for (int j = 0; j < static_cast<int>(fl.size()); ++j) {
      if (j == k) continue;
      for (int v : fl[j].route)
        if (inst_.IsSite(v)) taken_[v] = 1;
    }
    search_.SetTaken(taken_);
  }

  void Total(Multi* m) {
    m->reward = m->cost = 0;
    for (auto& s : m->fl) {
      search_.Evaluate(&s);
      m->reward += s.reward;
      m->cost += s.cost;
    }
  }

  // Moves between every pair of flights, then each flight refilled and searched again.
  void Improve(Multi* m) {
    for (int round = 0; round < 10; ++round) {
      bool moved = false;
      for (int a = 0; a < flights_; ++a)
        for (int b = a + 1; b < flights_; ++b) moved |= search_.BetweenRoutes(&m->fl[a], &m->fl[b]);
      bool grew = false;
      for (int k = 0; k < flights_; ++k) {
        const double before = m->fl[k].reward;
        MarkOthers(m->fl, k);
        search_.LocalSearch(&m->fl[k]);
        grew |= m->fl[k].reward > before + 1e-12;
      }
      if (!moved && !grew) break;
    }
    Total(m);
  }

  // Each flight polished (seed + k), then improved together.
  void Polish(Multi* m, uint64_t seed) {
    for (int k = 0; k < flights_; ++k) {
      MarkOthers(m->fl, k);
      search_.Polish(&m->fl[k], seed + k);
    }
    Improve(m);
  }

  // Every site with a reward is on a flight.
  bool AllVisited(const Multi& m) const {
    int rewarded = 0, on = 0;
    for (int v = inst_.FirstSite(); v < inst_.Size(); ++v) rewarded += inst_.nodes[v].reward > 0;
    for (const auto& s : m.fl)
      for (int v : s.route) on += inst_.IsSite(v) && inst_.nodes[v].reward > 0;
    return on == rewarded;
  }

  // One iteration's candidate: one flight (half of the time) or all of them ruined by
  // operator `op`, each refilled in a random order with noise, and improved together.
  void RuinAndRecreate(Multi* cand, int op) {
    std::mt19937_64& rng = search_.Rng();
    const int n = inst_.Size();
    const bool all = rng() % 2 == 0;
    const int one = static_cast<int>(rng() % flights_);
    std::fill(blocked_.begin(), blocked_.end(), 0);
    for (int k = 0; k < flights_; ++k) {
      if (!all && k != one) continue;
      const int m = static_cast<int>(cand->fl[k].route.size()) - 2;
      if (m <= 0) continue;
      search_.Ruin(&cand->fl[k], op, RuinSize(m, rng));
      for (int v = 0; v < n; ++v) blocked_[v] |= search_.Blocked()[v];
    }
    static constexpr double kNoise[] = {0.1, 0.3, 0.6};
    const double noise = kNoise[rng() % 3];
    std::vector<int> order(flights_);
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), rng);
    for (int k : order) {
      MarkOthers(cand->fl, k);
      search_.Blocked() = blocked_;
      search_.Recreate(&cand->fl[k], noise);
      search_.LocalSearch(&cand->fl[k]);
    }
    Improve(cand);
  }

 private:
  const OpInstance& inst_;
  const int flights_;
  Search search_;
  std::vector<char> taken_, blocked_;
};

}  // namespace

FlightsResult SolveAlnsFlights(const OpInstance& inst, int flights, const AlnsOptions& opt,
                               AlnsStats* out_stats) {
  if (flights == 1) {
    FlightsResult one;
    const PlanResult r = SolveAlns(inst, opt, out_stats);
    one.routes = {r.route};
    one.stats = r.stats;
    OrderFlights(inst, &one);
    return one;
  }
  Schedule schedule(opt, inst.Size() - inst.FirstSite());

  // The start: ALNS-OP flight by flight on the sites the earlier flights left, a quarter of
  // the work shared among them.
  uint64_t start_ticks = 0;
  FlightsResult seq = SequentialFlights(inst, flights, [&](const OpInstance& sub, int k) {
    AlnsOptions o = opt;
    o.seed = opt.seed + 7919 * static_cast<uint64_t>(k);
    o.time_limit_s = opt.time_limit_s > 0 ? 0.25 * opt.time_limit_s / flights : 0;
    if (opt.time_limit_s <= 0) o.max_iterations = std::min(opt.max_iterations, 2000);
    AlnsStats sub_stats;
    PlanResult r = SolveAlns(sub, o, &sub_stats);
    start_ticks += sub_stats.work_ticks;
    return r;
  });

  FlightsSearch fs(inst, flights, opt.seed ^ 0xA5A5A5A5ULL);
  Search& search = fs.search();
  std::mt19937_64& rng = search.Rng();
  Multi best;
  for (auto& r : seq.routes) best.fl.push_back(search.Make(r));
  fs.Improve(&best);
  const double seq_reward = seq.reward;
  Multi cur = best;

  const int restart = schedule.Restart();
  Roulette roulette;
  int it = 0, since_best = 0, new_bests = 0, last_polish = 0;
  auto ticks = [&] { return static_cast<double>(search.Ticks() + start_ticks); };
  for (; schedule.Going(it, since_best); ++it) {
    if (fs.AllVisited(best)) break;
    if (schedule.OutOfTime(ticks())) break;
    const int op = roulette.Pick(rng);
    Multi cand = cur;
    fs.RuinAndRecreate(&cand, op);
    const double threshold = schedule.Threshold(ticks(), since_best);
    ++since_best;
    if (Better(cand, best)) {
      best = cand;
      ++new_bests;
      since_best = 0;
      roulette.Score(op, 33);
      if (it - last_polish >= 50) {
        fs.Polish(&best, opt.seed + static_cast<uint64_t>(it));
        last_polish = it;
      }
      cur = best;
    } else if (Better(cand, cur)) {
      roulette.Score(op, 9);
      cur = std::move(cand);
    } else if (cand.reward >= best.reward * (1.0 - threshold)) {
      roulette.Score(op, 13);
      cur = std::move(cand);
    }
    if (since_best > 0 && since_best % restart == 0) cur = best;
    roulette.Next();
  }
  fs.Polish(&best, opt.seed + 0x9E3779B9ULL);

  FlightsResult res;
  for (auto& s : best.fl) res.routes.push_back(s.route);
  OrderFlights(inst, &res);
  AlnsStats st;
  st.flights = flights;
  st.start_reward = seq_reward;
  st.iterations = it;
  st.new_bests = new_bests;
  st.stopped_by = schedule.Why(it, since_best);
  st.work_ticks = static_cast<uint64_t>(ticks());
  st.elapsed_s = schedule.Elapsed();
  res.stats = st.ToJson();
  if (out_stats) *out_stats = std::move(st);
  return res;
}

}  // namespace mound::plan
