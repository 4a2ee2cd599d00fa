#include "plan/alns_operators.h"

#include <algorithm>
#include <array>
#include <limits>
#include <utility>

namespace mound::plan::alns {

Neighbourhood::Neighbourhood(const OpInstance& instance)
    : inst(instance),
      costs(instance),
      limit(instance.budget_m + BudgetSlack(instance.budget_m)),
      eps(1e-12 * (1.0 + instance.budget_m)) {
  for (int v = inst.FirstSite(); v < inst.Size(); ++v)
    if (inst.nodes[v].reward > 0) rewarded.push_back(v);
  // The kNear nearest nodes of each node, nearest first.
  const int n = inst.Size(), k = std::min(kNear, n - 1);
  near.resize(n);
  std::vector<std::pair<double, int>> d;
  for (int a = 0; a < n; ++a) {
    d.clear();
    for (int b = 0; b < n; ++b)
      if (b != a) d.push_back({costs(a, b), b});
    std::partial_sort(d.begin(), d.begin() + k, d.end());
    for (int j = 0; j < k; ++j) near[a].push_back(d[j].second);
  }
}

Solution Neighbourhood::Make(std::vector<int> route) const {
  Solution s;
  s.route = std::move(route);
  Evaluate(&s);
  return s;
}

void Neighbourhood::Evaluate(Solution* s) const {
  s->cost = 0;
  s->reward = 0;
  for (size_t i = 0; i + 1 < s->route.size(); ++i) s->cost += costs(s->route[i], s->route[i + 1]);
  for (int v : s->route)
    if (inst.IsSite(v)) s->reward += inst.nodes[v].reward;
}

void RouteState::Mark(const std::vector<int>& route) {
  std::fill(in.begin(), in.end(), 0);
  for (int v : route) in[v] = 1;
}

void RouteState::Positions(const std::vector<int>& r) {
  for (size_t i = 1; i + 1 < r.size(); ++i) pos[r[i]] = static_cast<int>(i);
}

void RouteState::Reverse(std::vector<int>* r, int p, int q) {
  std::reverse(r->begin() + p, r->begin() + q + 1);
  for (int i = p; i <= q; ++i) pos[(*r)[i]] = i;
}

void Ruin(const Neighbourhood& N, int op, int k, std::mt19937_64& rng, Solution* s,
          std::vector<char>* blocked) {
  const OpInstance& inst = N.inst;
  const Costs& C = N.costs;
  std::vector<int>& r = s->route;
  const int sites = static_cast<int>(r.size()) - 2;
  blocked->assign(inst.Size(), 0);
  if (sites <= 0) return;
  k = std::min(k, sites);
  std::vector<int> positions;
  switch (op) {
    case kRandom: {
      for (int p = 1; p <= sites; ++p) positions.push_back(p);
      std::shuffle(positions.begin(), positions.end(), rng);
      positions.resize(k);
      break;
    }
    case kSegment: {
      const int first = 1 + static_cast<int>(rng() % sites);
      for (int p = first; p < std::min(first + k, sites + 1); ++p) positions.push_back(p);
      break;
    }
    case kWorst: {
      std::uniform_real_distribution<double> noise(0.7, 1.3);
      std::vector<std::pair<double, int>> ratio;
      for (int p = 1; p <= sites; ++p) {
        const double save = C(r[p - 1], r[p]) + C(r[p], r[p + 1]) - C(r[p - 1], r[p + 1]);
        ratio.push_back({inst.nodes[r[p]].reward / std::max(save, 1e-9) * noise(rng), p});
      }
      std::partial_sort(ratio.begin(), ratio.begin() + k, ratio.end());
      for (int j = 0; j < k; ++j) positions.push_back(ratio[j].second);
      break;
    }
    default: {  // kRelated: a random site and the k - 1 sites of the route nearest to it
      const int centre = r[1 + rng() % sites];
      std::vector<std::pair<double, int>> near;
      for (int p = 1; p <= sites; ++p) near.push_back({C(centre, r[p]), p});
      std::partial_sort(near.begin(), near.begin() + k, near.end());
      for (int j = 0; j < k; ++j) positions.push_back(near[j].second);
      break;
    }
  }
  std::sort(positions.rbegin(), positions.rend());
  for (int p : positions) {
    (*blocked)[r[p]] = 1;
    r.erase(r.begin() + p);
  }
  N.Evaluate(s);
}

bool TwoOpt::Apply(const Neighbourhood& N, RouteState& state, Solution* s) const {
  const OpInstance& inst = N.inst;
  const Costs& C = N.costs;
  std::vector<int>& r = s->route;
  const int L = static_cast<int>(r.size());
  if (L < 4) return false;
  state.Positions(r);
  bool any = false;
  for (bool improved = true; improved;) {
    improved = false;
    for (int pu = 0; pu < L; ++pu) {
      const int u = r[pu];
      if (pu + 2 < L) {  // u = r[p-1]: new edge (u, c = r[q]), q > p
        const double old = C(u, r[pu + 1]);
        for (int c : N.near[u]) {
          const double cuc = C(u, c);
          if (cuc >= old - N.eps) break;
          if (!inst.IsSite(c) || !state.in[c]) continue;
          const int q = state.pos[c];
          if (q <= pu + 1 || q + 1 >= L) continue;
          const double delta = cuc + C(r[pu + 1], r[q + 1]) - old - C(c, r[q + 1]);
          if (delta < -N.eps) {
            state.Reverse(&r, pu + 1, q);
            s->cost += delta;
            improved = any = true;
            break;
          }
        }
      }
      if (pu >= 2 && r[pu] == u) {  // u = r[q+1]: new edge (c = r[p], u), p < q
        const double old = C(r[pu - 1], u);
        for (int c : N.near[u]) {
          const double cuc = C(u, c);
          if (cuc >= old - N.eps) break;
          if (!inst.IsSite(c) || !state.in[c]) continue;
          const int p = state.pos[c];
          if (p < 1 || p >= pu - 1) continue;
          const double delta = cuc + C(r[p - 1], r[pu - 1]) - old - C(r[p - 1], c);
          if (delta < -N.eps) {
            state.Reverse(&r, p, pu - 1);
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

bool OrOpt::Apply(const Neighbourhood& N, RouteState& state, Solution* s) const {
  const OpInstance& inst = N.inst;
  const Costs& C = N.costs;
  std::vector<int>& r = s->route;
  bool any = false;
  state.Positions(r);
  for (int len = 1; len <= 3; ++len) {
    for (int i = 1; i + len < static_cast<int>(r.size()); ++i) {
      const int L = static_cast<int>(r.size());
      const int p = r[i - 1], f = r[i], l = r[i + len - 1], q = r[i + len];
      const double removal = C(p, f) + C(l, q) - C(p, q);
      if (removal <= N.eps) continue;
      double best = N.eps;
      int best_k = -1;
      bool reversed = false;
      auto consider = [&](int k) {  // the edge (r[k], r[k+1])
        if (k < 0 || k + 1 >= L || (k >= i - 1 && k < i + len)) return;
        const int x = r[k], y = r[k + 1];
        const double base = C(x, y);
        const double fwd = C(x, f) + C(l, y) - base, rev = C(x, l) + C(f, y) - base;
        const double gain = removal - std::min(fwd, rev);
        if (gain > best) {
          best = gain;
          best_k = k;
          reversed = rev < fwd;
        }
      };
      for (int end : {f, l}) {
        for (int x : N.near[end]) {
          if (C(end, x) >= removal) break;  // an insertion beside x costs at least that
          int at;
          if (inst.IsSite(x)) {
            if (!state.in[x]) continue;
            at = state.pos[x];
          } else if (x == OpInstance::kHome) {
            consider(0);
            if (!inst.Closed()) continue;
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
      state.Positions(r);
      s->cost -= best;
      any = true;
    }
  }
  return any;
}

void RatioInsert::Apply(const Neighbourhood& N, RouteState& state, Solution* s,
                        const std::vector<char>& taken, const std::vector<char>* blocked,
                        double noise, std::mt19937_64& rng) {
  const OpInstance& inst = N.inst;
  const Costs& C = N.costs;
  std::vector<int>& r = s->route;
  const int n = inst.Size();
  const double inf = std::numeric_limits<double>::infinity();
  cand_.clear();
  for (int v : N.rewarded)
    if (!state.in[v] && !taken[v] && !(blocked && (*blocked)[v])) cand_.push_back(v);
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
  for (int k = 0; k < edges; ++k) save_[k] = C(r[k], r[k + 1]);
  for (int v : cand_) {
    double best = inf;
    int at = -1;
    for (int k = 0; k < edges; ++k) {
      const double d = C(v, r[k]) + C(v, r[k + 1]) - save_[k];
      if (d < best) {
        best = d;
        at = k;
      }
    }
    delta_[v] = best;
    after_[v] = r[at];
    if (noise > 0) factor_[v] = u(rng);
  }
  int inserted = 0;
  for (;;) {
    int best = -1;
    double best_ratio = -1;
    for (int v : cand_) {
      if (state.in[v] || s->cost + delta_[v] > N.limit) continue;
      const double ratio = inst.nodes[v].reward / std::max(delta_[v], 1e-12) * factor_[v];
      if (ratio > best_ratio) {
        best_ratio = ratio;
        best = v;
      }
    }
    if (best < 0) break;
    const int a = after_[best], b = next_[a];
    next_[a] = best;
    next_[best] = b;
    state.in[best] = 1;
    s->cost += delta_[best];
    s->reward += inst.nodes[best].reward;
    ++inserted;
    const double c_ab = C(a, best), c_bb = C(best, b);
    for (int v : cand_) {  // rows a, best and b read in order of v
      if (state.in[v]) continue;
      if (after_[v] == a) {
        Scan(N, v);  // its best edge (a, b) was split
        continue;
      }
      const double d1 = C(a, v) + C(best, v) - c_ab;
      const double d2 = C(best, v) + C(b, v) - c_bb;
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

void RatioInsert::Scan(const Neighbourhood& N, int v) {
  const OpInstance& inst = N.inst;
  const Costs& C = N.costs;
  const double inf = std::numeric_limits<double>::infinity();
  delta_[v] = inf;
  int a = inst.kHome;
  for (;;) {
    const int b = next_[a];
    if (b < 0) break;
    const double d = C(v, a) + C(v, b) - C(a, b);
    if (d < delta_[v]) {
      delta_[v] = d;
      after_[v] = a;
    }
    a = b;
    if (a == inst.end) break;
  }
}

bool Replace::Apply(const Neighbourhood& N, RouteState& state, Solution* s,
                    const std::vector<char>& taken) {
  const OpInstance& inst = N.inst;
  const Costs& C = N.costs;
  std::vector<int>& r = s->route;
  if (r.size() < 3 || r.size() > kMaxLocalSearchRoute + 2) return false;
  const double inf = std::numeric_limits<double>::infinity();
  double min_reward = inf;
  auto refresh = [&] {
    const int L = static_cast<int>(r.size());
    save_.assign(L, 0.0);
    edge_.resize(L - 1);
    for (int k = 0; k + 1 < L; ++k) edge_[k] = C(r[k], r[k + 1]);
    min_reward = inf;
    for (int p = 1; p + 1 < L; ++p) {
      save_[p] = edge_[p - 1] + edge_[p] - C(r[p - 1], r[p + 1]);
      min_reward = std::min(min_reward, inst.nodes[r[p]].reward);
    }
    state.Positions(r);
  };
  refresh();
  bool any = false;
  for (int v : N.rewarded) {
    if (state.in[v] || taken[v]) continue;
    const double rv = inst.nodes[v].reward;
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
      const double d = C(v, r[k]) + C(v, r[k + 1]) - edge_[k];
      if (d < top[2].first) {
        top[2] = {d, k};
        if (top[2] < top[1]) std::swap(top[2], top[1]);
        if (top[1] < top[0]) std::swap(top[1], top[0]);
      }
    };
    bool near_route = false;
    if (L > kFullScanRoute) {
      for (int x : N.near[v]) {
        if (inst.IsSite(x)) {
          if (!state.in[x]) continue;
          consider(state.pos[x] - 1);
          consider(state.pos[x]);
        } else {  // home (first edge; a closed tour's last too) or a path's end node
          if (x == OpInstance::kHome) consider(0);
          if (x == inst.end) consider(L - 2);
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
      const double gain = rv - inst.nodes[r[p]].reward;
      if (gain < -tie || gain < best_gain - tie) continue;
      double ins = C(v, r[p - 1]) + C(v, r[p + 1]) - (edge_[p - 1] + edge_[p] - save_[p]);
      for (const auto& [d, k] : top) {
        if (k < 0) break;
        if (k == p - 1 || k == p) continue;
        ins = std::min(ins, d);
        break;
      }
      const double cost = s->cost - save_[p] + ins;
      if (cost > N.limit || (gain <= tie && cost >= shorter)) continue;
      if (gain > best_gain + tie || cost < best_cost) {
        best_gain = gain;
        best_cost = cost;
        best_p = p;
      }
    }
    if (best_p < 0) continue;
    state.in[r[best_p]] = 0;
    s->reward -= inst.nodes[r[best_p]].reward;
    s->cost -= save_[best_p];
    r.erase(r.begin() + best_p);
    double d_best = inf;
    int at = 1;
    for (int k = 0; k + 1 < static_cast<int>(r.size()); ++k) {
      const double d = C(r[k], v) + C(v, r[k + 1]) - C(r[k], r[k + 1]);
      if (d < d_best) {
        d_best = d;
        at = k + 1;
      }
    }
    r.insert(r.begin() + at, v);
    state.in[v] = 1;
    s->cost += d_best;
    s->reward += rv;
    any = true;
    refresh();
  }
  return any;
}

namespace {

// Cost of leaving out r[p] (the edge that replaces it counted).
double Saving(const Neighbourhood& N, const std::vector<int>& r, int p) {
  const Costs& C = N.costs;
  return C(r[p - 1], r[p]) + C(r[p], r[p + 1]) - C(r[p - 1], r[p + 1]);
}

// The cheapest place for v in r: (extra cost, insert before index).
std::pair<double, int> CheapestInsertion(const Neighbourhood& N, const std::vector<int>& r, int v) {
  const Costs& C = N.costs;
  double best = std::numeric_limits<double>::infinity();
  int at = 1;
  for (size_t k = 0; k + 1 < r.size(); ++k) {
    const double d = C(r[k], v) + C(v, r[k + 1]) - C(r[k], r[k + 1]);
    if (d < best) {
      best = d;
      at = static_cast<int>(k) + 1;
    }
  }
  return {best, at};
}

}  // namespace

bool Relocate(const Neighbourhood& N, Solution* a, Solution* b) {
  const OpInstance& inst = N.inst;
  std::vector<int>& ra = a->route;
  for (int p = 1; p + 1 < static_cast<int>(ra.size()); ++p) {
    const int v = ra[p];
    const double save = Saving(N, ra, p);
    const auto [add, at] = CheapestInsertion(N, b->route, v);
    if (b->cost + add <= N.limit && add < save - 1e-9 * (1.0 + save)) {
      ra.erase(ra.begin() + p);
      b->route.insert(b->route.begin() + at, v);
      a->cost -= save;
      b->cost += add;
      a->reward -= inst.nodes[v].reward;
      b->reward += inst.nodes[v].reward;
      return true;
    }
  }
  return false;
}

bool Exchange(const Neighbourhood& N, Solution* a, Solution* b) {
  const OpInstance& inst = N.inst;
  const Costs& C = N.costs;
  std::vector<int>& ra = a->route;
  std::vector<int>& rb = b->route;
  for (int p = 1; p + 1 < static_cast<int>(ra.size()); ++p) {
    const int v = ra[p];
    const double out_a = C(ra[p - 1], v) + C(v, ra[p + 1]);
    for (int q = 1; q + 1 < static_cast<int>(rb.size()); ++q) {
      const int w = rb[q];
      const double da = C(ra[p - 1], w) + C(w, ra[p + 1]) - out_a;
      const double db = C(rb[q - 1], v) + C(v, rb[q + 1]) - C(rb[q - 1], w) - C(w, rb[q + 1]);
      if (da + db < -1e-9 * (1.0 + a->cost + b->cost) && a->cost + da <= N.limit &&
          b->cost + db <= N.limit) {
        std::swap(ra[p], rb[q]);
        a->cost += da;
        b->cost += db;
        const double rv = inst.nodes[v].reward, rw = inst.nodes[w].reward;
        a->reward += rw - rv;
        b->reward += rv - rw;
        return true;
      }
    }
  }
  return false;
}

bool Cross(const Neighbourhood& N, Solution* a, Solution* b) {
  const Costs& C = N.costs;
  std::vector<int>& ra = a->route;
  std::vector<int>& rb = b->route;
  const int la = static_cast<int>(ra.size()), lb = static_cast<int>(rb.size());
  if (la < 3 && lb < 3) return false;
  std::vector<double> pa(la, 0.0), pb(lb, 0.0);  // prefix costs
  for (int k = 1; k < la; ++k) pa[k] = pa[k - 1] + C(ra[k - 1], ra[k]);
  for (int k = 1; k < lb; ++k) pb[k] = pb[k - 1] + C(rb[k - 1], rb[k]);
  const double old = a->cost + b->cost, tol = 1e-9 * (1.0 + old);
  for (int i = 0; i + 1 < la; ++i) {
    for (int j = 0; j + 1 < lb; ++j) {
      if ((i == 0 && j == 0) || (i == la - 2 && j == lb - 2)) continue;  // a swap of whole routes
      const double na = pa[i] + C(ra[i], rb[j + 1]) + (pb[lb - 1] - pb[j + 1]);
      const double nb = pb[j] + C(rb[j], ra[i + 1]) + (pa[la - 1] - pa[i + 1]);
      if (na + nb < old - tol && na <= N.limit && nb <= N.limit) {
        std::vector<int> new_a(ra.begin(), ra.begin() + i + 1);
        new_a.insert(new_a.end(), rb.begin() + j + 1, rb.end());
        std::vector<int> new_b(rb.begin(), rb.begin() + j + 1);
        new_b.insert(new_b.end(), ra.begin() + i + 1, ra.end());
        ra = std::move(new_a);
        rb = std::move(new_b);
        N.Evaluate(a);
        N.Evaluate(b);
        return true;
      }
    }
  }
  return false;
}

}  // namespace mound::plan::alns
