"""How long the survey's pages take to open in headless Chromium, and how big the report is.

    .venv/bin/python tools/bench/bench_report.py RUN_DIR [--reps 5]

Times `chromium --headless --dump-dom` (process start to the DOM dumped, the page's own
`data-ready` set) for report.html (the reference: the static page), map.html and each
site's site3d.html, min and median of the repetitions, and sums the report's files
(report.html, report/, map.html, site3d.html, map/). Speed is measured here, not in tests.
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def load_s(chromium: str, url: str, profile: Path) -> float:
    t0 = time.perf_counter()
    r = subprocess.run([chromium, "--headless", "--no-sandbox", "--disable-gpu",
                        f"--user-data-dir={profile}", "--window-size=1200,800",
                        "--virtual-time-budget=10000", "--dump-dom", url],
                       capture_output=True, text=True, timeout=120)
    dt = time.perf_counter() - t0
    if r.returncode != 0 or 'data-ready="1"' not in r.stdout and "report.html" not in url:
        sys.exit(f"bench_report: {url} did not load: {r.stderr[-500:]}")
    return dt


def size_mb(paths: list[Path]) -> float:
    total = 0
    for p in paths:
        if p.is_file():
            total += p.stat().st_size
        elif p.is_dir():
            total += sum(f.stat().st_size for f in p.rglob("*") if f.is_file())
    return total / 1e6


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir", type=Path)
    ap.add_argument("--reps", type=int, default=5)
    a = ap.parse_args()
    chromium = shutil.which("chromium")
    if chromium is None:
        sys.exit("bench_report: chromium not found (tools/setup.sh)")
    run = a.run_dir.resolve()
    sites = sorted(p.stem for p in (run / "map" / "sites").glob("*.js"))
    pages = [("report.html", run / "report.html", ""), ("map.html", run / "map.html", "")]
    pages += [(f"site3d.html#{s}", run / "site3d.html", "#" + s) for s in sites[:3]]
    ref = None
    with tempfile.TemporaryDirectory() as tmp:
        for name, path, frag in pages:
            times = [load_s(chromium, path.as_uri() + frag, Path(tmp) / f"p{k}")
                     for k in range(a.reps)]
            mn, md = min(times), statistics.median(times)
            ref = ref or md
            print(f"{name:24s} min {mn:6.2f} s  median {md:6.2f} s  ({md / ref:4.2f}x report.html)")
    print(f"report files: {size_mb([run / 'report.html', run / 'report']):.1f} MB static, "
          f"{size_mb([run / 'map.html', run / 'site3d.html', run / 'map']):.1f} MB map and "
          f"3-D viewer ({len(sites)} sites)")


if __name__ == "__main__":
    main()
