"""Benchmark (not a test): the planners on the public orienteering instances.

Classic sets: Tsiligirides 1-3 and Chao 64 and 66 (../shared/data/op: start -> end paths,
plain Euclidean distances), reference = the proven optimum of best_known.csv where
computed, else the literature best where known. OPLib: Gen1 and Gen3 under 500 nodes
(closed tours at the depot, TSPLIB metrics, `mound_plan op`), reference = EA4OP's score
(recomputed where the OPLib README flags a score fix; heuristic, so a lower bound);
newalg-ls runs 3 s at most per OPLib instance.
For each instance and algorithm: reward, reference, gap and time; then per suite and
algorithm how many instances reach the reference and the mean gap.

    .venv/bin/python tools/bench/bench_op.py [--suite classic oplib] [--algos ...] [--csv out.csv]
"""

from __future__ import annotations

import argparse
import csv
import json
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "python"))

from mound import native
from mound.paths import shared_data_dir
from mound.plan.sites import from_classic_op_file

SETS = ("Tsiligirides_1", "Tsiligirides_2", "Tsiligirides_3", "ChaoSet_64", "ChaoSet_66")


def reference(row: dict) -> float | None:
    for key in ("computed_optimum", "best_score"):
        try:
            return float(row[key])
        except (KeyError, ValueError):
            continue
    return None


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--algos", nargs="+",
                    default=["newalg", "newalg-ls", "alns", "greedy", "tsiligirides", "glv"])
    ap.add_argument("--suite", nargs="+", default=["classic", "oplib"])
    ap.add_argument("--csv")
    args = ap.parse_args()
    results: list[dict] = []
    if "classic" in args.suite:
        results += run_classic(args.algos)
    if "oplib" in args.suite:
        results += run_oplib([a for a in args.algos if a != "glv"])
    summarise(results)
    if args.csv:
        with open(args.csv, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(results[0]))
            w.writeheader()
            w.writerows(results)
    return 0


def run_oplib(algos: list[str]) -> list[dict]:
    data = shared_data_dir() / "oplib"
    with open(data / "ea4op_solutions_subset.csv", newline="") as f:
        ref = {(r["instance"], r["generation"]): float(r["recomputed_score"])
               for r in csv.DictReader(f)}
    results = []
    for gen in ("gen1", "gen3"):
        for path in sorted((data / "instances" / gen).glob("*.oplib")):
            name = path.name.split("-")[0]
            reference = ref.get((name, gen))
            line = f"oplib/{gen}/{name:<12} ref {reference:>7g}"
            for algo in algos:
                extra = ["--time-limit", "3"] if algo == "newalg-ls" else []
                res = native.run_json("mound_plan", ["op", str(path), "--algo", algo, *extra])
                gap = 100.0 * (reference - res["reward"]) / reference if reference else None
                results.append({"suite": f"oplib-{gen}", "instance": f"{gen}/{name}",
                                "algo": algo, "reward": res["reward"], "reference": reference,
                                "gap_pct": gap, "seconds": res["elapsed_s"]})
                line += f"  {algo} {res['reward']:>6g}"
            print(line, flush=True)
    return results


def run_classic(algos: list[str]) -> list[dict]:
    data = shared_data_dir() / "op"
    with open(data / "best_known.csv", newline="") as f:
        known = {r["instance"]: r for r in csv.DictReader(f)}
    results: list[dict] = []
    with tempfile.TemporaryDirectory() as tmp:
        for set_name in SETS:
            for path in sorted((data / set_name).glob("*.txt")):
                key = f"{set_name}/{path.name}"
                ref = reference(known.get(key, {}))
                site_file = Path(tmp) / "sites.json"
                site_file.write_text(json.dumps(from_classic_op_file(path)))
                line = f"{key:<58} ref {ref if ref is not None else '?':>6}"
                for algo in algos:
                    plan = native.run_json("mound_plan", [str(site_file), "--algo", algo])
                    gap = None if not ref else 100.0 * (ref - plan["reward"]) / ref
                    results.append({"suite": "classic", "instance": key, "algo": algo,
                                    "reward": plan["reward"],
                                    "reference": ref, "gap_pct": gap,
                                    "seconds": plan["elapsed_s"]})
                    line += f"  {algo} {plan['reward']:>5g}"
                print(line, flush=True)
    return results


def summarise(results: list[dict]) -> None:
    print()
    print(f"{'suite':<12} {'algorithm':<13} {'instances':>9} {'at ref':>7} {'above':>6} "
          f"{'mean gap %':>10} {'max gap %':>9} {'mean ms':>8} {'max ms':>8}")
    for suite in dict.fromkeys(r["suite"] for r in results):
        for algo in dict.fromkeys(r["algo"] for r in results if r["suite"] == suite):
            mine = [r for r in results if r["suite"] == suite and r["algo"] == algo]
            rs = [r for r in mine if r["gap_pct"] is not None]
            ms = [1000 * r["seconds"] for r in mine]
            at = sum(abs(r["gap_pct"]) <= 1e-9 for r in rs)
            above = sum(r["gap_pct"] < -1e-9 for r in rs)
            print(f"{suite:<12} {algo:<13} {len(rs):>9} {at:>7} {above:>6} "
                  f"{statistics.mean(r['gap_pct'] for r in rs):>10.3f} "
                  f"{max(r['gap_pct'] for r in rs):>9.3f} {statistics.mean(ms):>8.2f} "
                  f"{max(ms):>8.2f}")


if __name__ == "__main__":
    sys.exit(main())
