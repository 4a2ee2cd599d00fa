"""`mound field`, `mound plan exact` and `mound bench table1`: fields of candidate sites, the
proven optimum, the paper's Table I."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from mound.args import UsageError, command_group
from mound.bounds import (
    BUDGET_M,
    FLIGHTS,
    HEIGHT_M,
    SEED,
    SITE_DIAMETER_M,
    TIME_S,
    Bound,
)
from mound.classify import statlog
from mound.classify.coarse import load_model
from mound.errors import InputError
from mound.formats.plan import Plan
from mound.geometry.flight import DEFAULT_SITE_DIAMETER_M, ScanSpec, flight_budget_m, scan_for_site
from mound.geometry.geodesy import Origin
from mound.jsonio import write_json
from mound.plan.field import ORIGIN, STANDARD_SEEDS, make_field, sites_document


def field_costs(args: argparse.Namespace) -> tuple[ScanSpec | None, float | None, float]:
    """(scan, scan cost, budget) of `mound field make|standard`: with --scan-pattern the
    scan cost comes from the pattern and the budget defaults to the aircraft's range;
    otherwise the paper's node cost (1 m) and budget (120 m)."""
    if args.scan_pattern is None:
        if args.site_diameter_m is not None or args.altitude is not None:
            raise UsageError("--site-diameter and --altitude need --scan-pattern")
        return (None, 1.0 if args.scan_cost is None else args.scan_cost,
                120.0 if args.budget is None else args.budget)
    if args.scan_cost is not None:
        raise UsageError("--scan-cost: the scan cost comes from --scan-pattern; give one")
    scan = scan_for_site(
        DEFAULT_SITE_DIAMETER_M if args.site_diameter_m is None else args.site_diameter_m,
        args.scan_pattern, args.altitude)
    scan.check()
    budget = flight_budget_m() if args.budget is None else args.budget
    return scan, None, budget


def cmd_field_make(args: argparse.Namespace) -> int:
    test = statlog.load("sat.tst")
    model = load_model(args.model)
    scan, scan_cost, budget = field_costs(args)
    sites = sites_document(make_field(test, args.seed), test, model, scan_cost, budget,
                           spacing_m=args.spacing, scan=scan,
                           origin=Origin.parse(args.origin) if args.origin else ORIGIN)
    if args.dem:
        from mound.flightplan import terrain

        if scan is None:
            raise UsageError("--dem needs --scan-pattern (the heights follow the scan)")
        sites = terrain.attach(sites, args.dem, terrain.spec_from_args(args),
                               args.dem_vertical, sites.origin)
    write_json(args.out, sites.to_doc())
    prov = sites.extra["provenance"]
    print(f"field seed {args.seed}: 100 sites, {prov['positives']} positives, "
          f"total reward {prov['total_reward']:.2f} bits -> {args.out}")
    return 0


def cmd_field_standard(args: argparse.Namespace) -> int:
    test = statlog.load("sat.tst")
    model = load_model(args.model)
    out = Path(args.out_dir)
    totals = []
    for seed in STANDARD_SEEDS:
        scan, scan_cost, budget = field_costs(args)
        sites = sites_document(make_field(test, seed), test, model, scan_cost, budget,
                               scan=scan)
        write_json(out / f"field_{seed}.json", sites.to_doc())
        prov = sites.extra["provenance"]
        totals.append(prov["total_reward"])
        print(f"field {seed}: {prov['positives']} positives, "
              f"total reward {totals[-1]:.2f}")
    print(f"average total reward of the ten standard fields: {np.mean(totals):.2f} "
          f"(paper: 61.37)")
    return 0


