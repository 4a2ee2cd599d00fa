"""Exact orienteering by branch-and-cut in SCIP (PyPI pyscipopt): the paper's integer
programme (eq. 4) in its undirected form with the generalised subtour elimination
constraints (GSECs) separated inside the search by a constraint handler.

Model on nodes 0..n-1 (0 = home, 1 = the end node of a path), edges e = {i, j}:
  max  sum_i r_i y_i
  s.t. x(delta(i)) = 2 y_i                  every site i (home: 2 for a closed tour; a
                                            path: 1 at home and 1 at the end node)
       sum_e c_e x_e <= B                   the budget, expanded edge costs
       x_e <= y_i, x_e <= y_j               logical cuts (x_e <= 2 y_j at home of a closed
                                            tour, where a tour to one site uses its edge twice)
       x(delta(S)) >= 2 y_k (- 1)           GSEC, S without home, k in S (the -1 when S holds
                                            the end node of a path), separated lazily:
                                            on integer points by connected components, on
                                            fractional LP points by a maximum flow from home
                                            to every visited site (minimum cut S)
  x_e in {0, 1} ({0, 1, 2} at home of a closed tour), y binary.
Before the model is built, sites that cannot be reached within the budget (c(home, i) +
c(i, end) > B) and edges that no route within the budget can use (c(home, i) + c_ij +
c(j, end) > B in both directions) are left out. SCIP's dual reductions are switched off,
since the GSECs are not in the model when it presolves. A heuristic route (the caller's
or `mound_plan --algo alns`) is given as the first solution, and SCIP's primal heuristics
are then switched off.
"""

from __future__ import annotations

import itertools
import time
from typing import Any

import numpy as np
from pyscipopt import SCIP_PARAMSETTING, SCIP_RESULT, Conshdlr, Model, quicksum

from mound.plan.exact import ExactResult, _components, _route_of, flow_graph, min_cut_from_home
from mound.plan.sites import OpProblem


class _Gsec(Conshdlr):
    """The GSEC family as one constraint handler (needs no constraint objects)."""

    def __init__(self, bc: _Model) -> None:
        self.bc = bc

    def _violated_integral(self, sol: Any) -> list[frozenset[int]]:
        comps = _components(self.bc.n, self.bc.used_edges(sol))
        return [frozenset(c) for c in comps if 0 not in c]

    def conscheck(self, constraints: Any, solution: Any, checkintegrality: Any,
                  checklprows: Any, printreason: Any, completely: Any) -> dict:
        if self._violated_integral(solution):
            return {"result": SCIP_RESULT.INFEASIBLE}
        return {"result": SCIP_RESULT.FEASIBLE}

    def consenfolp(self, constraints: Any, nusefulconss: Any, solinfeasible: Any) -> dict:
        outside = self._violated_integral(None)
        if not outside:
            return {"result": SCIP_RESULT.FEASIBLE}
        for s in outside:
            for k in s:
                self.bc.add_gsec(s, k, as_cut=False)
        return {"result": SCIP_RESULT.CONSADDED}

    def consenfops(self, constraints: Any, nusefulconss: Any, solinfeasible: Any,
                   objinfeasible: Any) -> dict:
        if self._violated_integral(None):
            return {"result": SCIP_RESULT.INFEASIBLE}
        return {"result": SCIP_RESULT.FEASIBLE}

    def conssepalp(self, constraints: Any, nusefulconss: Any) -> dict:
        bc = self.bc
        xs = np.array([self.model.getSolVal(None, v) for v in bc.x])
        ys = np.zeros(bc.n)
        for i, v in bc.y.items():
            ys[i] = self.model.getSolVal(None, v)
        root = self.model.getDepth() == 0
        found = 0
        for s, k in bc.separate(xs, ys, max_flows=bc.n if root else 20):
            if (s, k) not in bc.seen:
                bc.add_gsec(s, k, as_cut=True)
                found += 1
        return {"result": SCIP_RESULT.SEPARATED if found else SCIP_RESULT.DIDNOTFIND}

    def conslock(self, constraint: Any, locktype: Any, nlockspos: Any, nlocksneg: Any) -> None:
        pass


