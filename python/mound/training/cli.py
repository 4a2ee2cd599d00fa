"""`mound recon train-verdict | eval-verdict | terrain-domain | verdict-bound`: the
verdict's learning, added to the `recon` command group (mound.cli)."""

from __future__ import annotations

import argparse
import math
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, get_args

from mound.bounds import SEED, Bound
from mound.errors import InputError
from mound.jsonio import write_json

if TYPE_CHECKING:
    from mound.recon.verdict_band import Rate, ThreeAnswers
    from mound.training.verdict_eval import (
        GoalMounds,
        GoalNoMound,
        GroundRate,
        PaperAgreement,
        PaperCount,
        VerdictReport,
    )

# the held-out figures a trained model keeps of its report
HeldoutFigure = Literal["sites", "measured", "accuracy", "false_alarm_rate", "missed_rate",
                        "auc", "brier", "ece", "calibration", "goal_mounds_2m_15m",
                        "goal_no_mound", "old_rule_accuracy"]
HELDOUT_FIGURES: tuple[HeldoutFigure, ...] = get_args(HeldoutFigure)


def cmd_recon_terrain_domain(args: argparse.Namespace) -> int:
    """The model with the grids' terrain domain (verdict_blocks.terrain_domain) beside its
    other fields, checked by the model reader before it is written."""
    from mound.jsonio import load_json
    from mound.recon.model_file import check_verdict_model
    from mound.training import verdict_model as vm

    doc = dict(load_json(args.model))
    check_verdict_model(doc, args.model)
    measured = [r for g in args.grids for r in vm.load_grid(g) if r.measured]
    domain = vm.terrain_domain(measured, [str(Path(g)) for g in args.grids])
    if domain is None:
        raise InputError(f"{', '.join(args.grids)}: no measured site, or a verdict without "
                         "measurements.terrain (remeasure the grid: mound sim grid --remeasure)")
    doc["terrain_domain"] = domain
    check_verdict_model(doc, args.out)
    write_json(args.out, doc)
    for name, (lo, hi) in domain["ranges"].items():
        f = 180 / math.pi if name.endswith("_rad") else 1.0
        unit = "deg" if name.endswith("_rad") else "m"
        print(f"{name}: {f * lo:.3g} .. {f * hi:.3g} {unit}")
    print(f"terrain domain of {domain['sites']} sites -> {args.out}")
    return 0


def cmd_recon_train_verdict(args: argparse.Namespace) -> int:
    from mound.training import verdict_model as vm

    rows = [r for g in args.grids for r in vm.load_grid(g, args.second_look_kind)]
    names = vm.feature_names_of(rows)
    model = vm.train(rows, names, [str(Path(g)) for g in args.grids])
    t = model["trained"]
    print(f"trained on {t['sites']} sites ({t['with_rise']} with a rise, {t['mounds']} mounds): "
          f"l2 {t['l2']:g}, out-of-fold AUC {t['out_of_fold']['auc']:.3f}, ECE "
          f"{t['out_of_fold']['ece']:.3f}; threshold {model['threshold']:.2f}")

    def by_ground(gb: Mapping[str, Mapping[str, float]]) -> str:
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
    if "by_slope" in u:
        sb = u["trained"]["by_slope"]["out_of_fold"]
        bands = ", ".join(f"slope {math.degrees(b['site_slope_rad'][0]):.0f}-"
                          f"{math.degrees(b['site_slope_rad'][1]):.0f} deg: p in "
                          f"[{b['p_low']:.3f}, {b['p_high']:.3f})" for b in u["by_slope"])
        print(f"  by the site's slope ({bands}): out of fold (nested) "
              f"{sb['confident_misses']:.1f} confident misses, {sb['confident_false_alarms']:.1f}"
              f" confident false alarms, {sb['undecided']:.1f} sites undecided")
    if args.heldout:
        held = [r for g in args.heldout for r in vm.load_grid(g, args.second_look_kind)]
        report = vm.evaluate(vm.VerdictModel.of(model), held)
        model["heldout"] = {k: report[k] for k in HELDOUT_FIGURES}
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


