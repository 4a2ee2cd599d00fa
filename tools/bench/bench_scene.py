#!/usr/bin/env python3
"""Speed and memory of `mound scene score` on a large scene (not a test).

Tiles the 40 Kazanlak IKONOS stamps (each flipped/transposed at random) into one
SIZE x SIZE 4-band float32 GeoTIFF (tiled, DEFLATE), learns a model on the stamps, then
scores the big scene with the compiled kernel (`mound_scene`) (a) on local threads and
(b) on a separately started Dask scheduler with 2 workers (one thread each), REPS times
each, and (c) with the numpy reference engine on local threads (`--engine numpy`, REF_REPS
times: the reference system of the same script; every line prints its speed-up over it):
wall time min / median, peak RSS of the scoring process (and of the workers), Mpx/s.

    .venv/bin/python tools/bench/bench_scene.py [--size 10000] [--reps 3] [--ref-reps 1]
        [--strides 1,2,3]

The scene is built in a child process: a child started from this one inherits its peak
RSS in Linux's accounting (ru_maxrss), which would report the builder's 1.4 GB for every
run. The kernel's processes (`mound_scene --serve`, one per scoring thread) are the scoring
process's children: their peak is reported beside it.
"""

from __future__ import annotations

import argparse
import glob
import multiprocessing
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import rasterio
from rasterio.transform import from_origin
from rasterio.windows import Window

ROOT = Path(__file__).resolve().parents[2]
VENV = ROOT / ".venv" / "bin"


def data_dir() -> Path:
    return Path(os.environ.get("MOUND_DATA", ROOT.parent / "shared" / "data")) / "kazanlak"


def build_scene(path: Path, size: int, seed: int = 0) -> None:
    stamps = []
    for p in sorted(glob.glob(str(data_dir() / "stamps" / "*.tif"))):
        with rasterio.open(p) as ds:
            stamps.append(ds.read()[:, :250, :250])
    rng = np.random.default_rng(seed)
    profile = {"driver": "GTiff", "width": size, "height": size, "count": 4,
               "dtype": "float32", "crs": "EPSG:32635", "nodata": -9999.0,
               "transform": from_origin(366000.0, 4760000.0, 1.0, 1.0), "tiled": True,
               "blockxsize": 512, "blockysize": 512, "compress": "deflate",
               "BIGTIFF": "YES"}
    with rasterio.open(path, "w", **profile) as ds:
        for k, d in enumerate(("blue", "green", "red", "nir"), start=1):
            ds.set_band_description(k, d)
        for r0 in range(0, size, 250):
            row = []
            for _ in range(0, size, 250):
                s = stamps[rng.integers(len(stamps))]
                if rng.integers(2):
                    s = s[:, ::-1, :]
                if rng.integers(2):
                    s = s[:, :, ::-1]
                if rng.integers(2):
                    s = s.transpose(0, 2, 1)
                row.append(s)
            strip = np.concatenate(row, axis=2)[:, :, :size]
            h = min(250, size - r0)
            ds.write(strip[:, :h], window=Window(0, r0, size, h))


def run(cmd: list[str]) -> tuple[float, float, float]:
    """Wall seconds, the process's own peak RSS and its children's largest (GB)."""
    t = time.perf_counter()
    with tempfile.TemporaryFile() as err:
        p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=err)
        kids: dict[int, float] = {}
        while p.poll() is None:  # the servers' peaks, read while they live
            for pid in _children(p.pid):
                kids[pid] = max(kids.get(pid, 0.0), rss_gb(pid))
            time.sleep(0.5)
        wall = time.perf_counter() - t
        own = _own_peak.get(p.pid, float("nan"))
        if p.returncode != 0:
            err.seek(0)
            sys.exit(f"failed: {' '.join(cmd)}\n{err.read().decode()[-2000:]}")
    return wall, own, max(kids.values(), default=0.0)


_own_peak: dict[int, float] = {}


def _children(pid: int) -> list[int]:
    _own_peak[pid] = max(_own_peak.get(pid, 0.0), rss_gb(pid))
    out = []
    for task in Path(f"/proc/{pid}/task").glob("*"):  # a thread's children are its own
        try:
            out += [int(x) for x in (task / "children").read_text().split()]
        except OSError:
            pass
    return out


def rss_gb(pid: int) -> float:
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1e6
    except OSError:
        pass
    return float("nan")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=10_000)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--ref-reps", type=int, default=1, help="runs of the numpy reference")
    ap.add_argument("--strides", default="1,2,3", help="output strides, m")
    ap.add_argument("--work", default=None)
    a = ap.parse_args()
    work = Path(a.work or tempfile.mkdtemp(prefix="bench_scene."))
    work.mkdir(parents=True, exist_ok=True)
    scene = work / f"tiled_{a.size}.tif"
    if not scene.exists():
        t = time.perf_counter()
        child = multiprocessing.Process(target=build_scene, args=(scene, a.size))
        child.start()
        child.join()
        if child.exitcode != 0:
            sys.exit("building the scene failed")
        print(f"scene {a.size} x {a.size} x 4 float32 ({4 * 4 * a.size ** 2 / 1e9:.2f} GB "
              f"of pixels) built in {time.perf_counter() - t:.0f} s -> {scene}")
    model = work / "model.json"
    if not model.exists():
        stamps = sorted(glob.glob(str(data_dir() / "stamps" / "*.tif")))
        subprocess.run([str(VENV / "mound"), "scene", "train", *stamps, "--labels",
                        str(data_dir() / "mounds.geojson"), "--band-names",
                        "blue,green,red,nir", "--out", str(model)], check=True,
                       capture_output=True)
    mpx = a.size * a.size / 1e6
    for stride in (float(x) for x in a.strides.split(",")):
        bench_stride(a, work, scene, model, stride, mpx)


