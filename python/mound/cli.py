"""The `mound` command line: one entry point, subcommands per stage.

    mound data fetch [--url URL]
    mound classify bands
    mound classify train [--band B | --all] [--solver gd|lbfgs] [--l2 X] --out MODEL.json
    mound classify eval MODEL.json [--json OUT.json]
    mound field make --seed S [--model MODEL.json] [--spacing M] [--budget M]
                     [--scan-cost M | --scan-pattern P [--site-diameter D] [--altitude H]]
                     --out SITES.json
    mound field standard [--model MODEL.json] --out-dir DIR
    mound sim site [--preset bin_tepe|lab] [--mound tumulus|none] --seed S --out DIR [...]
    mound sim figures DIR [--out-dir DIR] [--dpi-scale X]
    mound sim flight PLAN --out CARD_DIR [--truth FILE] [...]
    mound recon figure RECON_DIR --out PNG
    mound recon rasters RECON_DIR --out DIR [--resolution-m 0.25] [--cloud dense.ply]
    mound mission build PLAN.json [--origin LAT,LON[,ALT]] --out MISSION.plan [...]
    mound mission upload MISSION.plan --connect udpout:HOST:PORT [--verify] [...]
    mound scene train SCENE.tif [...] --labels KNOWN.geojson --out MODEL.json [...]
    mound scene score SCENE.tif --model MODEL.json --out DIR [--stride-m S] [...]
    mound scene eval SCENE.tif [...] --labels KNOWN.geojson [--figure PNG] [...]

Exit codes: 0 ok, 1 internal error, 2 bad input or usage (one line on stderr), 3 valid
input that allowed no result.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from mound import datasets
from mound.args import Parser, UsageError
from mound.bounds import (
    BUDGET_M,
    FLIGHTS,
    GRID_SEED,
    HEIGHT_M,
    IMAGE_PX,
    SEED,
    SIM_SEED,
    SITE_DIAMETER_M,
    SPEED_M_S,
    THREADS,
    TIME_S,
    WORKERS,
    Bound,
)
from mound.classify import coarse, statlog
from mound.classify.model import SCHEMA as MODEL_SCHEMA
from mound.classify.model import VERSION as MODEL_VERSION
from mound.classify.model import Model
from mound.errors import EXIT_NO_RESULT, InputError, exit_for
from mound.geometry.flight import ScanSpec
from mound.geometry.geodesy import Origin
from mound.jsonio import read_json, write_json
from mound.photos import cli as photos_cli
from mound.plan.field import STANDARD_SEEDS, make_field, sites_document
from mound.scene import cli as scene_cli
from mound.uav import cli as uav_cli
from mound.uav import mission_items


def load_model(path: str | None) -> Model:
    if path is None:
        return coarse.train(statlog.load("sat.trn"), coarse.DEFAULT_BAND)
    return Model.from_doc(read_json(path, MODEL_SCHEMA, MODEL_VERSION), path)


def cmd_fetch(args: argparse.Namespace) -> int:
    where = datasets.fetch(datasets.STATLOG, url=args.url)
    print(f"statlog: {', '.join(datasets.STATLOG.files)} in {where} (sha256 checked)")
    return 0


def cmd_bands(args: argparse.Namespace) -> int:
    rows = coarse.select_band(statlog.load("sat.trn"), seed=args.seed)
    print("held-out evaluation on sat.trn (75/25 stratified split, L-BFGS):")
    print(f"{'features':<18} {'AUC':>7} {'accuracy':>9} {'log-loss':>9}")
    for r in rows:
        label = r["name"] if r["band"] is None else f"band {r['band']} {r['name']}"
        print(f"{label:<18} {r['auc']:>7.4f} {r['accuracy']:>9.4f} {r['log_loss']:>9.4f}")
    best = max((r for r in rows if r["band"] is not None), key=lambda r: r["auc"])
    print(f"best single band: {best['band']} ({best['name']})")
    return 0


def cmd_train(args: argparse.Namespace) -> int:
    band = None if args.all else args.band
    model = coarse.train(statlog.load("sat.trn"), band, solver=args.solver, l2=args.l2)
    write_json(args.out, model.to_doc())
    i = model.info
    print(f"trained {'all 36 features' if band is None else f'band {band}'} with {args.solver}: "
          f"{i['iterations']} iterations, {i['train_seconds']:.3f} s, loss {i['loss']:.5f}, "
          f"|grad| {i['grad_norm']:.2e} -> {args.out}")
    return 0


def print_eval(s: dict[str, Any]) -> None:
    print(f"sat.tst ({s['rows']} rows): accuracy {s['accuracy']:.4f} "
          f"(majority baseline {s['majority_accuracy']:.4f}), AUC {s['auc']:.4f}, "
          f"log-loss {s['log_loss']:.4f}, ECE {s['ece']:.4f}")
    print("reliability:   p range   count  mean p  observed")
    for r in s["reliability"]:
        if r["count"]:
            print(f"             {r['lo']:.1f}-{r['hi']:.1f} {r['count']:>7} "
                  f"{r['mean_p']:>7.3f} {r['observed']:>9.3f}")


def cmd_eval(args: argparse.Namespace) -> int:
    s = coarse.evaluate(load_model(args.model), statlog.load("sat.tst"))
    print_eval(s)
    if args.json:
        write_json(args.json, {"schema": "mound.classifier_eval", "version": 1, **{
            k: v for k, v in s.items() if k != "reliability"},
            "reliability": [r for r in s["reliability"] if r["count"]]})
    return 0


def field_costs(args: argparse.Namespace) -> tuple[ScanSpec | None, float | None, float]:
    """(scan, scan cost, budget) of `mound field make|standard`: with --scan-pattern the
    scan cost comes from the pattern and the budget defaults to the aircraft's range;
    otherwise the paper's node cost (1 m) and budget (120 m)."""
    if args.scan_pattern is None:
        if args.site_diameter is not None or args.altitude is not None:
            raise UsageError("--site-diameter and --altitude need --scan-pattern")
        return (None, 1.0 if args.scan_cost is None else args.scan_cost,
                120.0 if args.budget is None else args.budget)
    if args.scan_cost is not None:
        raise UsageError("--scan-cost: the scan cost comes from --scan-pattern; give one")
    scan = mission_items.scan_for_site(
        60.0 if args.site_diameter is None else args.site_diameter, args.scan_pattern,
        args.altitude)
    scan.validate()
    budget = mission_items.flight_budget_m() if args.budget is None else args.budget
    return scan, None, budget


