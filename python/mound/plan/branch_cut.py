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

Several flights (`flights=K`, the team orienteering problem): the same model per flight k
(x_e^k, y_i^k, a binary w_k that says flight k flies: home's degree 2 w_k, or w_k at home
and at the end node of a path), every site in at most one flight (sum_k y_i^k <= 1), the
budget per flight, the GSECs per flight, separated on each flight's LP values, and flights
ordered by reward (sum_i r_i y_i^k >= sum_i r_i y_i^(k+1)) against the symmetry.
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from pyscipopt import SCIP_PARAMSETTING, SCIP_RESULT, Conshdlr, Model, quicksum

from mound.plan.exact import (
    ExactResult,
    connected_components,
    flow_graph,
    min_cut_from_home,
    route_from_edges,
)
from mound.plan.sites import OpProblem


class _Gsec(Conshdlr):
    """The GSEC family as one constraint handler (needs no constraint objects)."""

    def __init__(self, bc: _Model) -> None:
        self.bc = bc

    def _violated_integral(self, sol: Any) -> list[tuple[int, frozenset[int]]]:
        out = []
        for f in range(self.bc.flights):
            comps = connected_components(self.bc.n, self.bc.used_edges(sol, f))
            out += [(f, frozenset(c)) for c in comps if 0 not in c]
        return out

    def conscheck(self, constraints: Any, solution: Any, checkintegrality: Any,
                  checklprows: Any, printreason: Any, completely: Any) -> dict:
        if self._violated_integral(solution):
            return {"result": SCIP_RESULT.INFEASIBLE}
        return {"result": SCIP_RESULT.FEASIBLE}

    def consenfolp(self, constraints: Any, nusefulconss: Any, solinfeasible: Any) -> dict:
        outside = self._violated_integral(None)
        if not outside:
            return {"result": SCIP_RESULT.FEASIBLE}
        for f, s in outside:
            for k in s:
                self.bc.add_gsec(s, k, as_cut=False, flight=f)
        return {"result": SCIP_RESULT.CONSADDED}

    def consenfops(self, constraints: Any, nusefulconss: Any, solinfeasible: Any,
                   objinfeasible: Any) -> dict:
        if self._violated_integral(None):
            return {"result": SCIP_RESULT.INFEASIBLE}
        return {"result": SCIP_RESULT.FEASIBLE}

    def conssepalp(self, constraints: Any, nusefulconss: Any) -> dict:
        bc = self.bc
        root = self.model.getDepth() == 0
        found = 0
        for f in range(bc.flights):
            xs = np.array([self.model.getSolVal(None, v) for v in bc.xf[f]])
            ys = np.zeros(bc.n)
            for i, v in bc.yf[f].items():
                ys[i] = self.model.getSolVal(None, v)
            for s, k in bc.separate(xs, ys, max_flows=bc.n if root else 20):
                if (s, k, f) not in bc.seen:
                    bc.add_gsec(s, k, as_cut=True, flight=f)
                    found += 1
        return {"result": SCIP_RESULT.SEPARATED if found else SCIP_RESULT.DIDNOTFIND}

    def conslock(self, constraint: Any, locktype: Any, nlockspos: Any, nlocksneg: Any) -> None:
        pass


