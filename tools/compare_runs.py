"""Are two survey runs the same? (`python tools/compare_runs.py BEFORE_DIR AFTER_DIR`)

How a refactor shows that it changed nothing: run `make demo` before and after, keep the
first run's folder (runs/survey), and compare the result files of the two — summary.json,
plan.json, sites.json, mission.json, every site's site_result.json and verdict.json —
value by value, numbers to 1e-9 relative, leaving out what differs from run to run
(timings, the worker, the date, the digests of the stages' keys, absolute paths). Prints
the files compared and every difference; exit 0 when there is none, 1 otherwise, 2 when a
folder is not a run.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

# Members that differ from run to run whatever the code: timings, where and when it ran.
RUN_TO_RUN = {"timings_s", "worker", "created_utc", "wall_s", "elapsed_s", "stages",
              "work_ticks", "cloud", "recon_dir", "key", "first_key"}


def differences(a: Any, b: Any, where: str = "") -> list[str]:
    """Where `a` and `b` differ (numbers to 1e-9 relative or absolute)."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for k in sorted(set(a) | set(b)):
            if k in RUN_TO_RUN or k.endswith("_s"):
                continue
            if k not in a or k not in b:
                out.append(f"{where}.{k}: only in {'after' if k not in a else 'before'}")
            else:
                out += differences(a[k], b[k], f"{where}.{k}")
        return out
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{where}: {len(a)} entries before, {len(b)} after"]
        return [d for i, (x, y) in enumerate(zip(a, b, strict=True))
                for d in differences(x, y, f"{where}[{i}]")]
    if isinstance(a, float) or isinstance(b, float):
        if isinstance(a, int | float) and isinstance(b, int | float) and math.isclose(
                a, b, rel_tol=1e-9, abs_tol=1e-9):
            return []
    elif a == b:
        return []
    return [f"{where}: {str(a)[:80]} before, {str(b)[:80]} after"]


def result_files(run: Path) -> list[str]:
    return ["summary.json", "plan.json", "sites.json", "mission.json",
            *sorted(str(p.relative_to(run)) for p in run.glob("sites/*/site_result.json")),
            *sorted(str(p.relative_to(run)) for p in run.glob("sites/*/recon/verdict.json"))]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("before", type=Path)
    p.add_argument("after", type=Path)
    a = p.parse_args(argv)
    for run in (a.before, a.after):
        if not (run / "summary.json").is_file():
            print(f"compare_runs: {run}: no summary.json (not a survey run)", file=sys.stderr)
            return 2
    files = result_files(a.before)
    found = []
    for f in files:
        if not (a.after / f).is_file():
            found.append(f"{f}: missing after")
            continue
        found += [f"{f}{d}" for d in differences(json.loads((a.before / f).read_text()),
                                                 json.loads((a.after / f).read_text()))]
    print(f"{len(files)} files compared, {len(found)} differences")
    for d in found:
        print(f"  {d}")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
