#include "plan/alns.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <random>
#include <utility>
#include <vector>

#include "plan/route_ops.h"

namespace mound::plan {
namespace {

// Expanded edge costs; a matrix up to this many nodes (32 MiB), computed on the fly above.
constexpr int kMaxMatrixNodes = 2048;
// 2-opt, Or-opt and replacements are O(m^2) per pass: beyond this route length only LKH.
constexpr int kMaxLocalSearchRoute = 1000;
// Neighbour lists of 2-opt, Or-opt and replacements.
constexpr int kNear = 16;
constexpr int kSpreadStarts = 8;  // multi-start constructions through spread-out sites
// Replacements scan every insertion edge up to this route length, beyond it only the
// edges beside a site's nearest nodes (and only sites with a nearest node on the route).
constexpr int kFullScanRoute = 64;

class Costs {
 public:
  explicit Costs(const OpInstance& inst) : inst_(inst), n_(inst.Size()) {
    if (n_ <= kMaxMatrixNodes) {
      m_.resize(static_cast<size_t>(n_) * n_);
      for (int a = 0; a < n_; ++a)
        for (int b = 0; b < n_; ++b) m_[static_cast<size_t>(a) * n_ + b] = inst.Cost(a, b);
    }
  }
  // Every lookup counts one tick of work: the search's deterministic clock.
  double operator()(int a, int b) const {
    ++ticks_;
    return m_.empty() ? inst_.Cost(a, b) : m_[static_cast<size_t>(a) * n_ + b];
  }
  uint64_t Ticks() const { return ticks_; }
  void Charge(uint64_t ticks) const { ticks_ += ticks; }

 private:
  const OpInstance& inst_;
  int n_;
  std::vector<double> m_;
  mutable uint64_t ticks_ = 0;
};

struct Solution {
  std::vector<int> route;  // home ... end
  double cost = 0;
  double reward = 0;
};

enum Ruin { kRandom = 0, kSegment, kWorst, kRelated, kNumRuins };
const char* const kRuinNames[kNumRuins] = {"random", "segment", "worst", "related"};

class Search {
 public:
  Search(const OpInstance& inst, uint64_t seed)
      : inst_(inst),
        c_(inst),
        rng_(seed),
        limit_(inst.budget_m + BudgetSlack(inst.budget_m)),
        eps_(1e-12 * (1.0 + inst.budget_m)),
        in_(inst.Size(), 0),
        taken_(inst.Size(), 0) {
    for (int v = inst.FirstSite(); v < inst.Size(); ++v)
      if (inst.nodes[v].reward > 0) rewarded_.push_back(v);
    pos_.assign(inst.Size(), -1);
    // The kNear nearest nodes of each node, nearest first.
    const int n = inst.Size(), k = std::min(kNear, n - 1);
    near_.resize(n);
    std::vector<std::pair<double, int>> d;
    for (int a = 0; a < n; ++a) {
      d.clear();
      for (int b = 0; b < n; ++b)
        if (b != a) d.push_back({c_(a, b), b});
      std::partial_sort(d.begin(), d.begin() + k, d.end());
      for (int j = 0; j < k; ++j) near_[a].push_back(d[j].second);
    }
  }

  Solution Make(std::vector<int> route) const {
    Solution s;
    s.route = std::move(route);
    Evaluate(&s);
    return s;
  }
  void Evaluate(Solution* s) const {
    s->cost = 0;
    s->reward = 0;
    for (size_t i = 0; i + 1 < s->route.size(); ++i) s->cost += c_(s->route[i], s->route[i + 1]);
    for (int v : s->route)
      if (inst_.IsSite(v)) s->reward += inst_.nodes[v].reward;
  }
  bool Better(const Solution& a, const Solution& b) const {
    return inst_.Better(a.route, a.cost, b.route, b.cost);
  }
  bool AllRewardedVisited(const Solution& s) const {
    int on = 0;
    for (int v : s.route) on += inst_.IsSite(v) && inst_.nodes[v].reward > 0;
    return on == static_cast<int>(rewarded_.size());
  }

