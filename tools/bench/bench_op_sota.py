"""Benchmark (not a test): the planner's state-of-the-art heuristic (ALNS-OP, `mound_plan
--algo alns`) against newalg-ls and PyVRP 0.14 at equal time budgets, on random
orienteering instances of 50-1,000 sites (closed tours and start -> end paths).

PyVRP (hybrid genetic search / iterated local search) solves the OP as a prize-collecting
problem with one vehicle, `unit_distance_cost=0` and `max_distance` = the budget, on the
expanded edge costs c_ij = d_ij + (s_i + s_j)/2 rounded up to 0.1 mm (so its routes stay
within the budget in exact arithmetic) and rewards scaled by 10^6. Every route is checked
again here with the float costs. The reference of an instance is the best reward any
method reached at any time budget, or with --exact S the optimum that SCIP proves within
S seconds (instances of <= 100 sites); reported: the mean and the worst percentage of it
per method and budget, and how often each method is ahead.

    .venv/bin/python tools/bench/bench_op_sota.py [--sizes 50 100 ...] [--per-size 3]
                                                  [--times 0.2 0.5 1] [--seed 1] [--exact S]
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "python"))

from mound import native
from mound.plan.sites import OpProblem, from_document

COST_SCALE = 1e4    # PyVRP's integer distances: 0.1 mm
PRIZE_SCALE = 1e6


def random_instance(n: int, closed: bool, rng: np.random.Generator) -> dict:
    """Sites uniform in a 1 km square, rewards uniform in (0, 1], scan costs 0-20 m; the
    budget reaches about a third of the sites (a fraction of the TSP length estimate
    0.7124 sqrt(n A))."""
    side = 1000.0
    xy = rng.uniform(0, side, size=(n, 2))
    reward = rng.uniform(0.01, 1.0, size=n)
    scan = rng.uniform(0, 20.0, size=n)
    tsp = 0.7124 * math.sqrt(n * side * side) + scan.sum()
    doc = {"schema": "mound.sites", "version": 1,
           "home": {"id": "home", "x_m": side / 2, "y_m": side / 2},
           "budget_m": round(0.3 * tsp, 3),
           "sites": [{"id": f"s{i}", "x_m": float(x), "y_m": float(y), "reward": float(r),
                      "scan_cost_m": float(s)}
                     for i, ((x, y), r, s) in enumerate(zip(xy, reward, scan, strict=True))]}
    if not closed:
        doc["home"] = {"id": "start", "x_m": 0.0, "y_m": 0.0}
        doc["end"] = {"id": "end", "x_m": side, "y_m": side}
        doc["budget_m"] = round(max(doc["budget_m"], 1.2 * math.sqrt(2) * side), 3)
    return doc


def check(p: OpProblem, route: list[int]) -> float:
    """The reward of a route after an independent feasibility check (float costs)."""
    assert route[0] == 0 and route[-1] == p.end, route
    inner = route[1:-1]
    assert len(set(inner)) == len(inner) and all(v >= (1 if p.closed else 2) for v in inner)
    cost = p.route_cost(route)
    assert cost <= p.budget + 1e-6 * (1 + p.budget), (cost, p.budget)
    return float(p.reward[inner].sum())


def run_mound(path: Path, p: OpProblem, algo: str, seconds: float,
              routes: list[list[int]] | None = None) -> tuple[float, float]:
    plan = native.run_json("mound_plan", [str(path), "--algo", algo, "--time-limit",
                                          str(seconds), "--iterations", "1000000000"])
    index = {sid: i for i, sid in enumerate(p.ids)}
    route = [index[s] for s in plan["tour"]]
    if routes is not None:
        routes.append(route)
    return check(p, route), plan["elapsed_s"]


def proven_optimum(p: OpProblem, routes: list[list[int]], seconds: float) -> float | None:
    """SCIP branch-and-cut (mound.plan.branch_cut) warm-started from the best route found:
    the optimum when proven within `seconds`, else None."""
    from mound.plan import branch_cut

    best = max(routes, key=lambda r: float(p.reward[r[1:-1]].sum()))
    r = branch_cut.solve(p, seconds, start_route=best)
    if r.status != "optimal":
        return None
    return check(p, r.route)


class PyVrp:
    """The instance as a PyVRP model (built once; solve time counted without it)."""

    def __init__(self, p: OpProblem, vehicles: int = 1) -> None:
        from pyvrp import Model

        self.p = p
        self.vehicles = vehicles
        c = p.cost_matrix()
        m = Model()
        locs = [m.add_location(float(x), float(y)) for x, y in p.xy]
        home = m.add_depot(locs[0])
        end = home if p.closed else m.add_depot(locs[1])
        m.add_vehicle_type(num_available=vehicles, start_depot=home, end_depot=end,
                           max_distance=int(math.floor(p.budget * COST_SCALE)),
                           unit_distance_cost=0)
        first = 1 if p.closed else 2
        self.client_node = list(range(first, len(p.ids)))
        for v in self.client_node:
            m.add_client(locs[v], prize=int(round(p.reward[v] * PRIZE_SCALE)), required=False)
        ci = np.ceil(c * COST_SCALE).astype(np.int64)
        for i in range(len(locs)):
            for j in range(len(locs)):
                if i != j:
                    m.add_edge(locs[i], locs[j], distance=int(ci[i, j]))
        self.model = m

    def solve(self, seconds: float, seed: int) -> tuple[float, float]:
        routes, elapsed = self.solve_routes(seconds, seed)
        return (check(self.p, routes[0]) if routes else 0.0), elapsed

    def solve_routes(self, seconds: float, seed: int) -> tuple[list[list[int]], float]:
        """PyVRP's best solution as routes (node indices, home ... end); none when it is
        infeasible."""
        from pyvrp.stop import MaxRuntime

        t0 = time.perf_counter()
        res = self.model.solve(stop=MaxRuntime(seconds), seed=seed, display=False,
                               collect_stats=False)
        elapsed = time.perf_counter() - t0
        best = res.best
        if not best.is_feasible():
            return [], elapsed
        out = []
        for r in best.routes():
            out.append([0, *[self.client_node[a.idx] for a in r if a.is_client()], self.p.end])
        return out or [[0, self.p.end]], elapsed


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", nargs="+", type=int, default=[50, 100, 200, 500, 1000])
    ap.add_argument("--per-size", type=int, default=3, help="instances per size and kind")
    ap.add_argument("--times", nargs="+", type=float, default=[0.2, 0.5, 1.0])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--exact", type=float, default=0.0,
                    help="seconds for SCIP to prove the optimum of each instance of <= 100 "
                    "sites, which then is the reference (0: best known only)")
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    methods = ("alns", "newalg-ls", "pyvrp")
    rows: list[dict] = []
    proven = 0
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.sizes:
            for closed in (True, False):
                for k in range(args.per_size):
                    doc = random_instance(n, closed, rng)
                    path = Path(tmp) / f"n{n}_{'closed' if closed else 'path'}_{k}.json"
                    path.write_text(json.dumps(doc))
                    p = from_document(doc)
                    vrp = PyVrp(p)
                    got: dict[tuple[str, float], tuple[float, float]] = {}
                    routes: list[list[int]] = []
                    for t in args.times:
                        got["alns", t] = run_mound(path, p, "alns", t, routes)
                        got["newalg-ls", t] = run_mound(path, p, "newalg-ls", t, routes)
                        got["pyvrp", t] = vrp.solve(t, args.seed)
                    ref = max(r for r, _ in got.values())
                    kind = "best"
                    if args.exact > 0 and n <= 100:
                        opt = proven_optimum(p, routes, args.exact)
                        if opt is not None:
                            assert opt >= ref - 1e-9, (opt, ref)
                            ref, kind = opt, "opt"
                    proven += kind == "opt"
                    line = f"{path.stem:<18} {kind} {ref:9.4f}"
                    for t in args.times:
                        line += f" | {t:g}s " + " ".join(
                            f"{100 * got[m, t][0] / ref:6.2f}" for m in methods)
                        for m in methods:
                            rows.append({"n": n, "closed": closed, "t": t, "method": m,
                                         "pct": 100 * got[m, t][0] / ref,
                                         "seconds": got[m, t][1],
                                         "ahead_of_pyvrp": got[m, t][0] > got["pyvrp", t][0] + 1e-9,
                                         "behind_pyvrp": got[m, t][0] < got["pyvrp", t][0] - 1e-9})
                    print(line + f"   ({', '.join(methods)} % of ref)", flush=True)
    print(f"\nreference: the proven optimum on {proven} instances (SCIP), else the best "
          "reward any method reached")
    print(f"{'sites':>6} {'budget s':>8} {'method':<10} {'mean %':>7} {'min %':>7} "
          f"{'mean s':>7} {'> pyvrp':>8} {'< pyvrp':>8}")
    for n in args.sizes:
        for t in args.times:
            for m in methods:
                sel = [r for r in rows if r["n"] == n and r["t"] == t and r["method"] == m]
                print(f"{n:>6} {t:>8g} {m:<10} {statistics.mean(r['pct'] for r in sel):>7.2f} "
                      f"{min(r['pct'] for r in sel):>7.2f} "
                      f"{statistics.mean(r['seconds'] for r in sel):>7.3f} "
                      f"{sum(r['ahead_of_pyvrp'] for r in sel) if m != 'pyvrp' else '':>8} "
                      f"{sum(r['behind_pyvrp'] for r in sel) if m != 'pyvrp' else '':>8}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