def cmd_plan_exact(args: argparse.Namespace) -> int:
    from mound.plan import sites

    prob = sites.load(args.sites, args.budget)
    if args.flights != 1:
        return plan_exact_flights(args, prob)
    if args.solver == "scip":
        from mound import native
        from mound.plan import branch_cut

        # The first solution: the heuristic's route (ALNS, 1 s).
        heur = Plan.from_doc(native.run_json(
            "mound_plan", [args.sites, str(prob.budget), "--algo", "alns", "--time-limit", "1"]),
            "mound_plan's plan")
        index = {sid: i for i, sid in enumerate(prob.ids)}
        r = branch_cut.solve(prob, time_limit_s=args.time_limit,
                             start_route=[index[sid] for sid in heur.flights[0].tour])
    else:
        from mound.plan import exact as exact_op

        r = exact_op.solve(prob, time_limit_s=args.time_limit)
    plan = Plan.of_flights(
        "exact-bc" if args.solver == "scip" else "exact-ip", [[prob.ids[v] for v in r.route]],
        [r.reward], [r.cost], prob.budget, prob.closed, sites_file=args.sites,
        elapsed_s=r.seconds, n_sites=len(prob.ids) - (1 if prob.closed else 2),
        n_visited=len(set(r.route)) - (1 if prob.closed else 2),
        solver={"name": args.solver, "proof": r.status, "upper_bound": r.bound, "gap": r.gap,
                "cuts": r.cuts, "rounds": r.rounds})
    return emit_exact_plan(args, plan, f"{r.status}: reward {r.reward:.4f}, upper bound "
                           f"{r.bound:.4f}, {r.cuts} cuts, {r.seconds:.1f} s")


def emit_exact_plan(args: argparse.Namespace, plan: Plan, line: str) -> int:
    """The plan to --out (or stdout), the proof's one line to stderr."""
    doc = plan.to_doc()
    if args.out:
        write_json(args.out, doc)
    else:
        print(json.dumps(doc, indent=1))
    print(line, file=sys.stderr)
    return 0


def plan_exact_flights(args: argparse.Namespace, prob: Any) -> int:
    """`mound plan exact --flights K`: SCIP's branch-and-cut on K flights, started from
    mound_plan's ALNS flights; plan.json with flights[] as mound_plan writes it."""
    from mound import native
    from mound.plan import branch_cut

    if args.solver != "scip":
        raise UsageError("--flights: the exact method for several flights is --solver scip")
    if not 1 <= args.flights <= 64:
        raise UsageError("--flights: 1 .. 64")
    heur = Plan.from_doc(native.run_json("mound_plan", [
        args.sites, str(prob.budget), "--flights", str(args.flights), "--time-limit", "1"]),
        "mound_plan's plan")
    index = {sid: i for i, sid in enumerate(prob.ids)}
    r = branch_cut.solve_flights(prob, args.flights, args.time_limit,
                                 [[index[sid] for sid in f.tour] for f in heur.flights])
    first = 1 if prob.closed else 2
    plan = Plan.of_flights(
        "exact-bc", [[prob.ids[v] for v in route] for route in r.routes],
        [float(sum(prob.reward[v] for v in set(route) if v >= first)) for route in r.routes],
        r.costs, prob.budget, prob.closed, sites_file=args.sites, elapsed_s=r.seconds,
        n_sites=len(prob.ids) - first,
        n_visited=sum(len(set(route[1:-1])) for route in r.routes),
        solver={"name": "scip", "proof": r.status, "upper_bound": r.bound, "gap": r.gap,
                "cuts": r.cuts, "rounds": r.rounds, "alns_reward": heur.reward})
    return emit_exact_plan(args, plan, f"{r.status}: {args.flights} flights, reward "
                           f"{r.reward:.4f}, upper bound {r.bound:.4f}, {r.cuts} cuts, "
                           f"{r.seconds:.1f} s")


def cmd_table1(args: argparse.Namespace) -> int:
    from dataclasses import asdict

    from mound.plan import table1

    for b in args.budgets or ():
        if not (np.isfinite(b) and 0 < b <= 1e6):
            raise InputError(f"--budgets: expected metres in (0, 1e6], got {b}")
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    all_rows = []
    exact: list[dict[str, object]] = []
    setting = None
    for c in args.scan_cost:
        rows, meta = table1.run(scan_cost=c, exact_time_limit_s=args.exact_time_limit,
                                workdir=out / "fields", paper=args.paper,
                                budgets=tuple(args.budgets or table1.BUDGETS),
                                progress=lambda line: print(f"table1: {line}", file=sys.stderr,
                                                            flush=True))
        all_rows += rows
        exact += [{"scan_cost_m": c, **e} for e in meta.exact]
        setting = meta.setting
        how = (f"paper setting: gradient descent stopped at t = {setting.gd_iterations:.4f} "
               "iterations" if args.paper else "converged classifier")
        print(f"node (scan) cost {c:g} m; {how}; total reward per field "
              f"{setting.total_reward_per_field:.2f} "
              f"(paper {table1.PAPER.total_reward_per_field})")
        print(table1.format_table(rows))
        if c == args.scan_cost[0]:
            table1.plot(rows, meta, out)
    table1.write_csv(all_rows, out / "table1.csv")
    write_json(out / "table1.json", {
        "schema": "mound.table1", "version": 1,
        "setting": asdict(setting) if setting else None,
        "rows": [asdict(r) for r in all_rows], "exact": exact})
    print(f"-> {out / 'table1.csv'}, {out / 'table1.json'}, {out / 'reward_vs_budget.png'}, "
          f"{out / 'field0_tours.png'}")
    return 0