  // The local search: shorten, fill, replace, until none applies.
  void LocalSearch(Solution* s) {
    Mark(s->route);
    for (int guard = 0; guard < 1000; ++guard) {
      Shorten(s);
      Insert(s, nullptr, 0.0);
      if (!Replace(s)) break;
    }
    Evaluate(s);  // drop accumulated rounding
  }

  // Re-orders the route with the LKH engine, then refills it.
  void Polish(Solution* s, uint64_t seed) {
    // LKH's work, charged as its pairwise cost matrix times a few trials' worth.
    const uint64_t m = s->route.size();
    c_.Charge(20 * m * m);
    if (s->route.size() >= 6 && ReorderWithLkh(inst_, &s->route, seed, &ops_)) {
      Evaluate(s);
      LocalSearch(s);
    }
  }

  // Removes k sites by operator `op`; the removed sites are marked in blocked_.
  void Ruin(Solution* s, int op, int k) {
    std::vector<int>& r = s->route;
    const int sites = static_cast<int>(r.size()) - 2;
    blocked_.assign(inst_.Size(), 0);
    if (sites <= 0) return;
    k = std::min(k, sites);
    std::vector<int> positions;
    switch (op) {
      case kRandom: {
        for (int p = 1; p <= sites; ++p) positions.push_back(p);
        std::shuffle(positions.begin(), positions.end(), rng_);
        positions.resize(k);
        break;
      }
      case kSegment: {
        const int first = 1 + static_cast<int>(rng_() % sites);
        for (int p = first; p < std::min(first + k, sites + 1); ++p) positions.push_back(p);
        break;
      }
      case kWorst: {
        std::uniform_real_distribution<double> noise(0.7, 1.3);
        std::vector<std::pair<double, int>> ratio;
        for (int p = 1; p <= sites; ++p) {
          const double save = c_(r[p - 1], r[p]) + c_(r[p], r[p + 1]) - c_(r[p - 1], r[p + 1]);
          ratio.push_back({inst_.nodes[r[p]].reward / std::max(save, 1e-9) * noise(rng_), p});
        }
        std::partial_sort(ratio.begin(), ratio.begin() + k, ratio.end());
        for (int j = 0; j < k; ++j) positions.push_back(ratio[j].second);
        break;
      }
      default: {  // kRelated: a random site and the k - 1 sites of the route nearest to it
        const int centre = r[1 + rng_() % sites];
        std::vector<std::pair<double, int>> near;
        for (int p = 1; p <= sites; ++p) near.push_back({c_(centre, r[p]), p});
        std::partial_sort(near.begin(), near.begin() + k, near.end());
        for (int j = 0; j < k; ++j) positions.push_back(near[j].second);
        break;
      }
    }
    std::sort(positions.rbegin(), positions.rend());
    for (int p : positions) {
      blocked_[r[p]] = 1;
      r.erase(r.begin() + p);
    }
    Evaluate(s);
  }

  // A route from scratch: noisy ratio insertion into home -> (a random site) -> end, then
  // the local search.
  Solution Construct(double noise) {
    // Seeded by a random site that fits, so that restarts reach other parts of the field.
    for (int tries = 0; tries < 20 && !rewarded_.empty(); ++tries) {
      const int v = rewarded_[rng_() % rewarded_.size()];
      if (Fits(v) && !taken_[v]) return ConstructFrom(v, noise);
    }
    return ConstructFrom(-1, noise);
  }

  // The same through a given site (-1: none).
  Solution ConstructFrom(int seed_site, double noise) {
    Solution s = seed_site < 0 ? Make({OpInstance::kHome, inst_.end})
                               : Make({OpInstance::kHome, seed_site, inst_.end});
    blocked_.assign(inst_.Size(), 0);
    Recreate(&s, noise);
    LocalSearch(&s);
    return s;
  }

  // Up to k rewarded sites that fit, spread over the instance: farthest-point order from
  // home in the expanded costs. Multi-start seeds, for fields whose reward lies in
  // clusters away from where NewAlg's route went.
  std::vector<int> SpreadSites(int k) const {
    std::vector<int> out;
    std::vector<double> gap;
    std::vector<int> cand;
    for (int v : rewarded_)
      if (Fits(v) && !taken_[v]) {
        cand.push_back(v);
        gap.push_back(c_(OpInstance::kHome, v));
      }
    while (static_cast<int>(out.size()) < k && !cand.empty()) {
      const size_t j = std::max_element(gap.begin(), gap.end()) - gap.begin();
      if (gap[j] <= 0) break;
      const int v = cand[j];
      out.push_back(v);
      for (size_t i = 0; i < cand.size(); ++i) gap[i] = std::min(gap[i], c_(v, cand[i]));
    }
    return out;
  }