def _print_three_answers(t: ThreeAnswers) -> None:
    def rate(d: Rate) -> str:
        lo, hi = d["rate_95ci"] or (math.nan, math.nan)
        return (f"{d['count']}/{d['of']} ({100 * (d['rate'] or 0):.1f} %, 95 % interval "
                f"{100 * lo:.1f}-{100 * hi:.1f} %)")

    u = t["undecided"]
    print(f"  three answers (undecided for p in [{t['band'][0]:.3f}, {t['band'][1]:.3f})"
          + (", or its band by the site's slope" if t.get("band_by_slope") else "") + "): "
          f"confident misses {rate(t['confident_misses'])}; confident false alarms "
          f"{rate(t['confident_false_alarms'])}; undecided {rate(u)}"
          + (f", of them tumuli {u['tumulus_share']:.2f} against mean p {u['mean_p']:.2f}"
             if u["of"] and u["count"] else ""))
    fr = t["frontier"]
    b = fr["best_within_undecided"]
    least = ("no band" if b is None else
             f"{100 * b['confident_misses']:.1f} % confident misses and "
             f"{100 * b['confident_false_alarms']:.1f} % confident false alarms "
             f"({b['times_the_goals']:.1f} x the goals)")
    print(f"  the frontier (any band, chosen on these sites: a bound): the goals' confident "
          f"errors need {100 * fr['undecided_at_goals']:.1f} % undecided; with <= "
          f"{100 * fr['at_most_undecided']:.0f} % undecided the least is {least}")
    if "terrain" in t:
        te = t["terrain"]
        would = te["would_be"]
        print(f"  terrain: {te['outside']} sites ({te['tumuli_outside']} with a tumulus) on "
              f"ground outside the model's domain, undecided (by p alone {would['mound']} "
              f"mound, {would['no_mound']} no_mound, {would['undecided']} undecided)")
        if "frontier_inside_domain" in t:
            fi = t["frontier_inside_domain"]
            print(f"  the frontier with the terrain domain: the goals need "
                  f"{100 * fi['undecided_at_goals']:.1f} % undecided")
    f = t["field_recall"]["all"]
    print("  tumuli confirmed mound (two answers' mound) by height: " + "; ".join(
        f"{k} {c['confirmed']['count']}/{c['tumuli']} ({c['two_answer_mound']['count']})"
        for k, c in f["by_height"].items()) + f"; all {f['all']['confirmed']['count']}/"
        f"{f['all']['tumuli']} ({f['all']['two_answer_mound']['count']})")


def _print_verdict_report(r: VerdictReport) -> None:
    g, n = r["goal_mounds_2m_15m"], r["goal_no_mound"]
    cal = r["calibration"]
    print(f"held-out: {r['measured']} of {r['sites']} sites measured; accuracy "
          f"{r['accuracy']:.3f} (old rule {r['old_rule_accuracy']:.3f}); AUC {r['auc']:.3f}, "
          f"Brier {r['brier']:.3f}, ECE {r['ece']:.3f} (a calibrated forecast on these sites: "
          f"<= {cal['ece_if_calibrated_95']:.3f} in 95 % of draws; p = {cal['p_value']:.2f})")

    def ci(d: GoalMounds | GoalNoMound | GroundRate) -> str:
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
    from mound.training import verdict_bound as vb

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
    from mound.recon.model_file import read_verdict_model
    from mound.training import verdict_model as vm

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
        def total(k: PaperCount) -> int:
            return sum(a[k] for a in agree)

        tot: PaperAgreement = {
            "sites": total("sites"), "judged": total("judged"), "agree": total("agree"),
            "paper_right": total("paper_right"), "learned_right": total("learned_right"),
            "paper_false_alarms": total("paper_false_alarms"),
            "paper_missed": total("paper_missed"), "paper_failed": total("paper_failed"),
            "rows": [r for a in agree for r in a["rows"]]}
        report["paper_agreement"] = tot
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


def add_commands(rc: Any) -> None:
    """The learning's commands in the `recon` group `rc`."""
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
    td = rc.add_parser("terrain-domain", help="write into a verdict model the ground its "
                       "training sites stood on (terrain_domain), measured on grids drawn as its "
                       "training grids were")
    td.add_argument("grids", nargs="+", help="grid folders (mound sim grid; their verdicts "
                    "measure the sites' terrain)")
    td.add_argument("--model", required=True, help="the verdict model (mound.verdict_model v1)")
    td.add_argument("--out", required=True, help="the model with its terrain_domain")
    td.set_defaults(func=cmd_recon_terrain_domain)
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