class _Model:
    def __init__(self, p: OpProblem, time_limit_s: float, flights: int = 1) -> None:
        self.p = p
        self.flights = flights
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
        incident: dict[int, list[int]] = {v: [] for v in nodes}
        for k, (a, b) in enumerate(self.edges):
            incident[a].append(k)
            incident[b].append(k)
        # Per flight f: x_e^f, y_i^f (one flight: the paper's model, home's degree 2).
        self.xf: list[list[Any]] = []
        self.yf: list[dict[int, Any]] = []
        self.wf: list[Any] = []
        for f in range(flights):
            tag = "" if flights == 1 else f"_f{f}"
            x = []
            for a, b in self.edges:
                twice = p.closed and a == 0
                x.append(m.addVar(f"x_{a}_{b}{tag}", vtype="I" if twice else "B", lb=0,
                                  ub=2 if twice else 1))
            y = {v: m.addVar(f"y_{v}{tag}", vtype="B") for v in self.sites}
            fly = 1 if flights == 1 else m.addVar(f"w{tag}", vtype="B")
            self.wf.append(fly)
            for v in depots:
                m.addCons(quicksum(x[k] for k in incident[v]) == (2 if p.closed else 1) * fly)
            for v in self.sites:
                m.addCons(quicksum(x[k] for k in incident[v]) == 2 * y[v])
                if flights > 1:
                    m.addCons(y[v] <= fly)
            for k, (a, b) in enumerate(self.edges):
                for v in (a, b):
                    if v in y:
                        m.addCons(x[k] <= (2 if p.closed and a == 0 else 1) * y[v])
            m.addCons(quicksum(float(c[a, b]) * x[k] for k, (a, b) in enumerate(self.edges))
                      <= p.budget + tol)
            self.xf.append(x)
            self.yf.append(y)
        for v in self.sites:
            if flights > 1:
                m.addCons(quicksum(self.yf[f][v] for f in range(flights)) <= 1)
        reward = [quicksum(float(p.reward[v]) * y for v, y in self.yf[f].items())
                  for f in range(flights)]
        for f in range(flights - 1):  # flights ordered by reward: no symmetric copies
            m.addCons(reward[f] >= reward[f + 1])
        m.setObjective(quicksum(reward), "maximize")
        self.seen: set[tuple[frozenset[int], int, int]] = set()
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
        for comp in connected_components(n, support):
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
        order = [v for v in sorted(self.sites, key=lambda v: -ys[v]) if ys[v] > tol]
        for k in order[:max_flows]:
            if k in covered:
                continue
            value, s = min_cut_from_home(graph, k)
            if value >= 2 * ys[k] - tol:
                continue
            best = max(s & set(self.sites), key=lambda v: ys[v])
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

    def add_gsec(self, s: frozenset[int], k: int, as_cut: bool, flight: int = 0) -> None:
        """x(delta(S)) >= 2 y_k, minus 1 when S holds the end node of a path (of one
        flight)."""
        self.seen.add((s, k, flight))
        self.cuts += 1
        delta = np.flatnonzero(self._crossing(s)).tolist()
        lhs = self._lhs(s)
        m = self.m
        x, y = self.xf[flight], self.yf[flight]
        if not as_cut:
            m.addCons(quicksum(x[i] for i in delta) - 2 * y[k] >= lhs)
            return
        row = m.createEmptyRowUnspec(f"gsec{self.cuts}", lhs=lhs, rhs=None, local=False,
                                     modifiable=False, removable=True)
        m.cacheRowExtensions(row)
        for i in delta:
            m.addVarToRow(row, x[i], 1.0)
        m.addVarToRow(row, y[k], -2.0)
        m.flushRowExtensions(row)
        m.addCut(row, forcecut=False)
        m.addPoolCut(row)

    def warm_start(self, routes: list[list[int]]) -> bool:
        """One route per flight (fewer: the rest do not fly)."""
        index = {e: k for k, e in enumerate(self.edges)}
        sol = self.m.createSol()
        for f in range(self.flights):
            route = routes[f] if f < len(routes) else []
            counts: dict[int, int] = {}
            for a, b in itertools.pairwise(route):
                k = index.get((min(a, b), max(a, b)))
                if k is None:
                    return False
                counts[k] = counts.get(k, 0) + 1
            for k, var in enumerate(self.xf[f]):
                self.m.setSolVal(sol, var, counts.get(k, 0))
            visited = set(route)
            for v, var in self.yf[f].items():
                self.m.setSolVal(sol, var, 1.0 if v in visited else 0.0)
            if self.flights > 1:
                flies = len(route) > 2 or (not self.p.closed and len(route) == 2)
                self.m.setSolVal(sol, self.wf[f], 1.0 if flies else 0.0)
        return bool(self.m.addSol(sol, free=True))

    def used_edges(self, sol: Any, flight: int = 0) -> list[tuple[int, int]]:
        """The edges of an integer solution (sol None: the LP's), each as often as used."""
        used = []
        for k, e in enumerate(self.edges):
            used += [e] * max(0, round(self.m.getSolVal(sol, self.xf[flight][k])))
        return used

    def route_of(self, sol: Any, flight: int = 0) -> list[int]:
        used = self.used_edges(sol, flight)
        home = next((comp for comp in connected_components(self.n, used) if 0 in comp), [0])
        return route_from_edges(self.n, [e for e in used if e[0] in home], self.p.closed,
                                self.p.end)


def solve(p: OpProblem, time_limit_s: float = 60.0,
          start_route: list[int] | None = None) -> ExactResult:
    """The proven optimum (status "optimal"), or on the time limit the best route found
    and SCIP's dual bound (status "time_limit")."""
    r = solve_flights(p, 1, time_limit_s, [start_route] if start_route is not None else None)
    return ExactResult(status=r.status, reward=r.reward, bound=r.bound, route=r.routes[0],
                       cost=r.costs[0], cuts=r.cuts, rounds=r.rounds, seconds=r.seconds,
                       gap=r.gap)


@dataclass
class FlightsResult:
    status: str                # "optimal" or "time_limit"
    reward: float              # of all flights returned (each feasible)
    bound: float
    routes: list[list[int]]    # ordered by reward
    costs: list[float]
    cuts: int
    rounds: int
    seconds: float
    gap: float = 0.0


def solve_flights(p: OpProblem, flights: int, time_limit_s: float = 60.0,
                  start_routes: list[list[int]] | None = None) -> FlightsResult:
    """K flights: the proven optimum of the team orienteering problem (status "optimal"),
    or on the time limit the best flights found and SCIP's dual bound."""
    start = time.perf_counter()
    bc = _Model(p, time_limit_s, flights)
    empty = [0, p.end]
    if not bc.sites:
        routes = [empty] * flights
        return FlightsResult("optimal", 0.0, 0.0, routes, [p.route_cost(r) for r in routes],
                             0, 0, time.perf_counter() - start)
    if start_routes is not None and all(p.route_cost(r) <= p.budget + 1e-9
                                        for r in start_routes):
        # A good first solution (ALNS-OP's is nearly always optimal) leaves SCIP's primal
        # heuristics little to find; without them the proof is about a quarter faster.
        ordered = sorted(start_routes, key=lambda r: -float(
            sum(p.reward[v] for v in set(r[1:-1]))))
        if bc.warm_start(ordered):
            bc.m.setHeuristics(SCIP_PARAMSETTING.OFF)
    bc.m.optimize()
    status = "optimal" if bc.m.getStatus() == "optimal" else "time_limit"
    routes = [empty] * flights
    if bc.m.getNSols() > 0:
        sol = bc.m.getBestSol()
        routes = [bc.route_of(sol, f) for f in range(flights)]
    first = 1 if p.closed else 2
    reward = float(sum(p.reward[v] for r in routes for v in set(r) if v >= first))
    bound = reward if status == "optimal" else float(bc.m.getDualbound())
    return FlightsResult(status=status, reward=reward, bound=bound, routes=routes,
                         costs=[p.route_cost(r) for r in routes], cuts=bc.cuts,
                         rounds=int(bc.m.getNNodes()), seconds=time.perf_counter() - start,
                         gap=(bound - reward) / bound if bound > 0 else 0.0)