  bool Fits(int v) const { return c_(OpInstance::kHome, v) + c_(v, inst_.end) <= limit_; }

  // Recreate: noisy ratio insertion without the removed sites, then with all of them.
  void Recreate(Solution* s, double noise) {
    Mark(s->route);
    Insert(s, &blocked_, noise);
    Insert(s, nullptr, noise);
  }

  std::mt19937_64& Rng() { return rng_; }
  uint64_t Ticks() const { return c_.Ticks(); }
  double Limit() const { return limit_; }
  // Sites flown by the other flights of a multi-flight plan: never inserted into this one.
  void SetTaken(const std::vector<char>& taken) { taken_ = taken; }
  void ClearTaken() { std::fill(taken_.begin(), taken_.end(), 0); }
  std::vector<char>& Blocked() { return blocked_; }

  // Moves between two flights that keep both within the budget and shorten them together
  // (rewards unchanged; the freed budget is refilled afterwards): relocate a site of a
  // into b, exchange a site of a with one of b, and cross (a's head with b's tail and b's
  // head with a's tail; both end at the same node). Returns true if any was made.
  bool BetweenRoutes(Solution* a, Solution* b) {
    bool any = false;
    for (int round = 0; round < 50; ++round) {
      if (!(Relocate(a, b) || Relocate(b, a) || Exchange(a, b) || Cross(a, b))) break;
      any = true;
    }
    if (any) {
      Evaluate(a);
      Evaluate(b);
    }
    return any;
  }

 private:
  void Mark(const std::vector<int>& route) {
    std::fill(in_.begin(), in_.end(), 0);
    for (int v : route) in_[v] = 1;
  }

  void Shorten(Solution* s) {
    if (s->route.size() > kMaxLocalSearchRoute + 2) return;
    for (int pass = 0; pass < 100; ++pass) {
      const bool a = TwoOpt(s);
      const bool b = OrOpt(s);
      if (!a && !b) break;
    }
  }

  // pos_[v]: index of site v in the route (home and end are not tracked).
  void Positions(const std::vector<int>& r) {
    for (size_t i = 1; i + 1 < r.size(); ++i) pos_[r[i]] = static_cast<int>(i);
  }

  // 2-opt by neighbour lists: an improving reversal of r[p..q] has a new edge shorter than
  // the old edge beside it, (r[p-1], r[q]) vs (r[p-1], r[p]) or (r[p], r[q+1]) vs
  // (r[q], r[q+1]), so it is found from r[p-1] or r[q+1] and one of its nearest nodes.
  bool TwoOpt(Solution* s) {
    std::vector<int>& r = s->route;
    const int L = static_cast<int>(r.size());
    if (L < 4) return false;
    Positions(r);
    bool any = false;
    for (bool improved = true; improved;) {
      improved = false;
      for (int pu = 0; pu < L; ++pu) {
        const int u = r[pu];
        if (pu + 2 < L) {  // u = r[p-1]: new edge (u, c = r[q]), q > p
          const double old = c_(u, r[pu + 1]);
          for (int c : near_[u]) {
            const double cuc = c_(u, c);
            if (cuc >= old - eps_) break;
            if (!inst_.IsSite(c) || !in_[c]) continue;
            const int q = pos_[c];
            if (q <= pu + 1 || q + 1 >= L) continue;
            const double delta = cuc + c_(r[pu + 1], r[q + 1]) - old - c_(c, r[q + 1]);
            if (delta < -eps_) {
              Reverse(&r, pu + 1, q);
              s->cost += delta;
              improved = any = true;
              break;
            }
          }
        }
        if (pu >= 2 && r[pu] == u) {  // u = r[q+1]: new edge (c = r[p], u), p < q
          const double old = c_(r[pu - 1], u);
          for (int c : near_[u]) {
            const double cuc = c_(u, c);
            if (cuc >= old - eps_) break;
            if (!inst_.IsSite(c) || !in_[c]) continue;
            const int p = pos_[c];
            if (p < 1 || p >= pu - 1) continue;
            const double delta = cuc + c_(r[p - 1], r[pu - 1]) - old - c_(r[p - 1], c);
            if (delta < -eps_) {
              Reverse(&r, p, pu - 1);
              s->cost += delta;
              improved = any = true;
              break;
            }
          }
        }
      }
    }
    return any;
  }