def bench_stride(a: argparse.Namespace, work: Path, scene: Path, model: Path, stride: float,
                 mpx: float) -> None:
    base = [str(VENV / "mound"), "scene", "score", str(scene), "--model", str(model),
            "--stride-m", str(stride), "--candidates", "200"]
    rows = {}
    tag = f"s{stride:g}_"
    reference = [run([*base, "--out", str(work / f"{tag}numpy{k}"), "--threads", "2",
                      "--engine", "numpy"]) for k in range(a.ref_reps)]
    rows["numpy reference, 2 threads"] = reference
    rows["kernel, 2 threads"] = [run([*base, "--out", str(work / f"{tag}local{k}"),
                                      "--threads", "2"]) for k in range(a.reps)]
    sched = subprocess.Popen([str(VENV / "dask"), "scheduler", "--port", "8799",
                              "--dashboard-address", ":0", "--no-show"],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    workers = [subprocess.Popen([str(VENV / "dask"), "worker", "tcp://127.0.0.1:8799",
                                 "--nthreads", "1", "--memory-limit", "1.5GB",
                                 "--dashboard-address", ":0", "--no-nanny"],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
               for _ in range(2)]
    time.sleep(6)
    try:
        rows["kernel, Dask + 2 workers"] = [
            run([*base, "--out", str(work / f"{tag}dask{k}"), "--scheduler",
                 "tcp://127.0.0.1:8799"]) for k in range(a.reps)]
        worker_rss = max(rss_gb(w.pid) for w in workers)
        server_rss = max((rss_gb(c) for w in workers for c in _children(w.pid)), default=0.0)
    finally:
        for p in (*workers, sched):
            p.terminate()
        for p in (*workers, sched):  # a worker still closing would join the next run's
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
    same = _same_candidates(work / f"{tag}numpy0", work / f"{tag}local0")
    ref = float(np.median([w for w, _, _ in reference]))
    print(f"scoring {a.size} x {a.size} px ({mpx:.0f} Mpx), stride {stride:g} m, "
          f"{os.cpu_count()} cores, min / median of {a.reps} runs "
          f"({a.ref_reps} of the reference); kernel vs reference: {same}")
    for name, rs in rows.items():
        walls = [w for w, _, _ in rs]
        med = float(np.median(walls))
        kids = max(k for _, _, k in rs)
        print(f"  {name:<28} wall {min(walls):6.1f} / {med:6.1f} s; {mpx / med:5.2f} Mpx/s "
              f"(median); peak RSS {max(r for _, r, _ in rs):.2f} GB"
              + (f" + {kids:.2f} GB per kernel" if kids else "")
              + f"; {ref / med:.2f} x the numpy reference")
    print(f"  Dask workers' peak RSS {worker_rss:.2f} GB each (+ {server_rss:.2f} GB kernel)")


def _same_candidates(ref_dir: Path, dir_: Path) -> str:
    """The candidates and p rasters of two runs compared. The bench's scene repeats its
    stamps, so some candidates' p agree to ~1e-14 at two places: their ranks may swap."""
    import json

    a = json.loads((ref_dir / "candidates.geojson").read_text())["features"]
    b = json.loads((dir_ / "candidates.geojson").read_text())["features"]
    pos_a = [(f["properties"]["row"], f["properties"]["col"]) for f in a]
    pos_b = [(f["properties"]["row"], f["properties"]["col"]) for f in b]
    p_a = {q: f["properties"]["p_mound"] for q, f in zip(pos_a, a, strict=True)}
    p_b = {q: f["properties"]["p_mound"] for q, f in zip(pos_b, b, strict=True)}
    swapped = [k for k in range(min(len(a), len(b))) if pos_a[k] != pos_b[k]]
    ties = all(abs(p_a[pos_a[k]] - p_b[pos_b[k]]) < 1e-12 for k in swapped)
    dp = max((abs(p_a[q] - p_b[q]) for q in p_a if q in p_b), default=0.0)
    with rasterio.open(ref_dir / "p_mound.tif") as d1, rasterio.open(dir_ / "p_mound.tif") as d2:
        raster = float(np.abs(d1.read(1).astype(np.float64) - d2.read(1)).max())
    order = ("in the same order" if not swapped else
             f"{len(swapped)} ranks swapped between p equal to 1e-12" if ties else
             f"{len(swapped)} ranks DIFFERENT")
    same = "the same" if set(pos_a) == set(pos_b) else "DIFFERENT"
    return (f"{same} {len(a)} candidates, {order}, p within {dp:.1e}, p raster within "
            f"{raster:.1e}")


if __name__ == "__main__":
    main()
