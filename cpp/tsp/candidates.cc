#include "tsp/candidates.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>

namespace mound::tsp {
namespace {

constexpr Cost kInf = std::numeric_limits<Cost>::max() / 4;

// A sparse symmetric graph in compressed rows: the neighbours of v are
// node[first[v] .. first[v + 1]) with untransformed costs P*D in pc (same positions).
struct SparseGraph {
  std::vector<int> first, node;
  std::vector<Cost> pc;
};

// A minimum 1-tree under transformed costs.
struct OneTree {
  std::vector<int> dad;        // tree parent, -1 for the root
  std::vector<Cost> dad_cost;  // transformed cost of (v, dad[v])
  std::vector<int> order;      // topological order: dad before child
  std::vector<int> degree;
  int special = -1, special_to = -1;  // the extra edge
  Cost special_cost = 0;
  Cost cost = 0;  // sum of transformed edge costs
};

class OneTreeBuilder {
 public:
  OneTreeBuilder(const CostCache& d, int precision) : d_(d), p_(precision), n_(d.Size()) {}

  Cost C(int i, int j, const std::vector<Cost>& pi) const {
    return p_ * d_.D(i, j) + pi[i] + pi[j];
  }

  // Prim on the complete graph, O(n^2).
  void Dense(const std::vector<Cost>& pi, OneTree* t) const {
    Init(t);
    std::vector<Cost> key(n_, kInf);
    std::vector<int> from(n_, -1);
    std::vector<char> in(n_, 0);
    int v = 0;
    in[v] = 1;
    t->order.push_back(v);
    for (int step = 1; step < n_; ++step) {
      int best = -1;
      Cost best_key = kInf;
      for (int u = 0; u < n_; ++u) {
        if (in[u]) continue;
        const Cost c = C(v, u, pi);
        if (c < key[u]) {
          key[u] = c;
          from[u] = v;
        }
        if (key[u] < best_key) {
          best_key = key[u];
          best = u;
        }
      }
      in[best] = 1;
      Attach(t, best, from[best], best_key);
      v = best;
    }
    // Special edge: over all leaves, the cheapest edge not in the tree; keep the longest.
    for (int s = 0; s < n_; ++s) {
      if (t->degree[s] != 1) continue;
      Cost c2 = kInf;
      int to = -1;
      for (int u = 0; u < n_; ++u) {
        if (u == s || u == t->dad[s] || t->dad[u] == s) continue;
        const Cost c = C(s, u, pi);
        if (c < c2) {
          c2 = c;
          to = u;
        }
      }
      ConsiderSpecial(t, s, to, c2);
    }
    Finish(t);
  }

  // Prim with a binary heap on a sparse symmetric graph; falls back to dense if the graph
  // does not span. The work arrays are kept between calls (the ascent calls it thousands
  // of times).
  void Sparse(const SparseGraph& g, const std::vector<Cost>& pi, OneTree* t) const {
    Init(t);
    key_.assign(n_, kInf);
    from_.assign(n_, -1);
    in_.assign(n_, 0);
    heap_.clear();
    auto greater = std::greater<Item>();
    key_[0] = 0;
    heap_.emplace_back(0, 0);
    int added = 0;
    while (!heap_.empty()) {
      std::pop_heap(heap_.begin(), heap_.end(), greater);
      const auto [k, v] = heap_.back();
      heap_.pop_back();
      if (in_[v] || k != key_[v]) continue;
      in_[v] = 1;
      ++added;
      if (v == 0) {
        t->order.push_back(0);
      } else {
        Attach(t, v, from_[v], k);
      }
      const Cost pv = pi[v];
      for (int e = g.first[v], end = g.first[v + 1]; e < end; ++e) {
        const int u = g.node[e];
        if (in_[u]) continue;
        const Cost c = g.pc[e] + pv + pi[u];
        if (c < key_[u]) {
          key_[u] = c;
          from_[u] = v;
          heap_.emplace_back(c, u);
          std::push_heap(heap_.begin(), heap_.end(), greater);
        }
      }
    }
    if (added < n_) {
      Dense(pi, t);
      return;
    }
    for (int s = 0; s < n_; ++s) {
      if (t->degree[s] != 1) continue;
      Cost c2 = kInf;
      int to = -1;
      for (int e = g.first[s], end = g.first[s + 1]; e < end; ++e) {
        const int u = g.node[e];
        if (u == t->dad[s] || t->dad[u] == s) continue;
        const Cost c = g.pc[e] + pi[s] + pi[u];
        if (c < c2) {
          c2 = c;
          to = u;
        }
      }
      if (to >= 0) ConsiderSpecial(t, s, to, c2);
    }
    Finish(t);
  }

