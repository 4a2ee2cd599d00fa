"""Benchmark (not a test): several flights (the team orienteering problem), `mound_plan
--flights K` against PyVRP 0.14 with K vehicles, at equal time, in one run.

ALNS-OP on K routes (`--algo alns`, the default) runs first with `--time-limit T`; PyVRP
(hybrid genetic search) then gets the time ALNS actually took, on the same instance as a
prize-collecting problem with `num_available=K`, `max_distance` = the per-flight budget and
`unit_distance_cost=0`, on the same expanded costs c_ij = d_ij + (s_i + s_j)/2 (rounded up
to 0.1 mm, so its routes stay within the budget in exact arithmetic; bench_op_sota.PyVrp).
The paper's baseline, NewAlg flight by flight (`--algo newalg --flights K`), runs too.
Every plan is checked again here: each flight within the budget with float costs, no site
in two flights.

Instances: random fields of 100-1,000 sites in a 1 km square (rewards in (0, 1], scan
costs 0-20 m, home in the centre; the per-flight budget a fraction of the TSP estimate
over K, so that the K flights together reach about 45 % of the sites), and the ten
standard fields of Table I (100 sites, 1 m apart, node cost 1 m) at budgets 40 and 80 m.
Small instances (12 sites) against the exact optimum of `--algo exact --flights K`
(Held-Karp over subsets, a proof); with `--exact S`, medium ones (`--medium 30 40`) against
the optimum SCIP's branch-and-cut for K flights proves within S seconds (mound.plan.
branch_cut.solve_flights, warm-started from the ALNS flights), else left out.

    .venv/bin/python tools/bench/bench_flights.py [--sizes 100 200 500 1000] [--flights 2 3 5]
        [--per-size 2] [--time 1] [--fields] [--small 20] [--exact S --medium 30 40]
        [--seed 1]
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "python"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_op_sota import PyVrp, check

from mound import native
from mound.plan.sites import OpProblem, from_document


def random_instance(n: int, flights: int, rng: np.random.Generator,
                    fraction: float = 0.45) -> dict:
    side = 1000.0
    xy = rng.uniform(0, side, size=(n, 2))
    reward = rng.uniform(0.01, 1.0, size=n)
    scan = rng.uniform(0, 20.0, size=n)
    tsp = 0.7124 * math.sqrt(n * side * side) + scan.sum()
    return {"schema": "mound.sites", "version": 1,
            "home": {"id": "home", "x_m": side / 2, "y_m": side / 2},
            "budget_m": round(fraction * tsp / flights, 3),
            "sites": [{"id": f"s{i}", "x_m": float(x), "y_m": float(y), "reward": float(r),
                       "scan_cost_m": float(s)}
                      for i, ((x, y), r, s) in enumerate(zip(xy, reward, scan, strict=True))]}


def check_flights(p: OpProblem, routes: list[list[int]]) -> float:
    seen: set[int] = set()
    total = 0.0
    for r in routes:
        total += check(p, r)
        inner = set(r[1:-1])
        assert not inner & seen, "a site in two flights"
        seen |= inner
    return total


def run_mound(path: Path, p: OpProblem, algo: str, flights: int,
              seconds: float) -> tuple[float, float]:
    plan = native.run_json("mound_plan", [str(path), "--algo", algo, "--flights", str(flights),
                                          "--time-limit", str(seconds)])
    index = {sid: i for i, sid in enumerate(p.ids)}
    routes = [[index[s] for s in f["tour"]] for f in plan["flights"]]
    reward = check_flights(p, routes)
    assert abs(reward - plan["reward"]) < 1e-6 * (1 + reward)
    return reward, plan["elapsed_s"]


def one_instance(name: str, doc: dict, flights: int, seconds: float, seed: int, tmp: Path,
                 exact: bool = False) -> dict:
    path = tmp / f"{name}.json"
    path.write_text(json.dumps(doc))
    p = from_document(doc)
    alns, t_alns = run_mound(path, p, "alns", flights, seconds)
    newalg, t_newalg = run_mound(path, p, "newalg", flights, seconds)
    vrp = PyVrp(p, flights)
    routes, t_vrp = vrp.solve_routes(t_alns, seed)
    pyvrp = check_flights(p, routes) if routes else 0.0
    row = {"name": name, "n": len(doc["sites"]), "k": flights, "alns": alns, "t_alns": t_alns,
           "newalg": newalg, "t_newalg": t_newalg, "pyvrp": pyvrp, "t_pyvrp": t_vrp}
    if exact:
        row["exact"], _ = run_mound(path, p, "exact", flights, seconds)
    return row


def proven(name: str, doc: dict, flights: int, seconds: float, exact_s: float, seed: int,
           tmp: Path) -> dict | None:
    """A medium instance against SCIP's proven optimum for K flights (None: not proven)."""
    from mound.plan import branch_cut

    row = one_instance(name, doc, flights, seconds, seed, tmp)
    p = from_document(doc)
    plan = native.run_json("mound_plan", [str(tmp / f"{name}.json"), "--flights", str(flights),
                                          "--time-limit", str(seconds)])
    index = {sid: i for i, sid in enumerate(p.ids)}
    r = branch_cut.solve_flights(p, flights, exact_s,
                                 [[index[s] for s in f["tour"]] for f in plan["flights"]])
    if r.status != "optimal":
        print(f"{name:<22} K={flights} not proven in {exact_s:g} s (gap {100 * r.gap:.2f} %)",
              flush=True)
        return None
    assert r.reward >= max(row["alns"], row["pyvrp"], row["newalg"]) - 1e-9
    row["exact"] = check_flights(p, r.routes)
    row["exact_s"] = r.seconds
    return row


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", nargs="*", type=int, default=[100, 200, 500, 1000])
    ap.add_argument("--flights", nargs="+", type=int, default=[2, 3, 5])
    ap.add_argument("--per-size", type=int, default=2)
    ap.add_argument("--time", type=float, default=1.0, help="ALNS's --time-limit, s")
    ap.add_argument("--fields", action="store_true", help="also the ten standard fields")
    ap.add_argument("--small", type=int, default=20,
                    help="small instances (12 sites) against the exact optimum")
    ap.add_argument("--exact", type=float, default=0.0,
                    help="seconds for SCIP to prove each medium instance (0: none)")
    ap.add_argument("--medium", nargs="+", type=int, default=[30, 40],
                    help="sites of the medium instances (with --exact)")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    rows: list[dict] = []
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        for n in args.sizes:
            for k in args.flights:
                for i in range(args.per_size):
                    r = one_instance(f"rand{n}_k{k}_{i}", random_instance(n, k, rng), k,
                                     args.time, args.seed, tmp)
                    r["suite"] = "random"
                    rows.append(r)
                    print_row(r)
        if args.fields:
            from mound.plan import table1

            docs, _ = table1.make_documents(1.0, False, 40.0)
            for budget in (40.0, 80.0):
                for k in args.flights:
                    for seed, doc in zip(table1.STANDARD_SEEDS, docs, strict=True):
                        name = f"field{seed}_B{budget:g}_k{k}"
                        fdoc = {**doc.to_doc(), "budget_m": budget}
                        # With --exact: the B = 40 m fields with 2 and 3 flights proven.
                        if args.exact > 0 and budget == 40.0 and k in (2, 3):
                            r = proven(name, fdoc, k, args.time, args.exact, args.seed, tmp)
                            if r is None:
                                r = one_instance(name, fdoc, k, args.time, args.seed, tmp)
                        else:
                            r = one_instance(name, fdoc, k, args.time, args.seed, tmp)
                        r["suite"] = "fields"
                        rows.append(r)
                        print_row(r)
        for i in range(args.small):
            k = 2 + i % 2
            doc = random_instance(12, k, rng, fraction=0.9)
            r = one_instance(f"small12_k{k}_{i}", doc, k, args.time, args.seed, tmp, exact=True)
            r["suite"] = "small"
            rows.append(r)
            print_row(r)
        if args.exact > 0:
            for n in args.medium:
                for k in (2, 3):
                    for i in range(args.per_size):
                        r = proven(f"medium{n}_k{k}_{i}", random_instance(n, k, rng), k,
                                   args.time, args.exact, args.seed, tmp)
                        if r is not None:
                            r["suite"] = "medium"
                            rows.append(r)
                            print_row(r)
    summarise(rows)
    return 0


