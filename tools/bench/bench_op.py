"""Benchmark (not a test): the planners on the classic orienteering sets.

Tsiligirides sets 1-3 and Chao sets 64 and 66 (../shared/data/op: start -> end paths,
plain Euclidean distances). For each instance and algorithm: our reward, the reference (the
proven optimum of best_known.csv where computed, else the literature best where known), the
gap and the time; then per algorithm how many instances reach the reference and the mean
gap.

    .venv/bin/python tools/bench/bench_op.py [--algos newalg newalg-ls ...] [--csv out.csv]
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

SETS = ("Tsiligirides_1", "Tsiligirides_2", "Tsiligirides_3", "ChaoSet_64", "ChaoSet_66")


def as_sites(path: Path) -> dict:
    rows = [ln.split() for ln in path.read_text().splitlines() if ln.strip()]
    pts = [(float(x), float(y), float(s)) for x, y, s in rows[1:]]
    return {
        "schema": "mound.sites", "version": 1,
        "home": {"id": "start", "x_m": pts[0][0], "y_m": pts[0][1]},
        "end": {"id": "end", "x_m": pts[1][0], "y_m": pts[1][1]},
        "budget_m": float(rows[0][0]),
        "sites": [{"id": f"n{i}", "x_m": x, "y_m": y, "reward": s}
                  for i, (x, y, s) in enumerate(pts[2:], start=2)],
    }


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
                    default=["newalg", "newalg-ls", "greedy", "tsiligirides", "glv"])
    ap.add_argument("--csv")
    args = ap.parse_args()
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
                site_file.write_text(json.dumps(as_sites(path)))
                line = f"{key:<58} ref {ref if ref is not None else '?':>6}"
                for algo in args.algos:
                    plan = native.run_json("mound_plan", [str(site_file), "--algo", algo])
                    gap = None if not ref else 100.0 * (ref - plan["reward"]) / ref
                    results.append({"instance": key, "algo": algo, "reward": plan["reward"],
                                    "reference": ref, "gap_pct": gap,
                                    "seconds": plan["elapsed_s"]})
                    line += f"  {algo} {plan['reward']:>5g}"
                print(line, flush=True)
    print()
    print(f"{'algorithm':<13} {'instances':>9} {'at ref':>7} {'mean gap %':>10} "
          f"{'max gap %':>9} {'mean ms':>8} {'max ms':>8}")
    for algo in args.algos:
        rs = [r for r in results if r["algo"] == algo and r["gap_pct"] is not None]
        ms = [1000 * r["seconds"] for r in results if r["algo"] == algo]
        at = sum(r["gap_pct"] <= 1e-9 for r in rs)
        print(f"{algo:<13} {len(rs):>9} {at:>7} {statistics.mean(r['gap_pct'] for r in rs):>10.3f} "
              f"{max(r['gap_pct'] for r in rs):>9.3f} {statistics.mean(ms):>8.2f} {max(ms):>8.2f}")
    above = [r for r in results if r["gap_pct"] is not None and r["gap_pct"] < -1e-9]
    for r in above:
        print(f"above the reference (a better solution than known?): {r}")
    if args.csv:
        with open(args.csv, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(results[0]))
            w.writeheader()
            w.writerows(results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