class _Model:
    def __init__(self, p: OpProblem, time_limit_s: float) -> None:
        self.p = p
        self.n = n = len(p.ids)
        c = p.cost_matrix()
        end = p.end
        tol = 1e-9 * (1 + p.budget)
        first = 1 if p.closed else 2
        via = c[0, :] + c[:, end]  # the cheapest route through one node
        self.sites = [v for v in range(first, n) if via[v] <= p.budget + tol]
        depots = [0] if p.closed else [0, 1]
        nodes = depots + self.sites
        self.edges: list[tuple[int, int]] = []
        for a, b in itertools.combinations(sorted(nodes), 2):
            through = c[a, b] + min(c[0, a] + c[b, end], c[0, b] + c[a, end])
            if through <= p.budget + tol:
                self.edges.append((a, b))
        self.ea = np.array([a for a, _ in self.edges], dtype=np.int64)
        self.eb = np.array([b for _, b in self.edges], dtype=np.int64)
        m = Model("mound_op")
        m.hideOutput()
        m.setParam("limits/time", max(0.01, time_limit_s))
        m.setParam("misc/allowstrongdualreds", False)
        m.setParam("misc/allowweakdualreds", False)
        self.m = m
        self.x = []
        for a, b in self.edges:
            twice = p.closed and a == 0
            self.x.append(m.addVar(f"x_{a}_{b}", vtype="I" if twice else "B", lb=0,
                                   ub=2 if twice else 1))
        self.y = {v: m.addVar(f"y_{v}", vtype="B") for v in self.sites}
        incident: dict[int, list[int]] = {v: [] for v in nodes}
        for k, (a, b) in enumerate(self.edges):
            incident[a].append(k)
            incident[b].append(k)
        for v in depots:
            m.addCons(quicksum(self.x[k] for k in incident[v]) == (2 if p.closed else 1))
        for v in self.sites:
            m.addCons(quicksum(self.x[k] for k in incident[v]) == 2 * self.y[v])
        for k, (a, b) in enumerate(self.edges):
            for v in (a, b):
                if v in self.y:
                    m.addCons(self.x[k] <= (2 if p.closed and a == 0 else 1) * self.y[v])
        m.addCons(quicksum(float(c[a, b]) * self.x[k] for k, (a, b) in enumerate(self.edges))
                  <= p.budget + tol)
        m.setObjective(quicksum(float(p.reward[v]) * y for v, y in self.y.items()), "maximize")
        self.seen: set[tuple[frozenset[int], int]] = set()
        self.cuts = 0
        self.handler = _Gsec(self)
        m.includeConshdlr(self.handler, "gsec", "generalised subtour elimination",
                          sepapriority=100, enfopriority=-100, chckpriority=-100,
                          sepafreq=1, needscons=False)

    def separate(self, xs: np.ndarray, ys: np.ndarray, max_flows: int,
                 tol: float = 1e-4) -> list[tuple[frozenset[int], int]]:
        """Violated GSECs of an LP point: first the connected components of its support
        that miss home (cheap), and only if there are none, minimum cuts from maximum
        flows home -> k for the sites k of largest y_k (at most max_flows of them).
        Each cut is returned for the site of S with the largest y_k."""
        n = self.n
        support = [self.edges[k] for k in np.flatnonzero(xs > 1e-6)]
        found: list[tuple[frozenset[int], int]] = []
        for comp in _components(n, support):
            if 0 in comp:
                continue
            s = frozenset(comp)
            k = max(comp, key=lambda v: ys[v])
            if self._violation(s, k, xs, ys) > tol:
                found.append((s, k))
        if found or max_flows <= 0:
            return found
        graph = flow_graph(n, self.edges, xs, self.p.closed)
        covered: set[int] = set()
        order = [v for v in sorted(self.y, key=lambda v: -ys[v]) if ys[v] > tol]
        for k in order[:max_flows]:
            if k in covered:
                continue
            value, s = min_cut_from_home(graph, k)
            if value >= 2 * ys[k] - tol:
                continue
            best = max(s & self.y.keys(), key=lambda v: ys[v])
            if self._violation(s, best, xs, ys) > tol:
                found.append((s, best))
                covered |= s
        return found

    def _crossing(self, s: frozenset[int]) -> np.ndarray:
        """Which edges cross the cut delta(S)."""
        inside = np.zeros(self.n, dtype=bool)
        inside[list(s)] = True
        return inside[self.ea] != inside[self.eb]

    def _lhs(self, s: frozenset[int]) -> float:
        """The GSEC's constant: -1 when S holds the end node of a path."""
        return -1.0 if (not self.p.closed and 1 in s) else 0.0

    def _violation(self, s: frozenset[int], k: int, xs: np.ndarray, ys: np.ndarray) -> float:
        return 2 * ys[k] + self._lhs(s) - float(xs[self._crossing(s)].sum())

    def add_gsec(self, s: frozenset[int], k: int, as_cut: bool) -> None:
        """x(delta(S)) >= 2 y_k, minus 1 when S holds the end node of a path."""
        self.seen.add((s, k))
        self.cuts += 1
        delta = np.flatnonzero(self._crossing(s)).tolist()
        lhs = self._lhs(s)
        m = self.m
        if not as_cut:
            m.addCons(quicksum(self.x[i] for i in delta) - 2 * self.y[k] >= lhs)
            return
        row = m.createEmptyRowUnspec(f"gsec{self.cuts}", lhs=lhs, rhs=None, local=False,
                                     modifiable=False, removable=True)
        m.cacheRowExtensions(row)
        for i in delta:
            m.addVarToRow(row, self.x[i], 1.0)
        m.addVarToRow(row, self.y[k], -2.0)
        m.flushRowExtensions(row)
        m.addCut(row, forcecut=False)
        m.addPoolCut(row)

    def warm_start(self, route: list[int]) -> bool:
        index = {e: k for k, e in enumerate(self.edges)}
        sol = self.m.createSol()
        counts: dict[int, int] = {}
        for a, b in itertools.pairwise(route):
            k = index.get((min(a, b), max(a, b)))
            if k is None:
                return False
            counts[k] = counts.get(k, 0) + 1
        for k, var in enumerate(self.x):
            self.m.setSolVal(sol, var, counts.get(k, 0))
        visited = set(route)
        for v, var in self.y.items():
            self.m.setSolVal(sol, var, 1.0 if v in visited else 0.0)
        return bool(self.m.addSol(sol, free=True))

    def used_edges(self, sol: Any) -> list[tuple[int, int]]:
        """The edges of an integer solution (sol None: the LP's), each as often as used."""
        used = []
        for k, e in enumerate(self.edges):
            used += [e] * max(0, round(self.m.getSolVal(sol, self.x[k])))
        return used

    def route_of(self, sol: Any) -> list[int]:
        used = self.used_edges(sol)
        home = next((comp for comp in _components(self.n, used) if 0 in comp), [0])
        return _route_of(self.n, [e for e in used if e[0] in home], self.p.closed, self.p.end)


