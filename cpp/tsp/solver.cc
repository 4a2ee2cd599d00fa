#include "tsp/solver.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <random>

#include "tsp/lin_kernighan.h"
#include "tsp/tour.h"

namespace mound::tsp {
namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}

bool RespectsFixed(const std::vector<int>& order, const std::vector<int>& fixed_partner) {
  const size_t n = order.size();
  for (size_t i = 0; i < n; ++i) {
    const int v = order[i];
    const int f = fixed_partner[v];
    if (f >= 0 && order[(i + 1) % n] != f && order[(i + n - 1) % n] != f) return false;
  }
  return true;
}

// Exhaustive search for n <= 8 (node 0 first, one direction per cycle).
TspResult SolveExact(const Problem& p, const std::vector<int>& fixed_partner) {
  const int n = p.Size();
  TspResult res;
  res.stats.exact = true;
  std::vector<int> perm(n);
  std::iota(perm.begin(), perm.end(), 0);
  if (n <= 3) {
    res.tour = perm;
    res.length = TourLength(p, perm);
    return res;
  }
  Cost best = -1;
  do {
    if (perm[1] > perm[n - 1]) continue;  // skip mirror images
    if (!RespectsFixed(perm, fixed_partner)) continue;
    const Cost len = TourLength(p, perm);
    if (best < 0 || len < best) {
      best = len;
      res.tour = perm;
    }
  } while (std::next_permutation(perm.begin() + 1, perm.end()));
  res.length = best;
  return res;
}

// LKH's default initial tour (a walk): from a random node go to the first unvisited
// candidate (alpha order), else to a random unvisited node; fixed edges are followed.
std::vector<int> InitialTour(const CandidateSet& cands, const std::vector<int>& fixed_partner,
                             std::mt19937_64& rng) {
  const int n = static_cast<int>(cands.size());
  std::vector<int> pool(n), where(n);
  std::iota(pool.begin(), pool.end(), 0);
  std::iota(where.begin(), where.end(), 0);
  std::vector<char> visited(n, 0);
  auto take = [&](int v) {
    visited[v] = 1;
    const int w = pool.back();
    pool[where[v]] = w;
    where[w] = where[v];
    pool.pop_back();
  };
  std::vector<int> order;
  order.reserve(n);
  int cur = static_cast<int>(rng() % n);
  take(cur);
  order.push_back(cur);
  while (!pool.empty()) {
    int next = -1;
    const int f = fixed_partner[cur];
    if (f >= 0 && !visited[f]) next = f;
    if (next < 0) {
      for (const Candidate& c : cands[cur]) {
        if (!visited[c.node]) {
          next = c.node;
          break;
        }
      }
    }
    if (next < 0) next = pool[rng() % pool.size()];
    take(next);
    order.push_back(next);
    cur = next;
  }
  return order;
}

}  // namespace

