"""Benchmark (not a test): the site simulator's default sequence (40 images 1280x960).

Simulates the default tumulus site once (terrain, texture, job files), then renders its job
with build/mound_render at 1 thread and at all cores, --reps times each, and prints the
median wall time of each stage, the per-image time, the thread speed-up (ratio against the
1-thread run in this same script) and the ratio of the whole sequence to the one-minute
budget of the issue.

    .venv/bin/python tools/bench/bench_render.py [--reps 3] [--out runs/bench_render]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "python"))

from mound import native
from mound.sim import site as sim


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--out", default="runs/bench_render")
    args = ap.parse_args()
    out = Path(args.out)
    start = time.perf_counter()
    site = sim.simulate(sim.SimSpec(), out)
    total = time.perf_counter() - start
    n = site["stats"]["images"]
    t = site["timings"]
    print(f"default sequence: {n} images {site['sim']['width_px']}x{site['sim']['height_px']}, "
          f"{site['stats']['reference_points']} terrain vertices")
    print(f"simulate() once: {total:.2f} s (terrain {t['terrain_s']:.2f}, texture "
          f"{t['texture_s']:.2f}, files {t['write_s']:.2f}, render {t['render_s']:.2f})")
    cores = os.cpu_count() or 1
    medians = {}
    for threads in sorted({1, cores}):
        times = []
        for _ in range(args.reps):
            r = native.run_json("mound_render", [str(out / "render.json"), "--out",
                                                 str(out / "rerender"), "--threads", str(threads)])
            times.append(r["elapsed_s"])
        medians[threads] = statistics.median(times)
        print(f"mound_render --threads {threads}: median {medians[threads]:.2f} s over "
              f"{args.reps} (min {min(times):.2f}), {medians[threads] / n * 1000:.0f} ms/image")
    if cores > 1:
        print(f"speed-up {cores} threads / 1 thread: {medians[1] / medians[cores]:.2f}x")
    whole = total - t["render_s"] + medians[cores]
    print(f"whole sequence (simulate with render at {cores} threads): {whole:.1f} s = "
          f"{whole / 60:.2f} of the one-minute budget")
    return 0


if __name__ == "__main__":
    sys.exit(main())