  void Reverse(std::vector<int>* r, int p, int q) {
    std::reverse(r->begin() + p, r->begin() + q + 1);
    for (int i = p; i <= q; ++i) pos_[(*r)[i]] = i;
  }

  // Moves runs of 1-3 consecutive sites next to one of the nearest nodes of either end,
  // either orientation.
  bool OrOpt(Solution* s) {
    std::vector<int>& r = s->route;
    bool any = false;
    Positions(r);
    for (int len = 1; len <= 3; ++len) {
      for (int i = 1; i + len < static_cast<int>(r.size()); ++i) {
        const int L = static_cast<int>(r.size());
        const int p = r[i - 1], f = r[i], l = r[i + len - 1], q = r[i + len];
        const double removal = c_(p, f) + c_(l, q) - c_(p, q);
        if (removal <= eps_) continue;
        double best = eps_;
        int best_k = -1;
        bool reversed = false;
        auto consider = [&](int k) {  // the edge (r[k], r[k+1])
          if (k < 0 || k + 1 >= L || (k >= i - 1 && k < i + len)) return;
          const int x = r[k], y = r[k + 1];
          const double base = c_(x, y);
          const double fwd = c_(x, f) + c_(l, y) - base, rev = c_(x, l) + c_(f, y) - base;
          const double gain = removal - std::min(fwd, rev);
          if (gain > best) {
            best = gain;
            best_k = k;
            reversed = rev < fwd;
          }
        };
        for (int end : {f, l}) {
          for (int x : near_[end]) {
            if (c_(end, x) >= removal) break;  // an insertion beside x costs at least that
            int at;
            if (inst_.IsSite(x)) {
              if (!in_[x]) continue;
              at = pos_[x];
            } else if (x == OpInstance::kHome) {
              consider(0);
              if (!inst_.Closed()) continue;
              at = L - 1;
            } else {  // the end node of a path
              at = L - 1;
            }
            consider(at - 1);
            consider(at);
          }
        }
        if (best_k < 0) continue;
        std::vector<int> seg(r.begin() + i, r.begin() + i + len);
        if (reversed) std::reverse(seg.begin(), seg.end());
        r.erase(r.begin() + i, r.begin() + i + len);
        const int at = best_k < i ? best_k + 1 : best_k + 1 - len;
        r.insert(r.begin() + at, seg.begin(), seg.end());
        Positions(r);
        s->cost -= best;
        any = true;
      }
    }
    return any;
  }

