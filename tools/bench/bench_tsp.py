"""Benchmark (not a test): our LKH engine against elkai (the original LKH-3) on TSPLIB.

For every instance of ../shared/data/tsplib/optimal.csv (up to --max-n nodes) it runs
`mound_plan tsp FILE --runs R --seed S` and elkai on the same TSPLIB text with the same
RUNS and SEED, in this one script, and prints each tour length, the gap to the proven
optimum, the wall time of each and the time ratio ours/elkai. Our time includes process
start and file reading; elkai's is an in-process call.

    .venv/bin/python tools/bench/bench_tsp.py [--max-n 1000] [--runs 1] [--seed 1]
"""

from __future__ import annotations

import argparse
import csv
import math
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "python"))

from mound import native
from mound.paths import shared_data_dir


def read_coords(text: str) -> list[tuple[float, float]]:
    coords: list[tuple[float, float]] = []
    in_section = False
    for line in text.splitlines():
        line = line.strip()
        if line.startswith("NODE_COORD_SECTION"):
            in_section = True
            continue
        if in_section:
            if not line or line == "EOF":
                break
            _, x, y = line.split()[:3]
            coords.append((float(x), float(y)))
    return coords


def euc2d_length(coords: list[tuple[float, float]], tour: list[int]) -> int:
    total = 0
    for i, a in enumerate(tour):
        b = tour[(i + 1) % len(tour)]
        dx, dy = coords[a][0] - coords[b][0], coords[a][1] - coords[b][1]
        total += int(math.sqrt(dx * dx + dy * dy) + 0.5)
    return total


def run_elkai(text: str, runs: int, seed: int) -> tuple[list[int], float]:
    from elkai import _elkai  # the C extension: LKH-3 reading a TSPLIB problem from text

    params = f"RUNS = {runs}\nSEED = {seed}\nPROBLEM_FILE = :stdin:\n"
    start = time.perf_counter()
    tour = _elkai.solve_problem(params, text)
    return [v - 1 for v in tour], time.perf_counter() - start


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--max-n", type=int, default=100000)
    ap.add_argument("--runs", type=int, default=1)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--no-elkai", action="store_true")
    args = ap.parse_args()

    data = shared_data_dir() / "tsplib"
    with open(data / "optimal.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f) if int(r["n"]) <= args.max_n]
    rows.sort(key=lambda r: int(r["n"]))
    header = (
        f"{'instance':<10} {'n':>5} {'optimum':>8} {'ours':>8} {'gap%':>6} {'ours_s':>7} "
        f"{'elkai':>8} {'gap%':>6} {'elkai_s':>7} {'ratio':>6}"
    )
    print(f"runs={args.runs} seed={args.seed}")
    print(header)
    gaps: list[float] = []
    gaps_1000: list[float] = []
    egaps: list[float] = []
    ratios: list[float] = []
    for r in rows:
        name, n, opt = r["name"], int(r["n"]), int(r["optimal_length"])
        path = data / f"{name}.tsp"
        start = time.perf_counter()
        res = native.run_json(
            "mound_plan", ["tsp", str(path), "--runs", str(args.runs), "--seed", str(args.seed)]
        )
        ours_s = time.perf_counter() - start
        gap = 100.0 * (res["length"] - opt) / opt
        gaps.append(gap)
        if n <= 1000:
            gaps_1000.append(gap)
        line = f"{name:<10} {n:>5} {opt:>8} {res['length']:>8} {gap:>6.3f} {ours_s:>7.2f}"
        if not args.no_elkai:
            text = path.read_text()
            tour, elkai_s = run_elkai(text, args.runs, args.seed)
            elen = euc2d_length(read_coords(text), tour)
            egap = 100.0 * (elen - opt) / opt
            egaps.append(egap)
            ratios.append(ours_s / elkai_s)
            line += f" {elen:>8} {egap:>6.3f} {elkai_s:>7.2f} {ours_s / elkai_s:>6.2f}"
        print(line, flush=True)
    print(f"mean gap ours: {statistics.mean(gaps):.4f}% over {len(gaps)} instances; "
          f"up to 1,000 nodes: {statistics.mean(gaps_1000):.4f}% over {len(gaps_1000)}")
    if egaps:
        print(f"mean gap elkai: {statistics.mean(egaps):.4f}%; time ratio ours/elkai: "
              f"geometric mean {statistics.geometric_mean(ratios):.2f}, "
              f"min {min(ratios):.2f}, max {max(ratios):.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