def add_parser(sub: Any, parser_class: Any) -> None:
    """The `field`, `plan` and `bench` command groups."""
    fld = command_group(sub, "field", "fields of candidate sites", parser_class)
    for name, func in (("make", cmd_field_make), ("standard", cmd_field_standard)):
        m = fld.add_parser(name, help="one field" if name == "make" else "seeds 0-9")
        if name == "make":
            m.add_argument("--seed", type=SEED.arg(), required=True)
            m.add_argument("--out", required=True)
            m.add_argument("--spacing", type=Bound(0, 100_000, "m", above=True).arg(), default=1.0,
                           help="grid spacing of the sites, m (1: the paper's field)")
            m.add_argument("--origin", help="LAT,LON[,ALT] of home (default: Bin Tepe, "
                           "38.5705,27.9862)")
            from mound.flightplan.terrain import add_arguments as add_terrain_arguments

            add_terrain_arguments(m)
        else:
            m.add_argument("--out-dir", required=True)
        m.add_argument("--model", help="classifier JSON (default: train the default band)")
        m.add_argument("--scan-cost", type=Bound(0, 100_000, "m").arg(),
                       help="node cost per site, m (default 1: the paper's)")
        m.add_argument("--scan-pattern", choices=("raster", "orbit", "both"),
                       help="derive each site's scan cost from this scan (the flight the "
                       "mission flies) and record it, with the take-off/landing climb")
        m.add_argument("--site-diameter", dest="site_diameter_m", metavar="D",
                       type=SITE_DIAMETER_M.arg(),
                       help="with --scan-pattern: the scan's scale, m (default 60)")
        m.add_argument("--altitude", type=HEIGHT_M.arg(),
                       help="with --scan-pattern: the raster's height, m (default: the "
                       "site diameter)")
        m.add_argument("--budget", type=BUDGET_M.arg(),
                       help="budget_m written, m (default 120, the paper's; with "
                       "--scan-pattern the aircraft's range, 14,400 m)")
        m.set_defaults(func=func)
    plan = command_group(sub, "plan", "tour planning (Python side)", parser_class)
    ex = plan.add_parser("exact", help="proven optimum: branch-and-cut (SCIP) or HiGHS")
    ex.add_argument("sites")
    ex.add_argument("budget", nargs="?", type=BUDGET_M.arg(), help="overrides budget_m")
    ex.add_argument("--time-limit", type=TIME_S.arg(), default=60.0, help="seconds (default 60)")
    ex.add_argument("--solver", choices=("scip", "highs"), default="scip",
                    help="scip: branch-and-cut with GSECs separated in the search, started "
                    "from the ALNS route (default); highs: cut loop around HiGHS's MIP")
    ex.add_argument("--out", help="plan.json (default: stdout)")
    ex.add_argument("--flights", type=FLIGHTS.arg(), default=1,
                    help="K flights (the team orienteering problem; scip only)")
    ex.set_defaults(func=cmd_plan_exact)
    bench = command_group(sub, "bench", "benchmarks and reproductions", parser_class)
    t1 = bench.add_parser("table1", help="the paper's Table I on the ten standard fields")
    t1.add_argument("--scan-cost", type=Bound(0, 100_000, "m").arg(), nargs="+", default=[1.0],
                    help="node cost(s) per site in m; the first is plotted")
    t1.add_argument("--exact-time-limit", type=Bound(0, 7 * 24 * 3600, "s").arg(), default=0.0,
                    help="seconds per field and budget for the exact optimum (SCIP "
                    "branch-and-cut; 0: skip)")
    t1.add_argument("--paper", action="store_true",
                    help="the paper's setting: the classifier stopped early where the ten "
                    "fields' average total reward is the paper's 61.37 bits")
    t1.add_argument("--budgets", type=BUDGET_M.arg(), nargs="+", default=None,
                    help="budgets in m (default 40 80 120 160 200)")
    t1.add_argument("--out-dir", default="runs/table1")
    t1.set_defaults(func=cmd_table1)