  // Ratio insertion (reward over cheapest insertion cost, times a per-call noise factor per
  // site) while the budget allows; insertion costs are updated incrementally.
  void Insert(Solution* s, const std::vector<char>* blocked, double noise) {
    std::vector<int>& r = s->route;
    const int n = inst_.Size();
    const double inf = std::numeric_limits<double>::infinity();
    cand_.clear();
    for (int v : rewarded_)
      if (!in_[v] && !taken_[v] && !(blocked && (*blocked)[v])) cand_.push_back(v);
    if (cand_.empty()) return;
    next_.assign(n, -1);
    for (size_t i = 0; i + 1 < r.size(); ++i) next_[r[i]] = r[i + 1];
    delta_.assign(n, inf);
    after_.assign(n, -1);
    factor_.assign(n, 1.0);
    std::uniform_real_distribution<double> u(1.0 - noise, 1.0 + noise);
    // First scan over the route as an array (row v of the matrix, edge costs once).
    const int edges = static_cast<int>(r.size()) - 1;
    save_.resize(edges);
    for (int k = 0; k < edges; ++k) save_[k] = c_(r[k], r[k + 1]);
    for (int v : cand_) {
      double best = inf;
      int at = -1;
      for (int k = 0; k < edges; ++k) {
        const double d = c_(v, r[k]) + c_(v, r[k + 1]) - save_[k];
        if (d < best) {
          best = d;
          at = k;
        }
      }
      delta_[v] = best;
      after_[v] = r[at];
      if (noise > 0) factor_[v] = u(rng_);
    }
    int inserted = 0;
    for (;;) {
      int best = -1;
      double best_ratio = -1;
      for (int v : cand_) {
        if (in_[v] || s->cost + delta_[v] > limit_) continue;
        const double ratio = inst_.nodes[v].reward / std::max(delta_[v], 1e-12) * factor_[v];
        if (ratio > best_ratio) {
          best_ratio = ratio;
          best = v;
        }
      }
      if (best < 0) break;
      const int a = after_[best], b = next_[a];
      next_[a] = best;
      next_[best] = b;
      in_[best] = 1;
      s->cost += delta_[best];
      s->reward += inst_.nodes[best].reward;
      ++inserted;
      const double c_ab = c_(a, best), c_bb = c_(best, b);
      for (int v : cand_) {  // rows a, best and b read in order of v
        if (in_[v]) continue;
        if (after_[v] == a) {
          Scan(v);  // its best edge (a, b) was split
          continue;
        }
        const double d1 = c_(a, v) + c_(best, v) - c_ab;
        const double d2 = c_(best, v) + c_(b, v) - c_bb;
        if (d1 < delta_[v]) {
          delta_[v] = d1;
          after_[v] = a;
        }
        if (d2 < delta_[v]) {
          delta_[v] = d2;
          after_[v] = best;
        }
      }
    }
    if (inserted > 0) {
      const size_t length = r.size() + inserted;
      const int head = r[0];
      r.assign(1, head);
      for (int v = next_[head]; r.size() < length; v = next_[v]) r.push_back(v);
    }
  }

  // The cheapest insertion edge of v in the linked route next_.
  void Scan(int v) {
    const double inf = std::numeric_limits<double>::infinity();
    delta_[v] = inf;
    int a = inst_.kHome;
    for (;;) {
      const int b = next_[a];
      if (b < 0) break;
      const double d = c_(v, a) + c_(v, b) - c_(a, b);
      if (d < delta_[v]) {
        delta_[v] = d;
        after_[v] = a;
      }
      a = b;
      if (a == inst_.end) break;
    }
  }