TspResult SolveTsp(const Problem& problem, const SolverOptions& opt) {
  const int n = problem.Size();
  std::vector<int> fixed_partner(n, -1);
  for (const auto& [a, b] : problem.FixedEdges()) {
    fixed_partner[a] = b;
    fixed_partner[b] = a;
  }
  if (n <= 8) return SolveExact(problem, fixed_partner);

  const auto t_start = Clock::now();
  auto out_of_time = [&]() { return opt.time_limit_s > 0 && Seconds(t_start) > opt.time_limit_s; };
  auto say = [&](const std::string& what) {
    if (opt.progress) opt.progress(what);
  };
  TspResult res;
  CostCache d(problem);
  AscentOptions ascent_opt = opt.ascent;
  // The ascent gets at most half of a time limit, so that the search has the other half.
  if (opt.time_limit_s > 0) {
    ascent_opt.should_stop = [&]() { return Seconds(t_start) > 0.5 * opt.time_limit_s; };
  }
  if (opt.progress && !ascent_opt.progress) ascent_opt.progress = opt.progress;
  say("ascent: " + std::to_string(n) + " nodes");
  const AscentResult ascent = Ascent(d, ascent_opt);
  res.stats.ascent_s = Seconds(t_start);
  {
    char line[160];
    std::snprintf(line, sizeof(line), "ascent done: %d iterations, bound %.6g, %.1f s%s",
                  ascent.iterations, ascent.lower_bound, res.stats.ascent_s,
                  opt.time_limit_s > 0 && res.stats.ascent_s > 0.5 * opt.time_limit_s
                      ? " (stopped at half the time limit)"
                      : "");
    say(line);
  }
  res.pi = ascent.pi;
  res.stats.lower_bound = ascent.lower_bound;
  res.stats.ascent_iterations = ascent.iterations;
  const auto t_cand = Clock::now();
  const CandidateSet cands =
      AlphaCandidates(d, ascent.pi, opt.ascent.precision, opt.max_candidates, problem.FixedEdges());
  res.stats.candidates_s = Seconds(t_cand);
  say("candidates: " + std::to_string(opt.max_candidates) + " per node");

  const auto t_search = Clock::now();
  const Cost sum_pi = std::accumulate(ascent.pi.begin(), ascent.pi.end(), Cost{0});
  const Cost precision = opt.ascent.precision;
  const Cost bound = static_cast<Cost>(std::ceil(ascent.lower_bound - 1e-9));
  const Cost target = std::max(opt.optimum, bound);
  const int max_trials = opt.max_trials > 0 ? opt.max_trials : n;
  const int runs = std::max(1, opt.runs);
  LinKernighan lk(d, ascent.pi, opt.ascent.precision, cands, problem.FixedEdges(), opt.move_k);
  auto last_report = Clock::now();
  auto length_of = [&](Cost transformed) { return (transformed - 2 * sum_pi) / precision; };

  Cost best_len = -1;
  for (int run = 0; run < runs; ++run) {
    std::mt19937_64 rng(opt.seed * 0x9E3779B97F4A7C15ULL + static_cast<uint64_t>(run));
    std::vector<int> order = InitialTour(cands, fixed_partner, rng);
    Tour tour(order);
    tour.SetJournaling(true);
    Cost cur = 0;
    for (int i = 0; i < n; ++i) cur += lk.C(order[i], order[(i + 1) % n]);
    std::shuffle(order.begin(), order.end(), rng);
    cur -= lk.Optimize(tour, order);
    tour.ClearJournal();
    ++res.stats.trials;
    // Long kicks matter on clustered instances (fl1577: 6% gap with 50, 0.1% with n/4).
    const int kick_max = opt.kick_segment > 0 ? opt.kick_segment : std::max(50, n / 4);
    const int kick_len = std::max(1, std::min(kick_max, (n - 2) / 3));
    for (int trial = 1; trial < max_trials; ++trial) {
      if (length_of(cur) <= target || out_of_time()) break;
      if (opt.progress && Clock::now() - last_report > std::chrono::seconds(2)) {
        last_report = Clock::now();
        say("run " + std::to_string(run + 1) + ", trial " + std::to_string(trial) + " of " +
            std::to_string(max_trials) + ": length " + std::to_string(length_of(cur)) + " (bound " +
            std::to_string(bound) + ")");
      }
      // Segment double bridge: a1 | B | C | D | e1  ->  a1 D C B e1.
      int a1 = -1, b1 = -1, b2 = -1, c1 = -1, c2 = -1, d1 = -1, d2 = -1, e1 = -1;
      bool ok = false;
      for (int attempt = 0; attempt < 20 && !ok; ++attempt) {
        a1 = static_cast<int>(rng() % n);
        auto walk = [&](int from) {
          int v = from;
          for (int s = static_cast<int>(rng() % kick_len); s > 0; --s) v = tour.Next(v);
          return v;
        };
        b1 = tour.Next(a1);
        b2 = walk(b1);
        c1 = tour.Next(b2);
        c2 = walk(c1);
        d1 = tour.Next(c2);
        d2 = walk(d1);
        e1 = tour.Next(d2);
        ok = !lk.IsFixed(a1, b1) && !lk.IsFixed(b2, c1) && !lk.IsFixed(c2, d1) &&
             !lk.IsFixed(d2, e1);
      }
      if (!ok) break;
      const size_t mark = tour.Mark();
      const Cost delta = lk.C(a1, d1) + lk.C(d2, c1) + lk.C(c2, b1) + lk.C(b2, e1) - lk.C(a1, b1) -
                         lk.C(b2, c1) - lk.C(c2, d1) - lk.C(d2, e1);
      tour.Reverse(b1, d2);
      tour.Reverse(d2, d1);
      tour.Reverse(c2, c1);
      tour.Reverse(b2, b1);
      const Cost after = cur + delta - lk.Optimize(tour, {a1, b1, b2, c1, c2, d1, d2, e1});
      ++res.stats.trials;
      if (after <= cur) {
        if (after < cur) ++res.stats.improving_trials;
        cur = after;
        tour.ClearJournal();
      } else {
        tour.UndoTo(mark);
      }
    }
    ++res.stats.runs;
    const Cost len = length_of(cur);
    if (best_len < 0 || len < best_len) {
      best_len = len;
      res.tour = tour.Order(0);
    }
    if (best_len <= target || out_of_time()) break;
  }
  res.length = TourLength(problem, res.tour);
  res.stats.lk_moves = lk.Stats().moves;
  res.stats.search_s = Seconds(t_search);
  return res;
}

}  // namespace mound::tsp
