"""Exact orienteering by integer programming (HiGHS), subtour cuts added lazily.

Eq. (4), the paper's integer programme for the tour, in its undirected form
(solve() below); the model on nodes 0..n-1 (0 = home, 1 = end of a path):
  max  sum_i r_i y_i
  s.t. sum_{e in delta(i)} x_e = 2 y_i   for every site i; 2 at home of a closed tour
       (a path: degree 1 at home and at the end node)
       sum_e c_e x_e <= B
       x(delta(S)) >= 2 y_k   for every S with home not in S and k in S  (GSEC; for a path
                         whose end node is in S the right side is 2 y_k - 1)
  x_e in {0, 1} (edges at home of a closed tour in {0, 1, 2}: a tour to one site), y binary.
The GSECs are added lazily. First the LP relaxation is cut until no GSEC is violated:
components of the support graph, then for every visited site k a maximum flow from home to
k (scipy) whose minimum cut S gives x(delta(S)) >= 2 y_k when violated. Then the integer
programme is solved (warm-started from a heuristic route if one is given), the connected
components of its solution give further cuts, and it is solved again until the solution is
one route. HiGHS's dual bound of every relaxed problem is a valid upper bound; on a time
limit the best bound and the best feasible route seen are returned instead of a proof.
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass, field

import highspy
import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import breadth_first_order, maximum_flow

from mound.plan.sites import OpProblem


@dataclass
class ExactResult:
    status: str              # "optimal" or "time_limit"
    reward: float            # of the route returned (feasible)
    bound: float             # upper bound on the optimum
    route: list[int]
    cost: float
    cuts: int
    rounds: int
    seconds: float
    gap: float = field(default=0.0)


def connected_components(n: int, edges: list[tuple[int, int]]) -> list[list[int]]:
    parent = list(range(n))

    def find(a: int) -> int:
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for a, b in edges:
        parent[find(a)] = find(b)
    groups: dict[int, list[int]] = {}
    for v in {v for e in edges for v in e}:
        groups.setdefault(find(v), []).append(v)
    return list(groups.values())


def route_from_edges(n: int, edges: list[tuple[int, int]], closed: bool, end: int) -> list[int]:
    """Walks the used edges from home (to the end node of a path)."""
    adj: dict[int, list[int]] = {}
    for a, b in edges:
        adj.setdefault(a, []).append(b)
        adj.setdefault(b, []).append(a)
    if not adj.get(0):
        return [0, end]
    route, prev, cur = [0], -1, 0
    while True:
        nxt = [v for v in adj[cur] if v != prev]
        if not nxt or (closed and nxt[0] == 0):
            break
        prev, cur = cur, nxt[0]
        route.append(cur)
        if cur == end and not closed:
            break
        if len(route) > n + 1:
            break
    if closed:
        route.append(0)
    return route


FLOW_SCALE = 1_000_000  # LP values as integer capacities for scipy's maximum flow


def flow_graph(n: int, edges: list[tuple[int, int]], x: np.ndarray,
               closed: bool) -> csr_matrix:
    """The support graph of an LP point with capacities x_e (scaled to integers). A path
    is a cycle with a virtual end->home edge of value 1."""
    rows, cols, caps = ([0, 1], [1, 0], [FLOW_SCALE, FLOW_SCALE]) if not closed else ([], [], [])
    for k, (a, b) in enumerate(edges):
        cap = round(x[k] * FLOW_SCALE)
        if cap > 0:
            rows += [a, b]
            cols += [b, a]
            caps += [cap, cap]
    return csr_matrix((np.array(caps, dtype=np.int32), (rows, cols)), shape=(n, n))


def min_cut_from_home(graph: csr_matrix, k: int) -> tuple[float, frozenset[int]]:
    """The maximum flow value home -> k (in LP units) and the sink side S of a minimum cut."""
    n = graph.shape[0]
    flow = maximum_flow(graph, 0, k)
    residual = (graph - flow.flow).tocsr()
    residual.data = np.where(residual.data > 0, residual.data, 0)
    residual.eliminate_zeros()
    source_side = set(breadth_first_order(residual, 0, directed=True,
                                          return_predecessors=False).tolist())
    return flow.flow_value / FLOW_SCALE, frozenset(set(range(n)) - source_side)


def _min_cut_sets(n: int, edges: list[tuple[int, int]], x: np.ndarray, y: np.ndarray,
                  closed: bool, tol: float = 1e-6) -> list[tuple[frozenset[int], int]]:
    """Violated GSECs of a fractional point: (S, k) with x(delta(S)) < 2 y_k - tol."""
    graph = flow_graph(n, edges, x, closed)
    found: list[tuple[frozenset[int], int]] = []
    for k in range(1, n):
        if y[k] <= tol:
            continue
        value, s = min_cut_from_home(graph, k)
        if value < 2 * y[k] - tol:
            found.append((s, k))
    return found


class _CutModel:
    """The OP as a HiGHS model: columns x_e (the edges, `edges`), then y_i (a site
    visited); degree rows, the budget row, and the GSECs added as cuts."""

    def __init__(self, p: OpProblem, mip_gap: float) -> None:
        self.p = p
        self.n = n = len(p.ids)
        c = p.cost_matrix()
        self.edges = edges = list(itertools.combinations(range(n), 2))
        self.ne = ne = len(edges)
        self.h = h = highspy.Highs()
        h.setOptionValue("output_flag", False)
        h.setOptionValue("mip_rel_gap", mip_gap)
        lower = np.zeros(ne + n)
        upper = np.ones(ne + n)
        if p.closed:
            for k, (a, _b) in enumerate(edges):
                if a == 0:
                    upper[k] = 2.0
        fixed = [0] if p.closed else [0, 1]
        for v in fixed:
            lower[ne + v] = 1.0
        h.addVars(ne + n, lower, upper)
        self.all_cols = np.arange(ne + n, dtype=np.int32)
        h.changeColsCost(ne + n, self.all_cols, np.concatenate([np.zeros(ne), p.reward]))
        self.integer(True)
        h.changeObjectiveSense(highspy.ObjSense.kMaximize)
        incident: list[list[int]] = [[] for _ in range(n)]
        for k, (a, b) in enumerate(edges):
            incident[a].append(k)
            incident[b].append(k)
        for i in range(n):
            if i in fixed:
                deg = 2.0 if p.closed else 1.0
                self.add_row(deg, deg, incident[i], [1.0] * len(incident[i]))
            else:
                self.add_row(0.0, 0.0, [*incident[i], ne + i], [1.0] * len(incident[i]) + [-2.0])
        self.add_row(-highspy.kHighsInf, p.budget + 1e-9 * (1 + p.budget), list(range(ne)),
                     [float(c[a, b]) for a, b in edges])
        self.cuts = 0

    def integer(self, on: bool) -> None:
        kind = highspy.HighsVarType.kInteger if on else highspy.HighsVarType.kContinuous
        self.h.changeColsIntegrality(self.ne + self.n, self.all_cols,
                                     np.array([kind] * (self.ne + self.n)))

    def add_row(self, lo: float, hi: float, idx: list[int], val: list[float]) -> None:
        self.h.addRow(lo, hi, len(idx), np.array(idx, dtype=np.int32),
                      np.array(val, dtype=float))

    def add_gsec(self, s: frozenset[int], v: int) -> None:
        # x(delta(S)) >= 2 y_v; for a path whose end node is in S the virtual end->home
        # edge crosses the cut, so the real edges need only 2 y_v - 1.
        delta = [k for k, (a, b) in enumerate(self.edges) if (a in s) != (b in s)]
        lo = -1.0 if (not self.p.closed and 1 in s) else 0.0
        self.add_row(lo, highspy.kHighsInf, [*delta, self.ne + v], [1.0] * len(delta) + [-2.0])
        self.cuts += 1

    def cut_lp(self, until: float) -> float:
        """The LP phase: the relaxation cut until no GSEC is violated (or the clock reaches
        `until`); returns its optimum, an upper bound on the integer optimum."""
        h = self.h
        self.integer(False)
        seen_cuts: set[tuple[frozenset[int], int]] = set()
        lp_bound = float("inf")
        while time.perf_counter() < until:
            h.setOptionValue("time_limit", max(1e-3, until - time.perf_counter()))
            h.run()
            sol = np.asarray(h.getSolution().col_value)
            if sol.size == 0 or h.getModelStatus() != highspy.HighsModelStatus.kOptimal:
                break
            lp_bound = min(lp_bound, float(h.getInfo().objective_function_value))
            new = [cut for cut in _min_cut_sets(self.n, self.edges, sol[:self.ne],
                                                sol[self.ne:], self.p.closed)
                   if cut not in seen_cuts]
            if not new:
                break
            for s_set, v in new:
                self.add_gsec(s_set, v)
                seen_cuts.add((s_set, v))
        self.integer(True)
        return lp_bound

    def warm_start(self, route: list[int]) -> None:
        warm = np.zeros(self.ne + self.n)
        index = {e: k for k, e in enumerate(self.edges)}
        for a, b in itertools.pairwise(route):
            warm[index[(min(a, b), max(a, b))]] += 1
        for v in set(route):
            warm[self.ne + v] = 1
        hs = highspy.HighsSolution()
        hs.col_value = warm.tolist()
        self.h.setSolution(hs)


def solve(p: OpProblem, time_limit_s: float = 60.0, mip_gap: float = 1e-9,
          start_route: list[int] | None = None) -> ExactResult:
    start = time.perf_counter()
    m = _CutModel(p, mip_gap)
    h, n, ne, edges = m.h, m.n, m.ne, m.edges
    lp_bound = m.cut_lp(start + time_limit_s / 2)
    best_route: list[int] = [0, p.end]
    if start_route is not None and p.route_cost(start_route) <= p.budget + 1e-9:
        best_route = list(start_route)
        m.warm_start(best_route)
    bound = lp_bound
    route: list[int] = [0, p.end]
    status = "optimal"
    rounds = 0
    while True:
        rounds += 1
        remaining = time_limit_s - (time.perf_counter() - start)
        if remaining <= 0:
            status = "time_limit"
            break
        h.setOptionValue("time_limit", remaining)
        h.run()
        info = h.getInfo()
        if np.isfinite(info.mip_dual_bound):
            bound = min(bound, float(info.mip_dual_bound))
        if h.getModelStatus() != highspy.HighsModelStatus.kOptimal:
            status = "time_limit"
        x = np.asarray(h.getSolution().col_value)
        if x.size == 0:
            break
        used = [edges[k] for k in range(ne) for _ in range(round(x[k]))]
        comps = connected_components(n, used)
        home_comp = next((comp for comp in comps if 0 in comp), [0])
        route = route_from_edges(n, [e for e in used if e[0] in home_comp], p.closed, p.end)
        if status != "optimal":
            break
        outside = [comp for comp in comps if 0 not in comp]
        if not outside:
            break
        for comp in outside:
            for v in comp:
                m.add_gsec(frozenset(comp), v)

    def reward_of(r: list[int]) -> float:
        return float(sum(p.reward[v] for v in set(r)))

    if status != "optimal" and reward_of(best_route) > reward_of(route):
        route = best_route  # the warm start beats the home component of the last solution
    reward = reward_of(route)
    if status == "optimal":
        bound = reward
    return ExactResult(status=status, reward=reward, bound=bound, route=route,
                       cost=p.route_cost(route), cuts=m.cuts, rounds=rounds,
                       seconds=time.perf_counter() - start,
                       gap=(bound - reward) / bound if bound > 0 else 0.0)