 private:
  void Init(OneTree* t) const {
    t->dad.assign(n_, -1);
    t->dad_cost.assign(n_, 0);
    t->order.clear();
    t->order.reserve(n_);
    t->degree.assign(n_, 0);
    t->special = t->special_to = -1;
    t->special_cost = -kInf;
    t->cost = 0;
  }
  static void Attach(OneTree* t, int v, int parent, Cost c) {
    t->dad[v] = parent;
    t->dad_cost[v] = c;
    t->order.push_back(v);
    ++t->degree[v];
    ++t->degree[parent];
    t->cost += c;
  }
  static void ConsiderSpecial(OneTree* t, int s, int to, Cost c) {
    if (to >= 0 && c > t->special_cost) {
      t->special = s;
      t->special_to = to;
      t->special_cost = c;
    }
  }
  static void Finish(OneTree* t) {
    if (t->special >= 0) {
      ++t->degree[t->special];
      ++t->degree[t->special_to];
      t->cost += t->special_cost;
    }
  }

  using Item = std::pair<Cost, int>;
  const CostCache& d_;
  const Cost p_;
  const int n_;
  mutable std::vector<Cost> key_;
  mutable std::vector<int> from_;
  mutable std::vector<char> in_;
  mutable std::vector<Item> heap_;
};

// Calls visit(a, b, alpha) for every pair a != b, in O(n^2) time and O(n) space.
template <typename Visit>
void ForAllAlpha(const OneTreeBuilder& b, const OneTree& t, const std::vector<Cost>& pi,
                 Visit visit) {
  const int n = static_cast<int>(t.dad.size());
  std::vector<Cost> beta(n);
  std::vector<int> mark(n, -1);
  // Edges at the special node: alpha = d - (larger of its two 1-tree edges).
  const int s = t.special;
  Cost s_max = 0;
  if (s >= 0) {
    // s is a leaf of the spanning tree; when it is the root its one edge goes to a child.
    Cost tree_edge = t.dad[s] >= 0 ? t.dad_cost[s] : -kInf;
    if (t.dad[s] < 0) {
      for (int c = 0; c < n; ++c)
        if (t.dad[c] == s) tree_edge = t.dad_cost[c];
    }
    s_max = std::max(tree_edge, t.special_cost);
  }
  auto in_tree = [&](int x, int y) {
    return t.dad[x] == y || t.dad[y] == x || (x == s && y == t.special_to) ||
           (y == s && x == t.special_to);
  };
  for (int a = 0; a < n; ++a) {
    if (a == s) {
      for (int c = 0; c < n; ++c) {
        if (c == a) continue;
        const Cost dac = b.C(a, c, pi);
        visit(a, c, in_tree(a, c) ? 0 : dac - s_max, dac);
      }
      continue;
    }
    beta[a] = -kInf;
    mark[a] = a;
    for (int u = a; t.dad[u] >= 0; u = t.dad[u]) {
      beta[t.dad[u]] = std::max(beta[u], t.dad_cost[u]);
      mark[t.dad[u]] = a;
    }
    for (int c : t.order) {
      if (c == a) continue;
      if (mark[c] != a) beta[c] = std::max(beta[t.dad[c]], t.dad_cost[c]);
      const Cost dac = b.C(a, c, pi);
      if (c == s) {
        visit(a, c, in_tree(a, c) ? 0 : dac - s_max, dac);
      } else {
        visit(a, c, dac - beta[c], dac);
      }
    }
  }
}

double Norm(const OneTree& t) {
  double norm = 0;
  for (int d : t.degree) norm += static_cast<double>(d - 2) * (d - 2);
  return norm;
}

Cost SumPi(const std::vector<Cost>& pi) {
  Cost s = 0;
  for (Cost p : pi) s += p;
  return s;
}

}  // namespace

CostCache::CostCache(const Problem& p, int dense_limit) : p_(p), n_(p.Size()) {
  if (n_ <= dense_limit) {
    dense_.resize(static_cast<size_t>(n_) * n_);
    for (int i = 0; i < n_; ++i)
      for (int j = 0; j < n_; ++j) dense_[static_cast<size_t>(i) * n_ + j] = p.Dist(i, j);
  }
}

AscentResult Ascent(const CostCache& d, const AscentOptions& opt) {
  const int n = d.Size();
  AscentResult res;
  res.pi.assign(n, 0);
  if (static_cast<int>(opt.initial_pi.size()) == n) res.pi = opt.initial_pi;
  if (n < 3) return res;
  OneTreeBuilder builder(d, opt.precision);
  OneTree tree;
  builder.Dense(res.pi, &tree);
  Cost w = tree.cost - 2 * SumPi(res.pi);
  Cost best_w = w;
  std::vector<Cost> best_pi = res.pi;
  double norm = Norm(tree);
  res.iterations = 1;
  if (norm == 0 || !opt.subgradient) {
    res.tour_found = norm == 0;
    res.lower_bound = static_cast<double>(best_w) / opt.precision;
    return res;
  }

  // Sparse graph for the rest of the ascent: the alpha-nearest neighbours, symmetrised,
  // with untransformed costs P*D (penalties are added on the fly).
  const bool large = n > kLargeAscentNodes;
  const int k = std::min(opt.ascent_candidates > 0 ? opt.ascent_candidates
                         : large                   ? kLargeAscentCandidates
                                                   : 50,
                         n - 1);
  SparseGraph graph;
  const bool use_sparse = n > 2 * k + 2;
  if (use_sparse) {
    std::vector<std::vector<std::pair<int, Cost>>> adj(n);
    std::vector<std::pair<Cost, int>> row;
    row.reserve(n);
    int current = -1;
    auto flush = [&](int a) {
      const size_t kk = std::min<size_t>(k, row.size());
      std::nth_element(row.begin(), row.begin() + (kk - 1), row.end());
      for (size_t i = 0; i < kk; ++i) {
        const int c = row[i].second;
        const Cost pc = static_cast<Cost>(opt.precision) * d.D(a, c);
        adj[a].emplace_back(c, pc);
        adj[c].emplace_back(a, pc);
      }
      row.clear();
    };
    ForAllAlpha(builder, tree, res.pi, [&](int a, int c, Cost alpha, Cost /*dac*/) {
      if (a != current) {
        if (current >= 0) flush(current);
        current = a;
      }
      row.emplace_back(alpha, c);
    });
    if (current >= 0) flush(current);
    graph.first.assign(n + 1, 0);
    for (int a = 0; a < n; ++a) {
      auto& list = adj[a];
      std::sort(list.begin(), list.end());
      list.erase(std::unique(list.begin(), list.end()), list.end());
      graph.first[a + 1] = graph.first[a] + static_cast<int>(list.size());
      for (const auto& [c, pc] : list) {
        graph.node.push_back(c);
        graph.pc.push_back(pc);
      }
      std::vector<std::pair<int, Cost>>().swap(list);
    }
  }
  auto compute = [&](const std::vector<Cost>& pi) {
    if (use_sparse) {
      builder.Sparse(graph, pi, &tree);
    } else {
      builder.Dense(pi, &tree);
    }
  };

  std::vector<int> last_v(n, 0);
  for (int i = 0; i < n; ++i) last_v[i] = tree.degree[i] - 2;
  const auto started = std::chrono::steady_clock::now();
  auto last_report = started;
  bool stopped = false;
  auto stop_now = [&]() {
    if (opt.progress) {
      const auto now = std::chrono::steady_clock::now();
      if (now - last_report > std::chrono::seconds(2)) {
        last_report = now;
        char line[160];
        std::snprintf(line, sizeof(line), "ascent: iteration %d, bound %.6g, %.1f s",
                      res.iterations, static_cast<double>(best_w) / opt.precision,
                      std::chrono::duration<double>(now - started).count());
        opt.progress(line);
      }
    }
    stopped = stopped || (opt.should_stop && opt.should_stop());
    return stopped;
  };
  const int initial_period = opt.initial_period > 0 ? opt.initial_period
                             : large                ? kLargeAscentPeriod
                                                    : std::max(n / 2, 100);
  Cost step = opt.precision;  // INITIAL_STEP_SIZE = 1, scaled by the precision
  bool initial_phase = true;
  for (int period = initial_period; period > 0 && step > 0 && norm != 0; period /= 2, step /= 2) {
    for (int p = 1; step > 0 && p <= period && norm != 0; ++p) {
      if (res.iterations >= opt.max_iterations || stop_now()) break;
      for (int i = 0; i < n; ++i) {
        const int v = tree.degree[i] - 2;
        if (v != 0) res.pi[i] += step * (7 * v + 3 * last_v[i]) / 10;
        last_v[i] = v;
      }
      compute(res.pi);
      ++res.iterations;
      w = tree.cost - 2 * SumPi(res.pi);
      norm = Norm(tree);
      if (w > best_w) {
        best_w = w;
        best_pi = res.pi;
        if (initial_phase && step * std::sqrt(norm) > 0) step *= 2;
        if (p == period && (period *= 2) > initial_period) period = initial_period;
      } else if (initial_phase && p > period / 2) {
        initial_phase = false;
        p = 0;
        step = 3 * step / 4;
      }
    }
    if (res.iterations >= opt.max_iterations || stopped) break;
  }
  res.pi = best_pi;
  res.tour_found = norm == 0 && w == best_w;
  res.lower_bound = static_cast<double>(best_w) / opt.precision;
  if (use_sparse) {
    // A 1-tree of the sparse graph may cost more than the true minimum 1-tree, so the bound
    // is taken from one 1-tree of the complete graph under the best penalties (O(n^2)).
    builder.Dense(best_pi, &tree);
    res.tour_found = Norm(tree) == 0;
    res.lower_bound = static_cast<double>(tree.cost - 2 * SumPi(best_pi)) / opt.precision;
  }
  return res;
}

CandidateSet AlphaCandidates(const CostCache& d, const std::vector<Cost>& pi, int precision,
                             int max_candidates,
                             const std::vector<std::pair<int, int>>& fixed_edges) {
  const int n = d.Size();
  CandidateSet cands(n);
  if (n < 2) return cands;
  OneTreeBuilder builder(d, precision);
  OneTree tree;
  builder.Dense(pi, &tree);
  const int k = std::min(max_candidates, n - 1);
  auto better = [](const Candidate& x, const Candidate& y) {
    return x.alpha != y.alpha ? x.alpha < y.alpha : x.cost < y.cost;
  };
  ForAllAlpha(builder, tree, pi, [&](int a, int c, Cost alpha, Cost dac) {
    auto& list = cands[a];
    const Candidate cand{c, dac, alpha};
    if (static_cast<int>(list.size()) == k && !better(cand, list.back())) return;
    auto it = std::upper_bound(list.begin(), list.end(), cand, better);
    list.insert(it, cand);
    if (static_cast<int>(list.size()) > k) list.pop_back();
  });
  for (const auto& [a, b] : fixed_edges) {
    for (auto [x, y] : {std::pair{a, b}, std::pair{b, a}}) {
      auto& list = cands[x];
      const int partner = y;  // C++17: a structured binding cannot be captured
      const bool has = std::any_of(list.begin(), list.end(),
                                   [partner](const Candidate& c) { return c.node == partner; });
      if (!has) list.insert(list.begin(), Candidate{y, builder.C(x, y, pi), 0});
    }
  }
  return cands;
}

}  // namespace mound::tsp