def cmd_field_make(args: argparse.Namespace) -> int:
    test = statlog.load("sat.tst")
    model = load_model(args.model)
    if args.spacing <= 0:
        raise UsageError("--spacing must be > 0")
    scan, scan_cost, budget = field_costs(args)
    doc = sites_document(make_field(test, args.seed), test, model, scan_cost, budget,
                         spacing_m=args.spacing, scan=scan)
    if args.origin:
        doc["origin"] = Origin.parse(args.origin).to_doc()
    if args.dem:
        from mound.uav import terrain

        if scan is None:
            raise UsageError("--dem needs --scan-pattern (the heights follow the scan)")
        doc = terrain.attach(doc, args.dem, terrain.spec_from_args(args), args.dem_vertical,
                             Origin.from_doc(doc["origin"]))
    write_json(args.out, doc)
    prov = doc["provenance"]
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
        doc = sites_document(make_field(test, seed), test, model, scan_cost, budget, scan=scan)
        write_json(out / f"field_{seed}.json", doc)
        totals.append(doc["provenance"]["total_reward"])
        print(f"field {seed}: {doc['provenance']['positives']} positives, "
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
        heur = native.run_json("mound_plan", [args.sites, str(prob.budget), "--algo", "alns",
                                              "--time-limit", "1"])
        index = {sid: i for i, sid in enumerate(prob.ids)}
        r = branch_cut.solve(prob, time_limit_s=args.time_limit,
                             start_route=[index[sid] for sid in heur["tour"]])
    else:
        from mound.plan import exact as exact_op

        r = exact_op.solve(prob, time_limit_s=args.time_limit)
    tour = [prob.ids[v] for v in r.route]
    doc = {
        "schema": "mound.plan", "version": 1, "status": "ok",
        "algo": "exact-bc" if args.solver == "scip" else "exact-ip",
        "sites_file": args.sites, "closed": prob.closed, "tour": tour, "reward": r.reward,
        "cost_m": r.cost, "budget_m": prob.budget, "budget_left_m": prob.budget - r.cost,
        "elapsed_s": r.seconds, "n_sites": len(prob.ids) - (1 if prob.closed else 2),
        "n_visited": len(set(r.route)) - (1 if prob.closed else 2),
        "solver": {"name": args.solver, "proof": r.status, "upper_bound": r.bound,
                   "gap": r.gap, "cuts": r.cuts, "rounds": r.rounds},
    }
    return emit_exact_plan(args, doc, f"{r.status}: reward {r.reward:.4f}, upper bound "
                           f"{r.bound:.4f}, {r.cuts} cuts, {r.seconds:.1f} s")


def emit_exact_plan(args: argparse.Namespace, doc: dict[str, Any], line: str) -> int:
    """The plan to --out (or stdout), the proof's one line to stderr."""
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
    heur = native.run_json("mound_plan", [args.sites, str(prob.budget), "--flights",
                                          str(args.flights), "--time-limit", "1"])
    index = {sid: i for i, sid in enumerate(prob.ids)}
    r = branch_cut.solve_flights(prob, args.flights, args.time_limit,
                                 [[index[sid] for sid in f["tour"]] for f in heur["flights"]])
    first = 1 if prob.closed else 2
    flights = [{"flight": k + 1, "tour": [prob.ids[v] for v in route],
                "reward": float(sum(prob.reward[v] for v in set(route) if v >= first)),
                "cost_m": cost, "budget_left_m": prob.budget - cost}
               for k, (route, cost) in enumerate(zip(r.routes, r.costs, strict=True))]
    doc = {
        "schema": "mound.plan", "version": 1, "status": "ok", "algo": "exact-bc",
        "sites_file": args.sites, "closed": prob.closed, "tour": flights[0]["tour"],
        "flights": flights, "reward": r.reward, "cost_m": sum(r.costs),
        "budget_m": prob.budget, "budget_left_m": prob.budget * len(flights) - sum(r.costs),
        "elapsed_s": r.seconds, "n_sites": len(prob.ids) - first,
        "n_visited": sum(len(set(route[1:-1])) for route in r.routes),
        "solver": {"name": "scip", "proof": r.status, "upper_bound": r.bound, "gap": r.gap,
                   "cuts": r.cuts, "rounds": r.rounds, "alns_reward": heur["reward"]},
    }
    return emit_exact_plan(args, doc, f"{r.status}: {args.flights} flights, reward "
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
    exact: list[dict[str, Any]] = []
    setting = None
    for c in args.scan_cost:
        rows, meta = table1.run(scan_cost=c, exact_time_limit_s=args.exact_time_limit,
                                workdir=out / "fields", paper=args.paper,
                                budgets=tuple(args.budgets or table1.BUDGETS),
                                progress=lambda line: print(f"table1: {line}", file=sys.stderr,
                                                            flush=True))
        all_rows += rows
        exact += [{"scan_cost_m": c, **e} for e in meta["exact"]]
        setting = meta["setting"]
        how = (f"paper setting: gradient descent stopped at t = {setting.gd_iterations:.4f} "
               "iterations" if args.paper else "converged classifier")
        print(f"node (scan) cost {c:g} m; {how}; total reward per field "
              f"{meta['total_reward_per_field']:.2f} "
              f"(paper {table1.PAPER['total_reward_per_field']})")
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


def cmd_sim_site(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from mound.sim import site as sim
    from mound.sim import terrain
    from mound.sim.appearance import Lighting

    overrides: dict[str, Any] = {"mound": args.mound == "tumulus", "seed": args.seed}
    for key in ("profile", "diameter_m", "height_m", "erosion_m", "size_m", "resolution_m"):
        if getattr(args, key) is not None:
            overrides[key] = getattr(args, key)
    if args.pit:
        overrides.update(pit_radius_m=args.pit[0], pit_depth_m=args.pit[1],
                         pit_offset_m=args.pit[2])
    if args.offset:
        overrides.update(mound_x_m=args.offset[0], mound_y_m=args.offset[1])
    if args.trench:
        overrides.update(trench_width_m=args.trench[0], trench_depth_m=args.trench[1],
                         trench_azimuth_deg=args.trench[2])
    if args.slope:
        overrides.update(slope_deg=args.slope[0], slope_azimuth_deg=args.slope[1])
    if args.dem:
        try:
            x, y = float(args.dem[1]), float(args.dem[2])
        except ValueError:
            raise InputError("--dem: expected PATH X Y (the patch's centre in the DEM's CRS)"
                             ) from None
        overrides.update(dem_path=args.dem[0], dem_x_m=x, dem_y_m=y)
    if args.confuser:
        if args.mound != "none":
            raise InputError("--confuser: only on a site without a mound (--mound none)")
        length, width, height, az = args.confuser_size
        overrides["confusers"] = (terrain.Confuser(args.confuser, 0.0, 0.0, length, width,
                                                   height, az, count=args.trees,
                                                   seed=args.seed),)
    spec = sim.SimSpec(
        terrain=terrain.preset(args.preset, **overrides),
        lighting=Lighting(np.deg2rad(args.sun[0]), np.deg2rad(args.sun[1])),
        width_px=args.size[0], height_px=args.size[1], hfov_rad=np.deg2rad(args.hfov_deg),
        dist=tuple(args.distortion), pattern=args.pattern,
        noise_sigma=args.noise_sigma, vignetting=args.vignetting,
        gps_sigma_h_m=args.gps_sigma[0], gps_sigma_v_m=args.gps_sigma[1], seed=args.seed)
    if args.altitude is not None:
        spec = replace(spec, raster_altitude_m=args.altitude)
    if args.orbit_images is not None:
        spec = replace(spec, orbit_images=args.orbit_images)
    if args.scan_diameter is not None:
        spec = replace(spec, scan_diameter_m=args.scan_diameter)
    site = sim.simulate(spec, args.out, threads=args.threads)
    if args.jpeg:
        from mound.sim.card import site_jpegs

        site_jpegs(args.out, _start_time(args.start_time))
    t = site["timings"]
    print(f"{'tumulus' if spec.terrain.mound else 'flat control'} ({args.preset}, seed "
          f"{args.seed}): {site['stats']['images']} images {spec.width_px}x{spec.height_px} "
          f"-> {args.out}")
    print(f"terrain {t['terrain_s']:.2f} s, texture {t['texture_s']:.2f} s, render "
          f"{t['render_s']:.2f} s ({site['stats']['render_threads']} threads)")
    if args.figures:
        cmd_sim_figures(argparse.Namespace(site=args.out, out_dir=args.out, dpi_scale=1.0))
    return 0


def _start_time(text: str) -> Any:
    from datetime import datetime

    try:
        return datetime.fromisoformat(text)
    except ValueError:
        raise InputError(f"--start-time: expected YYYY-MM-DDTHH:MM:SS, got {text!r}") from None


def cmd_sim_flight(args: argparse.Namespace) -> int:
    from mound.jsonio import write_json
    from mound.sim.card import CardSpec, write_card

    sites = args.sites or str(Path(args.plan).with_name("sites.json"))
    spec = CardSpec(start=_start_time(args.start_time), speed_mps=args.speed,
                    transit_every_s=args.transit_every_s, sim_seed=args.sim_seed,
                    image_size=tuple(args.image_size), pattern=args.scan_pattern,
                    site_diameter_m=args.site_diameter, threads=args.threads,
                    scan_factor=args.scan_factor)
    truth = write_card(args.plan, sites, args.out, spec)
    if args.truth:
        write_json(args.truth, truth)
    n_transit = sum(1 for f in truth["files"] if f["reason"] == "transit")
    n_sites = len({f["site"] for f in truth["files"] if f["site"]})
    print(f"{len(truth['files'])} photos ({n_sites} sites, {n_transit} transit) -> "
          f"{args.out}/DCIM/100MEDIA")
    return 0


def terrain_confusers() -> tuple[str, ...]:
    from mound.sim.terrain import CONFUSERS

    return CONFUSERS


def cmd_sim_grid(args: argparse.Namespace) -> int:
    from mound.paths import shared_data_dir
    from mound.sim import grid

    if args.workers < 1 or args.threads < 1:
        raise InputError("--workers, --threads: must be >= 1")

    def progress(k: int, row: dict[str, Any]) -> None:
        t = row.get("times") or {}
        print(f"{row['dir']}: {row['truth']['kind']:<9} {row.get('status')} "
              f"({sum(t.values()):.1f} s)", flush=True)

    dem: list[str] | None = None
    if args.dem == ["none"]:
        dem = None
    elif args.dem and "none" in args.dem:
        raise InputError("--dem: none cannot be given with a DEM")
    elif args.dem:
        dem = args.dem
    else:
        # A quarter of the draws are terrain patches of the DEM: without it the same seed
        # would draw another grid, so a missing default is an error, not a quiet change.
        here = [p / "dem" / grid.DEFAULT_DEM for p in (datasets.cache_dir(), shared_data_dir())]
        found = [p for p in here if p.is_file()]
        if not found:
            raise InputError(f"--dem: no DEM at {here[0]} nor {here[1]}: pass --dem FILE "
                             f"(the 1 m laser DEM, {grid.DEFAULT_DEM}), or --dem none to "
                             "draw the grid without terrain patches (another grid)")
        dem = [str(found[0])]
    doc = grid.make_grid(args.out, args.sites, args.seed, tuple(args.size), dem,
                         args.threads, args.workers, args.remeasure, progress,
                         pattern=args.pattern, dense=args.dense, card=args.card,
                         flights_from=args.flights_from, second_look=args.second_look,
                         dem_part=args.dem_part, population=args.population,
                         second_look_kind=args.second_look_kind)
    print(f"{doc['measured']} of {doc['sites']} sites measured in {doc['wall_s']:.0f} s -> "
          f"{args.out}/grid.json")
    if "earlier_tools" in doc:
        print(f"note: {args.out}: verdicts made before were made by another build of "
              "mound_recon (grid.json: earlier_tools); --remeasure judges every site with "
              "this one", file=sys.stderr)
    if doc["status"] == "failed":
        reasons = sorted({str(r.get("reason", "?"))[:120] for r in doc["rows"]})
        print(f"mound sim grid: no result: no site was measured ({reasons[0]}"
              f"{f' and {len(reasons) - 1} other reasons' if len(reasons) > 1 else ''}; "
              f"each site's log.txt says more)", file=sys.stderr)
        return EXIT_NO_RESULT
    return 0


def cmd_recon_train_verdict(args: argparse.Namespace) -> int:
    from mound.jsonio import write_json
    from mound.recon import verdict_model as vm

    rows = [r for g in args.grids for r in vm.load_grid(g, args.second_look_kind)]
    names = vm.feature_names_of(rows)
    model = vm.train(rows, names, [str(Path(g)) for g in args.grids])
    t = model["trained"]
    print(f"trained on {t['sites']} sites ({t['with_rise']} with a rise, {t['mounds']} mounds): "
          f"l2 {t['l2']:g}, out-of-fold AUC {t['out_of_fold']['auc']:.3f}, ECE "
          f"{t['out_of_fold']['ece']:.3f}; threshold {model['threshold']:.2f}")

    def by_ground(gb: dict[str, Any]) -> str:
        return (f"clear of their ground {gb['clear']['found']:.1f} of {gb['clear']['sites']}, "
                f"masked by it {gb['masked']['found']:.1f} of {gb['masked']['sites']}")

    print("  out of fold, goal tumuli found by the first look: "
          + by_ground(t["out_of_fold"]["goal_found_by_ground"]))
    sl = model.get("second_look")
    if sl:
        o = sl["trained"]["out_of_fold"]
        print(f"second look (a scan {sl['scan_factor']:g} x as wide) for p in "
              f"[{sl['p_low']:g}, {model['threshold']:.2f}), a mound at {sl['threshold']:.2f}: "
              f"out of fold {o['flights']:.1f} flights, goal tumuli "
              f"{o['goal_found_first_look']:.1f} -> {o['goal_found']:.1f} of "
              f"{o['goal_sites']}, false alarms "
              f"{o['false_alarms_first_look']:.1f} -> {o['false_alarms']:.1f} of {o['negatives']}")
        print("  out of fold, goal tumuli found with the second look: "
              + by_ground(o["goal_found_by_ground"]))
    elif t.get("second_look_not_kept"):
        n = t["second_look_not_kept"]
        print(f"second look not kept (p in [{n['p_low']:g}, {model['threshold']:.2f}), "
              f"{n['out_of_fold']['flights']:.1f} flights out of fold): {n['why']}")
    u = model["undecided"]
    o = u["trained"]["out_of_fold"]
    print(f"undecided for p in [{u['p_low']:.3f}, {u['p_high']:.3f}): out of fold (nested) "
          f"{o['confident_misses']:.1f} of {o['goal_tumuli']} tumuli >= 1 m x 10 m called "
          f"no_mound, {o['confident_false_alarms']:.1f} of {o['negatives']} sites without one "
          f"called mound, {o['undecided']:.1f} of {o['sites']} sites undecided")
    if args.heldout:
        held = [r for g in args.heldout for r in vm.load_grid(g, args.second_look_kind)]
        report = vm.evaluate(model, held)
        model["heldout"] = {k: report[k] for k in (
            "sites", "measured", "accuracy", "false_alarm_rate", "missed_rate", "auc",
            "brier", "ece", "calibration", "goal_mounds_2m_15m", "goal_no_mound",
            "old_rule_accuracy")}
        if "three_answers" in report:
            model["heldout"]["three_answers"] = {
                k: v for k, v in report["three_answers"].items() if k != "field_recall"}
        if "two_looks" in report:
            model["heldout"]["two_looks"] = {k: v for k, v in report["two_looks"].items()
                                             if k not in ("second_looks", "errors")}
        model["heldout"]["grids"] = [str(Path(g)) for g in args.heldout]
        _print_verdict_report(report)
        if args.report:
            write_json(Path(args.report), report)
        if args.figure:
            vm.figure(report, args.figure)
    write_json(Path(args.out), model)
    print(f"-> {args.out}")
    return 0


def _print_three_answers(t: dict[str, Any]) -> None:
    def rate(d: dict[str, Any]) -> str:
        lo, hi = d["rate_95ci"] or (math.nan, math.nan)
        return (f"{d['count']}/{d['of']} ({100 * (d['rate'] or 0):.1f} %, 95 % interval "
                f"{100 * lo:.1f}-{100 * hi:.1f} %)")

    u = t["undecided"]
    print(f"  three answers (undecided for p in [{t['band'][0]:.3f}, {t['band'][1]:.3f})): "
          f"confident misses {rate(t['confident_misses'])}; confident false alarms "
          f"{rate(t['confident_false_alarms'])}; undecided {rate(u)}"
          + (f", of them tumuli {u['tumulus_share']:.2f} against mean p {u['mean_p']:.2f}"
             if u["of"] and u["count"] else ""))
    fr = t["frontier"]
    b = fr["best_within_undecided"]
    print(f"  the frontier (any band, chosen on these sites: a bound): the goals' confident "
          f"errors need {100 * fr['undecided_at_goals']:.1f} % undecided; with <= "
          f"{100 * fr['at_most_undecided']:.0f} % undecided the least is "
          f"{100 * b['confident_misses']:.1f} % confident misses and "
          f"{100 * b['confident_false_alarms']:.1f} % confident false alarms "
          f"({b['times_the_goals']:.1f} x the goals)")
    f = t["field_recall"]["all"]
    print("  tumuli confirmed mound (two answers' mound) by height: " + "; ".join(
        f"{k} {c['confirmed']['count']}/{c['tumuli']} ({c['two_answer_mound']['count']})"
        for k, c in f["by_height"].items()) + f"; all {f['all']['confirmed']['count']}/"
        f"{f['all']['tumuli']} ({f['all']['two_answer_mound']['count']})")


def _print_verdict_report(r: dict[str, Any]) -> None:
    g, n = r["goal_mounds_2m_15m"], r["goal_no_mound"]
    cal = r["calibration"]
    print(f"held-out: {r['measured']} of {r['sites']} sites measured; accuracy "
          f"{r['accuracy']:.3f} (old rule {r['old_rule_accuracy']:.3f}); AUC {r['auc']:.3f}, "
          f"Brier {r['brier']:.3f}, ECE {r['ece']:.3f} (a calibrated forecast on these sites: "
          f"<= {cal['ece_if_calibrated_95']:.3f} in 95 % of draws; p = {cal['p_value']:.2f})")

    def ci(d: dict[str, Any]) -> str:
        lo, hi = d["rate_95ci"] or (math.nan, math.nan)
        return f"95 % interval {100 * lo:.1f}-{100 * hi:.1f} %"

    print(f"  mounds >= 2 m high and >= 15 m across: {g['right']}/{g['sites']} right "
          f"({ci(g)}); no mound: {n['false_alarms']}/{n['sites']} false alarms ({ci(n)})")
    b = g["by_ground"]
    masked = "; ".join(f"{t['dir']} {t['prominence_m']:.1f} m over {t['ground_clutter_m']:.1f} m"
                       + ("" if t["found"] else " missed") for t in b["masked"]["tumuli"])
    print(f"    of them standing clear of their ground (prominence >= {b['clear_of_ground']:g} x "
          f"the ground's clutter): {b['clear']['right']}/{b['clear']['sites']} right"
          + (f" ({ci(b['clear'])})" if b["clear"]["sites"] else "")
          + f"; masked by it: {b['masked']['right']}/{b['masked']['sites']}"
          + (f" ({masked})" if masked else "")
          + (f"; relief unknown: {b['relief_unknown']}" if b["relief_unknown"] else ""))
    for key, c in r["per_group"].items():
        print(f"  {key:<24} {c['right']:>3}/{c['sites']:<3} right (old rule "
              f"{c['old_rule_right']})")
    w = r["wider_than_scan"]
    print(f"  tumuli wider than the 60 m scan: {w['right']}/{w['sites']} right; reaching past "
          f"the cloud: {w['beyond_the_cloud']}, of them {w['beyond_the_cloud_warned']} "
          "flagged clipped")
    print("  other thresholds (tumuli >= 2 m x 15 m found; false alarms): " + "; ".join(
        f"{o['threshold']:g}: {o['mounds_2m_15m_found']}/{g['sites']}, "
        f"{o['false_alarms']}/{n['sites']}" for o in r["operating_points"]))
    three = r.get("three_answers")
    if three:
        _print_three_answers(three)
    two = r.get("two_looks")
    if two:
        g2, n2, c2 = two["goal_mounds_2m_15m"], two["goal_no_mound"], two["calibration"]
        print(f"  with the second look (p in [{two['p_low']:g}, {r['threshold']:.2f}): "
              f"{two['flown']} of {two['band']} flown again, a mound at "
              f"{two['threshold']:.2f}): mounds >= 2 m x 15 m {g2['right']}/{g2['sites']} "
              f"({ci(g2)}); no mound {n2['false_alarms']}/{n2['sites']} false alarms "
              f"({ci(n2)}); ECE {two['ece']:.3f} (p = {c2['p_value']:.2f}); standing clear "
              f"of their ground {g2['by_ground']['clear']['right']}/"
              f"{g2['by_ground']['clear']['sites']}")
    lim = r["detection_limit"]["limit"] or []
    print("  detection limit (>= 95 % of the mounds at least this high and wide detected): "
          + ("; ".join(f"{c['height_m_at_least']:g} m x {c['diameter_m_at_least']:g} m "
                       f"({c['detected']}/{c['mounds']})" for c in lim) or "none"))


def cmd_recon_verdict_bound(args: argparse.Namespace) -> int:
    from mound.jsonio import write_json
    from mound.recon import verdict_bound as vb

    if args.placements < 1:
        raise InputError(f"--placements: {args.placements}: must be >= 1")
    if args.ground_from and not args.whiten:
        raise InputError("--ground-from: only with --whiten")
    if args.place_within and not args.whiten:
        raise InputError("--place-within: only with --whiten")
    if not (math.isfinite(args.place_within) and 0 <= args.place_within <= 30):
        raise InputError(f"--place-within: {args.place_within}: expected 0 to 30 m")
    kind = "whitened" if args.whiten else "plain"
    thresholds = (vb.read_thresholds(args.thresholds_from, kind, args.place_within)
                  if args.thresholds_from else None)
    report = vb.judge(vb.measure(args.grids, args.placements, args.seed, args.whiten,
                                 args.ground_from, args.place_within), thresholds)
    g = report["goal_tumuli"]
    told = (f"centre told within {args.place_within:g} m" if args.place_within
            else "centre")
    print(f"oracle {kind} matched filter ({told} and relief told; true surface), thresholds "
          + ", ".join(f"{k} {v:.2f}" for k, v in report["thresholds"].items())
          + (" (given)" if thresholds else ""))
    for name in ("all", "clear", "masked", "on_dem", "on_synthetic"):
        print(f"  goal tumuli {name}: {g[name]['found']} of {g[name]['sites']} found")
    for k, v in report["null"].items():
        if v["above_threshold"] is not None:
            print(f"  null on {k} ground: {v['placements']} placements, "
                  f"{100 * v['above_threshold']:.1f} % above its threshold")
    if args.report:
        write_json(args.report, report)
    return 0


def cmd_recon_eval_verdict(args: argparse.Namespace) -> int:
    from mound.jsonio import write_json
    from mound.recon import verdict_model as vm
    from mound.recon.model_file import read_verdict_model

    model = read_verdict_model(args.model)
    dense_model = read_verdict_model(args.dense_model) if args.dense_model else model
    grids = [vm.load_grid(g) for g in args.grids]  # read once: merged and per grid
    # each grid by the model of its cloud; the merged report of the grids --model judges
    models = [dense_model if vm.grid_cloud(g) == "dense" else model for g in args.grids]
    merged = [r for m, rows in zip(models, grids, strict=True) if m is model for r in rows]
    if not merged:
        raise InputError("eval-verdict: every grid is of dense clouds: give their model as "
                         "--model")
    report = vm.evaluate(model, merged)
    _print_verdict_report(report)
    if args.paper:
        import tempfile

        with tempfile.TemporaryDirectory() as tmp:
            agree = [vm.paper_agreement(g, model, Path(tmp) / str(k), args.paper_sites)
                     for k, g in enumerate(args.grids)]
        tot = {k: sum(a[k] for a in agree) for k in (
            "sites", "judged", "agree", "paper_right", "learned_right", "paper_false_alarms",
            "paper_missed", "paper_failed")}
        report["paper_agreement"] = {**tot, "rows": [r for a in agree for r in a["rows"]]}
        print(f"  the paper's test (--reference) on {tot['judged']} sites: agrees with the "
              f"learned verdict on {tot['agree']}; right on {tot['paper_right']} (learned: "
              f"{tot['learned_right']}); {tot['paper_false_alarms']} false alarms, "
              f"{tot['paper_missed']} missed; {tot['paper_failed']} failed (ICP)")
    if args.figure:
        vm.figure(report, args.figure)
    if args.recall_figure:
        if "three_answers" not in report:
            raise InputError("--recall-figure: the model has no undecided band (three answers)")
        from mound.recon.verdict_band import recall_figure

        recall_figure(report["three_answers"], args.recall_figure,
                      ", ".join(vm.grid_label(g) for g in args.grids))
    if args.detection_figure:
        panels = [(vm.grid_label(g), vm.evaluate(m, rows))
                  for g, m, rows in zip(args.grids, models, grids, strict=True)]
        report["per_grid"] = [{"grid": str(g), "label": label,
                               "model": args.model if m is model else args.dense_model,
                               "detection_limit": r["detection_limit"],
                               "goal_no_mound": r["goal_no_mound"],
                               "goal_mounds_2m_15m": r["goal_mounds_2m_15m"],
                               "auc": r["auc"], "ece": r["ece"]}
                              for g, m, (label, r) in zip(args.grids, models, panels,
                                                          strict=True)]
        for label, r in panels:
            lim = r["detection_limit"]["limit"] or []
            print(f"  {label}: {r['goal_mounds_2m_15m']['right']}/"
                  f"{r['goal_mounds_2m_15m']['sites']} tumuli >= 2 m x 15 m, false alarms "
                  f"{r['goal_no_mound']['false_alarms']}/{r['goal_no_mound']['sites']}; "
                  ">= 95 % from " + (", ".join(f"{c['height_m_at_least']:g} m x "
                                               f"{c['diameter_m_at_least']:g} m" for c in lim)
                                     or "none"))
        vm.detection_figure(panels, args.detection_figure)
    if args.report:
        write_json(Path(args.report), report)
    return 0


def cmd_recon_figure(args: argparse.Namespace) -> int:
    from mound.recon import figures as recon_figures

    out = recon_figures.cloud_and_cameras(args.recon_dir, args.out)
    print(f"-> {out}")
    return 0


def cmd_recon_rasters(args: argparse.Namespace) -> int:
    from mound.recon import rasters

    doc = rasters.from_recon(Path(args.recon_dir), Path(args.out), args.resolution_m,
                             Path(args.cloud) if args.cloud else None,
                             args.ground_window_m, args.relief_sigma_m,
                             ortho=not args.no_orthophoto,
                             images_dir=Path(args.images) if args.images else None)
    print(f"{doc['crs']}, {doc['width']} x {doc['height']} cells of {doc['resolution_m']:g} m, "
          f"{100 * doc['coverage']:.1f} % covered -> {args.out}/"
          f"{{{','.join(doc['files'])}}}.tif, rasters.json")
    return 0


def cmd_sim_figures(args: argparse.Namespace) -> int:
    from mound.sim import figures as sim_figures

    out = Path(args.out_dir or args.site)
    scale = args.dpi_scale
    a = sim_figures.contact_sheet(args.site, out / "contact_sheet.png", dpi=int(80 * scale))
    b = sim_figures.scene_3d(args.site, out / "scene_3d.png", dpi=int(90 * scale))
    print(f"-> {a}, {b}")
    return 0


# The simulator's sizes of pits, trenches and confusers, and their azimuths (m or degrees).
SIM_SIZE_M = Bound(-1_000, 1_000)


def build_parser() -> argparse.ArgumentParser:
    p = Parser(prog="mound", description="mound-survey command line")
    sub = p.add_subparsers(dest="group", required=True, parser_class=Parser)

    data = sub.add_parser("data", help="public data sets").add_subparsers(
        dest="cmd", required=True, parser_class=Parser)
    f = data.add_parser("fetch", help="download Statlog into the cache ($MOUND_DATA)")
    f.add_argument("--url", help="archive URL (default: UCI)")
    f.set_defaults(func=cmd_fetch)

    cls = sub.add_parser("classify", help="coarse-search classifier").add_subparsers(
        dest="cmd", required=True, parser_class=Parser)
    b = cls.add_parser("bands", help="held-out comparison of the bands on sat.trn")
    b.add_argument("--seed", type=SEED.arg(), default=0)
    b.set_defaults(func=cmd_bands)
    t = cls.add_parser("train", help="train on sat.trn")
    g = t.add_mutually_exclusive_group()
    g.add_argument("--band", type=int, choices=range(4), default=coarse.DEFAULT_BAND)
    g.add_argument("--all", action="store_true", help="all 36 features")
    t.add_argument("--solver", choices=("gd", "lbfgs"), default="gd")
    t.add_argument("--l2", type=Bound(0, 1e6).arg(), default=coarse.DEFAULT_L2)
    t.add_argument("--out", required=True)
    t.set_defaults(func=cmd_train)
    e = cls.add_parser("eval", help="evaluate on sat.tst")
    e.add_argument("model")
    e.add_argument("--json", help="also write the figures as JSON")
    e.set_defaults(func=cmd_eval)

    fld = sub.add_parser("field", help="fields of candidate sites").add_subparsers(
        dest="cmd", required=True, parser_class=Parser)
    for name, func in (("make", cmd_field_make), ("standard", cmd_field_standard)):
        m = fld.add_parser(name, help="one field" if name == "make" else "seeds 0-9")
        if name == "make":
            m.add_argument("--seed", type=SEED.arg(), required=True)
            m.add_argument("--out", required=True)
            m.add_argument("--spacing", type=Bound(0, 100_000, "m", above=True).arg(), default=1.0,
                           help="grid spacing of the sites, m (1: the paper's field)")
            m.add_argument("--origin", help="LAT,LON[,ALT] of home (default: Bin Tepe, "
                           "38.5705,27.9862)")
            from mound.uav.terrain import add_arguments as add_terrain_arguments

            add_terrain_arguments(m)
        else:
            m.add_argument("--out-dir", required=True)
        m.add_argument("--model", help="classifier JSON (default: train the default band)")
        m.add_argument("--scan-cost", type=Bound(0, 100_000, "m").arg(),
                       help="node cost per site, m (default 1: the paper's)")
        m.add_argument("--scan-pattern", choices=("raster", "orbit", "both"),
                       help="derive each site's scan cost from this scan (the flight the "
                       "mission flies) and record it, with the take-off/landing climb")
        m.add_argument("--site-diameter", type=SITE_DIAMETER_M.arg(),
                       help="with --scan-pattern: the scan's scale, m (default 60)")
        m.add_argument("--altitude", type=HEIGHT_M.arg(),
                       help="with --scan-pattern: the raster's height, m (default: the "
                       "site diameter)")
        m.add_argument("--budget", type=BUDGET_M.arg(),
                       help="budget_m written, m (default 120, the paper's; with "
                       "--scan-pattern the aircraft's range, 14,400 m)")
        m.set_defaults(func=func)
    plan = sub.add_parser("plan", help="tour planning (Python side)").add_subparsers(
        dest="cmd", required=True, parser_class=Parser)
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

    simp = sub.add_parser("sim", help="site simulator (images with ground truth)"
                          ).add_subparsers(dest="cmd", required=True, parser_class=Parser)
    st = simp.add_parser("site", help="render a site's flight with its ground truth")
    st.add_argument("--preset", choices=("bin_tepe", "lab"), default="bin_tepe")
    st.add_argument("--mound", choices=("tumulus", "none"), default="tumulus",
                    help="none: the flat control (same ground, texture and flight)")
    st.add_argument("--profile", choices=("conical", "spherical_cap", "drum", "ploughed"))
    st.add_argument("--diameter", dest="diameter_m", type=SITE_DIAMETER_M.arg(), help="m")
    st.add_argument("--height", dest="height_m", type=Bound(0, 200, "m").arg(), help="m")
    st.add_argument("--erosion", dest="erosion_m", type=Bound(0, 200, "m").arg(), help="m")
    st.add_argument("--site-size", dest="size_m", type=Bound(0, 5_000, "m", above=True).arg(),
                    help="side of the site, m")
    st.add_argument("--resolution", dest="resolution_m", type=Bound(0.01, 100, "m").arg(),
                    help="grid spacing, m")
    st.add_argument("--pit", type=SIM_SIZE_M.arg(), nargs=3, metavar=("RADIUS", "DEPTH", "OFFSET"),
                    help="a looters' pit, m")
    st.add_argument("--trench", type=SIM_SIZE_M.arg(),
                    nargs=3, metavar=("WIDTH", "DEPTH", "AZIMUTH_DEG"),
                    help="a looters' trench through the top, m")
    st.add_argument("--offset", type=Bound(-5_000, 5_000, "m").arg(),
                    nargs=2, metavar=("EAST_M", "NORTH_M"),
                    help="the mound's centre off the site centre")
    st.add_argument("--slope", type=Bound(-360, 360, "deg").arg(),
                    nargs=2, metavar=("DEG", "AZIMUTH_DEG"),
                    help="ground rising towards the azimuth")
    st.add_argument("--dem", nargs=3, metavar=("DEM.tif", "X", "Y"),
                    help="real ground: the DEM's patch centred on X, Y (its CRS)")
    st.add_argument("--confuser", choices=terrain_confusers(),
                    help="something that is not a tumulus, at the site centre (--mound none)")
    st.add_argument("--confuser-size", type=SIM_SIZE_M.arg(),
                    nargs=4, default=(40.0, 10.0, 3.0, 0.0),
                    metavar=("LENGTH", "WIDTH", "HEIGHT", "AZIMUTH_DEG"))
    st.add_argument("--trees", type=Bound(0, 1_000, integer=True).arg(),
                    default=6, help="crowns in a group of trees")
    st.add_argument("--scan-diameter", type=SITE_DIAMETER_M.arg(),
                    help="the flight's own scale, m (default: the mound's diameter)")
    st.add_argument("--seed", type=SEED.arg(), default=1)
    st.add_argument("--out", required=True)
    st.add_argument("--pattern", choices=("raster", "orbit", "both"), default="both")
    st.add_argument("--size", type=IMAGE_PX.arg(), nargs=2, default=(1280, 960), metavar=("W", "H"))
    st.add_argument("--hfov-deg", type=Bound(1, 179, "deg").arg(), default=70.0)
    st.add_argument("--distortion", type=Bound(-10, 10).arg(), nargs=5, default=(0, 0, 0, 0, 0),
                    metavar=("K1", "K2", "P1", "P2", "K3"))
    st.add_argument("--altitude", type=HEIGHT_M.arg(), help="raster height above the site datum, m")
    st.add_argument("--orbit-images", type=Bound(3, 10_000, integer=True).arg())
    st.add_argument("--sun", type=Bound(-360, 360, "deg").arg(), nargs=2, default=(135.0, 40.0),
                    metavar=("AZIMUTH_DEG", "ELEVATION_DEG"))
    st.add_argument("--noise-sigma", type=Bound(0, 255).arg(), default=1.5, help="sensor noise, DN")
    st.add_argument("--vignetting", type=Bound(0, 1).arg(), default=0.15)
    st.add_argument("--gps-sigma", type=Bound(0, 1_000, "m").arg(), nargs=2, default=(1.0, 2.0),
                    metavar=("HORIZONTAL_M", "VERTICAL_M"))
    st.add_argument("--threads", type=THREADS.arg(), help="render threads (default: all cores)")
    st.add_argument("--figures", action="store_true",
                    help="also write contact_sheet.png and scene_3d.png into --out")
    st.add_argument("--jpeg", action="store_true",
                    help="JPEGs with EXIF (GPS, altitude, time, focal length) instead of PNGs")
    st.add_argument("--start-time", default="2026-06-01T09:00:00",
                    help="--jpeg: the first image's capture time (camera local time)")
    st.set_defaults(func=cmd_sim_site)
    sfl = simp.add_parser("flight", help="a planned survey's photos as one card folder "
                          "(DCIM/100MEDIA/DJI_NNNN.JPG with EXIF; transit frames included)")
    sfl.add_argument("plan", help="plan.json (mound_plan; every flight, in order)")
    sfl.add_argument("--sites", help="its sites document with the hidden truth (default: "
                     "sites.json beside the plan)")
    sfl.add_argument("--out", required=True, help="the card's folder")
    sfl.add_argument("--truth", help="also write what each file is (mound.card_truth v1)")
    sfl.add_argument("--start-time", default="2026-06-01T09:00:00",
                     help="take-off of the first flight (camera local time)")
    sfl.add_argument("--speed", type=SPEED_M_S.arg(), default=10.0, help="ground speed, m/s")
    sfl.add_argument("--transit-every-s", type=Bound(0, 3_600, "s").arg(), default=10.0,
                     help="a transit frame every this many seconds between sites (0: none)")
    sfl.add_argument("--sim-seed", type=SIM_SEED.arg(),
                     default=1, help="as the survey's --sim-seed")
    sfl.add_argument("--image-size", type=IMAGE_PX.arg(), nargs=2, default=(640, 480),
                     metavar=("W", "H"))
    sfl.add_argument("--scan-pattern", choices=("raster", "orbit", "both"), default="raster")
    sfl.add_argument("--site-diameter", type=SITE_DIAMETER_M.arg(), default=60.0,
                     help="as the survey's --site-diameter, m")
    sfl.add_argument("--threads", type=THREADS.arg(), help="render threads (default: all cores)")
    sfl.add_argument("--scan-factor", type=Bound(1, 100).arg(), default=1.0,
                     help="each site flown with a scan this many times as wide: the card of "
                     "a survey's second looks (PLAN: its second_look/plan.json, --sites its "
                     "sites.json, the factor its second_look/mission.json's scan_factor)")
    sfl.set_defaults(func=cmd_sim_flight)
    rc = sub.add_parser("recon", help="the 3-D stage (Python side)").add_subparsers(
        dest="cmd", required=True, parser_class=Parser)
    rf = rc.add_parser("figure", help="picture of a mound_recon output: cloud + cameras")
    rf.add_argument("recon_dir")
    rf.add_argument("--out", required=True, help="PNG file")
    rf.set_defaults(func=cmd_recon_figure)
    tv = rc.add_parser("train-verdict", help="learn the verdict model (mound.verdict_model v1) "
                       "from grids of measured sites (mound sim grid)")
    tv.add_argument("grids", nargs="+", help="training grid folders")
    tv.add_argument("--out", required=True, help="verdict_model.json")
    tv.add_argument("--heldout", nargs="*", default=[], help="held-out grid folders")
    tv.add_argument("--report", help="held-out report (JSON)")
    tv.add_argument("--figure", help="reliability diagram and detection limit (PNG)")
    tv.add_argument("--second-look-kind", choices=("wider", "lower"), default="wider",
                    help="which second look the grids flew to learn from (mound sim grid "
                    "--second-look-kind)")
    tv.set_defaults(func=cmd_recon_train_verdict)
    ev = rc.add_parser("eval-verdict", help="judge a verdict model on grids of measured sites")
    ev.add_argument("grids", nargs="+")
    ev.add_argument("--model", required=True)
    ev.add_argument("--dense-model", help="the model for the grids of dense clouds (their "
                    "grid.json says so; default: --model), e.g. data/verdict_model_dense.json; "
                    "the merged report is then of the other grids, each grid's own in "
                    "per_grid with --detection-figure")
    ev.add_argument("--report", help="report (JSON)")
    ev.add_argument("--figure", help="reliability diagram and detection limit (PNG)")
    ev.add_argument("--recall-figure", help="the tumuli confirmed mound, undecided and called "
                    "no mound by height class (PNG; a model with an undecided band)")
    ev.add_argument("--detection-figure", help="the detection rate over height x diameter, "
                    "one panel per grid (PNG)")
    ev.add_argument("--paper", action="store_true",
                    help="also run the paper's test (--reference) on every site and count "
                    "how often it agrees")
    ev.add_argument("--paper-sites", type=Bound(1, 100_000, integer=True).arg(),
                    help="at most this many sites for --paper")
    ev.set_defaults(func=cmd_recon_eval_verdict)
    vb = rc.add_parser("verdict-bound", help="the oracle's ceiling: goal tumuli a matched "
                       "filter told their centre, size and profile finds on the true surface at "
                       "1 %% false alarms (mound.verdict_bound v1)")
    vb.add_argument("grids", nargs="+", help="grid folders (mound sim grid)")
    vb.add_argument("--report", help="report (JSON)")
    vb.add_argument("--thresholds-from", help="judge against this report's thresholds (e.g. "
                    "the training grids') instead of the grids' own null")
    vb.add_argument("--placements", type=Bound(1, 1_000, integer=True).arg(), default=6,
                    help="null placements per site without a tumulus (default 6; the plain "
                    "filter's)")
    vb.add_argument("--whiten", action="store_true",
                    help="the whitened filter: the ground's covariance at each tumulus's "
                    "window learned from sites without a tumulus (see the module text)")
    vb.add_argument("--ground-from", nargs="+", metavar="GRID",
                    help="with --whiten: learn the ground's covariance from these grids' "
                    "sites without a tumulus (e.g. the training grids'), the null from the "
                    "grids judged")
    vb.add_argument("--place-within", type=Bound(0, 30, "m").arg(), default=0.0, metavar="M",
                    help="with --whiten: told the place only within M metres (the highest "
                    "output over centres 2 m apart within M of the true one; 0 to 30)")
    vb.add_argument("--seed", type=SEED.arg(), default=0)
    vb.set_defaults(func=cmd_recon_verdict_bound)
    rr = rc.add_parser("rasters", help="DSM, DTM, local relief model, hillshade and "
                       "orthophoto GeoTIFFs (UTM) of a metric mound_recon model")
    rr.add_argument("recon_dir")
    rr.add_argument("--out", required=True, help="output folder")
    rr.add_argument("--resolution-m", type=Bound(0.01, 100, "m").arg(),
                    default=0.25, help="cell size, m")
    rr.add_argument("--cloud", help="a PLY cloud in the model's frame instead of points.ply")
    rr.add_argument("--ground-window-m", type=Bound(0, 10_000, "m", above=True).arg(), default=80.0,
                    help="largest window of the ground filter (> the mounds' diameter), m")
    rr.add_argument("--relief-sigma-m", type=Bound(0, 10_000, "m", above=True).arg(), default=30.0,
                    help="Gaussian smoothing of the terrain for the relief model, m")
    rr.add_argument("--images", help="the model's images (default: recon.json's images_dir)")
    rr.add_argument("--no-orthophoto", action="store_true", help="skip orthophoto.tif")
    rr.set_defaults(func=cmd_recon_rasters)
    sg = simp.add_parser("grid", help="sites that look like the field (tumuli of every shape, "
                         "confusers), flown, reconstructed and measured: the verdict's data")
    sg.add_argument("--out", required=True, help="the grid's folder (resumable)")
    sg.add_argument("--sites", type=Bound(1, 99_999, integer=True).arg(), default=200)
    sg.add_argument("--seed", type=GRID_SEED.arg(), default=1, help="another seed: another grid")
    sg.add_argument("--size", type=IMAGE_PX.arg(), nargs=2, default=(320, 240), metavar=("W", "H"),
                    help="image size (small: the grid runs in minutes)")
    sg.add_argument("--dem", action="append", help="a DEM for real terrain patches, in a "
                    "CRS in metres; repeat it for several (each patch on one drawn among "
                    "those it fits on; default: the 1 m laser DEM in $MOUND_DATA/dem or "
                    "../shared/data/dem, an error when neither holds it); none: no terrain "
                    "patches (other draws)")
    sg.add_argument("--dem-part", choices=("all", "train", "heldout"), default="all",
                    help="where on each DEM the patches lie: train, the first 60 %% across "
                    "its longer axis (west or north); heldout, the rest; all (default)")
    sg.add_argument("--population", metavar="kazanlak|FILE",
                    help="draw each tumulus's base length, width, height and looters' trench "
                    "from a measured inventory (GeoJSON with length_m, width_m, height_m, "
                    "robber_trench; kazanlak: the Kazanlak inventory) instead of the uniform "
                    "ranges")
    sg.add_argument("--workers", type=WORKERS.arg(), default=2, help="sites at once")
    sg.add_argument("--threads", type=THREADS.arg(), default=1, help="threads per site")
    sg.add_argument("--pattern", choices=("raster", "both"), default="raster",
                    help="raster: the survey's scan (default); both: the full 40-image "
                    "flight (the raster and an oblique orbit)")
    sg.add_argument("--dense", action="store_true",
                    help="densify each site (mound_recon densify) and judge the dense cloud")
    sg.add_argument("--card", action="store_true",
                    help="reconstruct each site as from the aircraft's photo card (JPEGs "
                    "with EXIF, the lens refined about EXIF's values) instead of the simulator's "
                    "calibration")
    sg.add_argument("--flights-from", metavar="GRID",
                    help="take each site's flight and reconstruction from this grid (the same "
                    "--seed, --size, --pattern and --card): e.g. --dense on a sparse grid's "
                    "sites without flying them again")
    sg.add_argument("--remeasure", action="store_true",
                    help="rerun only the verdicts (after a change of the detector)")
    sg.add_argument("--second-look", action="store_true",
                    help="fly each site the first verdict leaves undecided again with a scan "
                    "twice as wide (NNNN/second/): what train-verdict learns the second "
                    "look's calibration from")
    sg.add_argument("--second-look-kind", choices=("wider", "lower"), default="wider",
                    help="with --second-look: wider (the scan twice as wide, NNNN/second/) or "
                    "lower (the same scan with the raster half as high: the ground sampled "
                    "twice as finely, NNNN/second_lower/)")
    sg.set_defaults(func=cmd_sim_grid)
    sf = simp.add_parser("figures", help="contact sheet and 3-D plot of a simulated site")
    sf.add_argument("site")
    sf.add_argument("--out-dir", help="default: the site directory")
    sf.add_argument("--dpi-scale", type=Bound(0.05, 10).arg(),
                    default=1.0, help="smaller files below 1")
    sf.set_defaults(func=cmd_sim_figures)

    uav_cli.add_parser(sub, Parser)
    scene_cli.add_parser(sub, Parser)
    photos_cli.add_parser(sub, Parser)

    bench = sub.add_parser("bench", help="benchmarks and reproductions").add_subparsers(
        dest="cmd", required=True, parser_class=Parser)
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
    return p


def help_argv(parser: argparse.ArgumentParser, argv: list[str]) -> list[str]:
    """`--help` anywhere on the command line: the help of the deepest (sub)command named
    before anything else, whatever the other arguments are."""
    path: list[str] = []
    for token in argv:
        subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        if not subs or token not in subs[0].choices:
            break
        path.append(token)
        parser = subs[0].choices[token]
    return [*path, "--help"]


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    try:
        parser = build_parser()
        if "-h" in argv or "--help" in argv:
            argv = help_argv(parser, argv)
        args = parser.parse_args(argv)
        scan = getattr(args, "scan_cost", None)
        budget = getattr(args, "budget", None)
        costs = [c for c in (scan if isinstance(scan, list) else [scan]) if c is not None]
        if min(costs, default=0) < 0 or (budget or 0) < 0:
            raise UsageError("--scan-cost and budgets must be >= 0")
        start = time.perf_counter()
        code: int = args.func(args)
        print(f"({time.perf_counter() - start:.2f} s)", file=sys.stderr)
        return code
    except Exception as e:
        return exit_for("mound", e)


if __name__ == "__main__":
    sys.exit(main())