def solve(p: OpProblem, time_limit_s: float = 60.0,
          start_route: list[int] | None = None) -> ExactResult:
    """The proven optimum (status "optimal"), or on the time limit the best route found
    and SCIP's dual bound (status "time_limit")."""
    start = time.perf_counter()
    bc = _Model(p, time_limit_s)
    if not bc.sites:
        route = [0, p.end]
        return ExactResult(status="optimal", reward=0.0, bound=0.0, route=route,
                           cost=p.route_cost(route), cuts=0, rounds=0,
                           seconds=time.perf_counter() - start)
    if start_route is not None and p.route_cost(start_route) <= p.budget + 1e-9:
        # A good first route (ALNS-OP's is nearly always optimal) leaves SCIP's primal
        # heuristics little to find; without them the proof is about a quarter faster.
        if bc.warm_start(start_route):
            bc.m.setHeuristics(SCIP_PARAMSETTING.OFF)
    bc.m.optimize()
    status = "optimal" if bc.m.getStatus() == "optimal" else "time_limit"
    route = [0, p.end]
    if bc.m.getNSols() > 0:
        route = bc.route_of(bc.m.getBestSol())
    reward = float(sum(p.reward[v] for v in set(route) if v >= (1 if p.closed else 2)))
    bound = reward if status == "optimal" else float(bc.m.getDualbound())
    return ExactResult(status=status, reward=reward, bound=bound, route=route,
                       cost=p.route_cost(route), cuts=bc.cuts,
                       rounds=int(bc.m.getNNodes()), seconds=time.perf_counter() - start,
                       gap=(bound - reward) / bound if bound > 0 else 0.0)