def print_row(r: dict) -> None:
    ref = r.get("exact", max(r["alns"], r["pyvrp"], r["newalg"]))
    line = (f"{r['name']:<22} K={r['k']} ref {ref:9.4f}  alns {100 * r['alns'] / ref:6.2f} % "
            f"({r['t_alns']:.2f} s)  pyvrp {100 * r['pyvrp'] / ref:6.2f} % ({r['t_pyvrp']:.2f} s)"
            f"  newalg {100 * r['newalg'] / ref:6.2f} % ({r['t_newalg']:.3f} s)")
    print(line + ("  [exact]" if "exact" in r else ""), flush=True)


def summarise(rows: list[dict]) -> None:
    print(f"\n{'suite':<8} {'sites':>6} {'K':>3} {'inst':>5} {'ALNS ahead':>10} {'equal':>6} "
          f"{'behind':>7} {'ALNS/PyVRP %':>13} {'NewAlg/ALNS %':>14} {'ALNS s':>7} "
          f"{'PyVRP s':>8} {'ALNS/opt %':>16}")
    keys = sorted({(r["suite"], r["n"], r["k"]) for r in rows},
                  key=lambda t: (["random", "fields", "medium", "small"].index(t[0]), t[1],
                                 t[2]))
    for suite, n, k in keys:
        sel = [r for r in rows if (r["suite"], r["n"], r["k"]) == (suite, n, k)]
        tol = 1e-9
        ahead = sum(r["alns"] > r["pyvrp"] + tol for r in sel)
        behind = sum(r["alns"] < r["pyvrp"] - tol for r in sel)
        ratio = statistics.mean(100 * r["alns"] / r["pyvrp"] if r["pyvrp"] > 0 else float("inf")
                                for r in sel)
        base = statistics.mean(100 * r["newalg"] / r["alns"] for r in sel if r["alns"] > 0)
        opt = ""
        proofs = [r for r in sel if "exact" in r]
        if proofs:
            opt = (f"{min(100 * r['alns'] / r['exact'] for r in proofs):.2f} (min of "
                   f"{len(proofs)})")
        print(f"{suite:<8} {n:>6} {k:>3} {len(sel):>5} {ahead:>10} {len(sel) - ahead - behind:>6} "
              f"{behind:>7} {ratio:>13.2f} {base:>14.2f} "
              f"{statistics.mean(r['t_alns'] for r in sel):>7.2f} "
              f"{statistics.mean(r['t_pyvrp'] for r in sel):>8.2f} {opt:>16}")


if __name__ == "__main__":
    sys.exit(main())