  // 1-1 replacements: each unvisited site in turn takes the place of the visited site of
  // less reward whose removal (with the unvisited site at its cheapest place in the route
  // without it) gains the most reward within the budget, or of equal reward if that
  // shortens the route; applied at once. Returns true if any was made.
  bool Replace(Solution* s) {
    std::vector<int>& r = s->route;
    if (r.size() < 3 || r.size() > kMaxLocalSearchRoute + 2) return false;
    const double inf = std::numeric_limits<double>::infinity();
    double min_reward = inf;
    auto refresh = [&] {
      const int L = static_cast<int>(r.size());
      save_.assign(L, 0.0);
      edge_.resize(L - 1);
      for (int k = 0; k + 1 < L; ++k) edge_[k] = c_(r[k], r[k + 1]);
      min_reward = inf;
      for (int p = 1; p + 1 < L; ++p) {
        save_[p] = edge_[p - 1] + edge_[p] - c_(r[p - 1], r[p + 1]);
        min_reward = std::min(min_reward, inst_.nodes[r[p]].reward);
      }
      Positions(r);
    };
    refresh();
    bool any = false;
    for (int v : rewarded_) {
      if (in_[v] || taken_[v]) continue;
      const double rv = inst_.nodes[v].reward;
      if (rv < min_reward * (1.0 - 1e-12)) continue;  // every visited site has more
      const int L = static_cast<int>(r.size());
      // The three cheapest insertion edges (k: between r[k] and r[k+1]): on long routes
      // only the edges beside v's nearest nodes on the route (and v is left out when none
      // of those is on it).
      std::array<std::pair<double, int>, 3> top{{{inf, -1}, {inf, -1}, {inf, -1}}};
      auto consider = [&](int k) {
        if (k < 0 || k + 1 >= L || k == top[0].second || k == top[1].second || k == top[2].second) {
          return;
        }
        const double d = c_(v, r[k]) + c_(v, r[k + 1]) - edge_[k];
        if (d < top[2].first) {
          top[2] = {d, k};
          if (top[2] < top[1]) std::swap(top[2], top[1]);
          if (top[1] < top[0]) std::swap(top[1], top[0]);
        }
      };
      bool near_route = false;
      if (L > kFullScanRoute) {
        for (int x : near_[v]) {
          if (inst_.IsSite(x)) {
            if (!in_[x]) continue;
            consider(pos_[x] - 1);
            consider(pos_[x]);
          } else {  // home (first edge; a closed tour's last too) or a path's end node
            if (x == OpInstance::kHome) consider(0);
            if (x == inst_.end) consider(L - 2);
          }
          near_route = true;
        }
      }
      if (L > kFullScanRoute && !near_route) continue;  // far from the route
      if (!near_route)
        for (int k = 0; k + 1 < L; ++k) consider(k);
      // A swap for a site of equal reward must shorten the route (it frees budget).
      const double tie = 1e-12 * (1.0 + rv), shorter = s->cost - 1e-9 * (1.0 + s->cost);
      double best_gain = -1, best_cost = 0;
      int best_p = -1;
      for (int p = 1; p + 1 < L; ++p) {
        const double gain = rv - inst_.nodes[r[p]].reward;
        if (gain < -tie || gain < best_gain - tie) continue;
        double ins = c_(v, r[p - 1]) + c_(v, r[p + 1]) - (edge_[p - 1] + edge_[p] - save_[p]);
        for (const auto& [d, k] : top) {
          if (k < 0) break;
          if (k == p - 1 || k == p) continue;
          ins = std::min(ins, d);
          break;
        }
        const double cost = s->cost - save_[p] + ins;
        if (cost > limit_ || (gain <= tie && cost >= shorter)) continue;
        if (gain > best_gain + tie || cost < best_cost) {
          best_gain = gain;
          best_cost = cost;
          best_p = p;
        }
      }
      if (best_p < 0) continue;
      in_[r[best_p]] = 0;
      s->reward -= inst_.nodes[r[best_p]].reward;
      s->cost -= save_[best_p];
      r.erase(r.begin() + best_p);
      double d_best = inf;
      int at = 1;
      for (int k = 0; k + 1 < static_cast<int>(r.size()); ++k) {
        const double d = c_(r[k], v) + c_(v, r[k + 1]) - c_(r[k], r[k + 1]);
        if (d < d_best) {
          d_best = d;
          at = k + 1;
        }
      }
      r.insert(r.begin() + at, v);
      in_[v] = 1;
      s->cost += d_best;
      s->reward += rv;
      any = true;
      refresh();
    }
    return any;
  }

  // Cost of leaving out r[p] (the edge that replaces it counted).
  double Saving(const std::vector<int>& r, int p) const {
    return c_(r[p - 1], r[p]) + c_(r[p], r[p + 1]) - c_(r[p - 1], r[p + 1]);
  }

  // The cheapest place for v in r: (extra cost, insert before index).
  std::pair<double, int> CheapestInsertion(const std::vector<int>& r, int v) const {
    double best = std::numeric_limits<double>::infinity();
    int at = 1;
    for (size_t k = 0; k + 1 < r.size(); ++k) {
      const double d = c_(r[k], v) + c_(v, r[k + 1]) - c_(r[k], r[k + 1]);
      if (d < best) {
        best = d;
        at = static_cast<int>(k) + 1;
      }
    }
    return {best, at};
  }

  // A site of a moved into b where that costs less than it saves in a.
  bool Relocate(Solution* a, Solution* b) {
    std::vector<int>& ra = a->route;
    for (int p = 1; p + 1 < static_cast<int>(ra.size()); ++p) {
      const int v = ra[p];
      const double save = Saving(ra, p);
      const auto [add, at] = CheapestInsertion(b->route, v);
      if (b->cost + add <= limit_ && add < save - 1e-9 * (1.0 + save)) {
        ra.erase(ra.begin() + p);
        b->route.insert(b->route.begin() + at, v);
        a->cost -= save;
        b->cost += add;
        a->reward -= inst_.nodes[v].reward;
        b->reward += inst_.nodes[v].reward;
        return true;
      }
    }
    return false;
  }

  // A site of a and a site of b swapped, each at the other's place.
  bool Exchange(Solution* a, Solution* b) {
    std::vector<int>& ra = a->route;
    std::vector<int>& rb = b->route;
    for (int p = 1; p + 1 < static_cast<int>(ra.size()); ++p) {
      const int v = ra[p];
      const double out_a = c_(ra[p - 1], v) + c_(v, ra[p + 1]);
      for (int q = 1; q + 1 < static_cast<int>(rb.size()); ++q) {
        const int w = rb[q];
        const double da = c_(ra[p - 1], w) + c_(w, ra[p + 1]) - out_a;
        const double db = c_(rb[q - 1], v) + c_(v, rb[q + 1]) - c_(rb[q - 1], w) - c_(w, rb[q + 1]);
        if (da + db < -1e-9 * (1.0 + a->cost + b->cost) && a->cost + da <= limit_ &&
            b->cost + db <= limit_) {
          std::swap(ra[p], rb[q]);
          a->cost += da;
          b->cost += db;
          const double rv = inst_.nodes[v].reward, rw = inst_.nodes[w].reward;
          a->reward += rw - rv;
          b->reward += rv - rw;
          return true;
        }
      }
    }
    return false;
  }

  // 2-opt*: a[0..i] + b[j+1..] and b[0..j] + a[i+1..].
  bool Cross(Solution* a, Solution* b) {
    std::vector<int>& ra = a->route;
    std::vector<int>& rb = b->route;
    const int la = static_cast<int>(ra.size()), lb = static_cast<int>(rb.size());
    if (la < 3 && lb < 3) return false;
    std::vector<double> pa(la, 0.0), pb(lb, 0.0);  // prefix costs
    for (int k = 1; k < la; ++k) pa[k] = pa[k - 1] + c_(ra[k - 1], ra[k]);
    for (int k = 1; k < lb; ++k) pb[k] = pb[k - 1] + c_(rb[k - 1], rb[k]);
    const double old = a->cost + b->cost, tol = 1e-9 * (1.0 + old);
    for (int i = 0; i + 1 < la; ++i) {
      for (int j = 0; j + 1 < lb; ++j) {
        if ((i == 0 && j == 0) || (i == la - 2 && j == lb - 2)) continue;  // a swap of whole routes
        const double na = pa[i] + c_(ra[i], rb[j + 1]) + (pb[lb - 1] - pb[j + 1]);
        const double nb = pb[j] + c_(rb[j], ra[i + 1]) + (pa[la - 1] - pa[i + 1]);
        if (na + nb < old - tol && na <= limit_ && nb <= limit_) {
          std::vector<int> new_a(ra.begin(), ra.begin() + i + 1);
          new_a.insert(new_a.end(), rb.begin() + j + 1, rb.end());
          std::vector<int> new_b(rb.begin(), rb.begin() + j + 1);
          new_b.insert(new_b.end(), ra.begin() + i + 1, ra.end());
          ra = std::move(new_a);
          rb = std::move(new_b);
          Evaluate(a);
          Evaluate(b);
          return true;
        }
      }
    }
    return false;
  }

  const OpInstance& inst_;
  Costs c_;
  std::mt19937_64 rng_;
  double limit_, eps_;
  std::vector<char> in_, blocked_, taken_;
  std::vector<int> rewarded_, cand_, next_, after_, pos_;
  std::vector<std::vector<int>> near_;
  std::vector<double> delta_, factor_, save_, edge_;
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

  Search search(inst, opt.seed ^ 0xA5A5A5A5ULL);
  std::mt19937_64& rng = search.Rng();
  const int n = inst.Size();
  std::vector<char> taken(n, 0);
  auto mark_others = [&](const std::vector<Solution>& fl, int k) {
    std::fill(taken.begin(), taken.end(), 0);
    for (int j = 0; j < static_cast<int>(fl.size()); ++j) {
      if (j == k) continue;
      for (int v : fl[j].route)
        if (inst.IsSite(v)) taken[v] = 1;
    }
    search.SetTaken(taken);
  };
  struct Multi {
    std::vector<Solution> fl;
    double reward = 0, cost = 0;
  };
  auto total = [&](Multi* m) {
    m->reward = m->cost = 0;
    for (auto& s : m->fl) {
      search.Evaluate(&s);
      m->reward += s.reward;
      m->cost += s.cost;
    }
  };
  auto better = [&](const Multi& a, const Multi& b) {
    const double eps = 1e-12 * (1.0 + std::abs(b.reward));
    if (a.reward > b.reward + eps) return true;
    return a.reward >= b.reward - eps && a.cost < b.cost - 1e-9;
  };
  // Moves between every pair of flights, then each flight refilled and searched again.
  auto improve = [&](Multi* m) {
    for (int round = 0; round < 10; ++round) {
      bool moved = false;
      for (int a = 0; a < flights; ++a)
        for (int b = a + 1; b < flights; ++b) moved |= search.BetweenRoutes(&m->fl[a], &m->fl[b]);
      bool grew = false;
      for (int k = 0; k < flights; ++k) {
        const double before = m->fl[k].reward;
        mark_others(m->fl, k);
        search.LocalSearch(&m->fl[k]);
        grew |= m->fl[k].reward > before + 1e-12;
      }
      if (!moved && !grew) break;
    }
    total(m);
  };

  Multi best;
  for (auto& r : seq.routes) best.fl.push_back(search.Make(r));
  improve(&best);
  const double seq_reward = seq.reward;
  Multi cur = best;

  const int restart = schedule.Restart();
  Roulette roulette;
  int it = 0, since_best = 0, new_bests = 0, last_polish = 0;
  std::vector<char> blocked(n, 0);
  auto ticks = [&] { return static_cast<double>(search.Ticks() + start_ticks); };
  int rewarded = 0;
  for (int v = inst.FirstSite(); v < n; ++v) rewarded += inst.nodes[v].reward > 0;
  auto all_visited = [&](const Multi& m) {
    int on = 0;
    for (const auto& s : m.fl)
      for (int v : s.route) on += inst.IsSite(v) && inst.nodes[v].reward > 0;
    return on == rewarded;
  };
  for (; schedule.Going(it, since_best); ++it) {
    if (all_visited(best)) break;
    if (schedule.OutOfTime(ticks())) break;
    const int op = roulette.Pick(rng);
    Multi cand = cur;
    // Ruin one flight (half of the time) or all of them.
    const bool all = rng() % 2 == 0;
    const int one = static_cast<int>(rng() % flights);
    std::fill(blocked.begin(), blocked.end(), 0);
    for (int k = 0; k < flights; ++k) {
      if (!all && k != one) continue;
      const int m = static_cast<int>(cand.fl[k].route.size()) - 2;
      if (m <= 0) continue;
      search.Ruin(&cand.fl[k], op, RuinSize(m, rng));
      for (int v = 0; v < n; ++v) blocked[v] |= search.Blocked()[v];
    }
    static constexpr double kNoise[] = {0.1, 0.3, 0.6};
    const double noise = kNoise[rng() % 3];
    std::vector<int> order(flights);
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), rng);
    for (int k : order) {
      mark_others(cand.fl, k);
      search.Blocked() = blocked;
      search.Recreate(&cand.fl[k], noise);
      search.LocalSearch(&cand.fl[k]);
    }
    improve(&cand);

    const double threshold = schedule.Threshold(ticks(), since_best);
    ++since_best;
    if (better(cand, best)) {
      best = cand;
      ++new_bests;
      since_best = 0;
      roulette.Score(op, 33);
      if (it - last_polish >= 50) {
        for (int k = 0; k < flights; ++k) {
          mark_others(best.fl, k);
          search.Polish(&best.fl[k], opt.seed + static_cast<uint64_t>(it) + k);
        }
        improve(&best);
        last_polish = it;
      }
      cur = best;
    } else if (better(cand, cur)) {
      roulette.Score(op, 9);
      cur = std::move(cand);
    } else if (cand.reward >= best.reward * (1.0 - threshold)) {
      roulette.Score(op, 13);
      cur = std::move(cand);
    }
    if (since_best > 0 && since_best % restart == 0) cur = best;
    roulette.Next();
  }
  for (int k = 0; k < flights; ++k) {
    mark_others(best.fl, k);
    search.Polish(&best.fl[k], opt.seed + 0x9E3779B9ULL + k);
  }
  improve(&best);

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
