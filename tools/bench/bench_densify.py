"""Benchmark (not a test): `mound_recon densify` on the default simulated site (40 images
1280 x 960, the 60 m / 12 m tumulus) and its flat control, against the simulator's true
heightfield, with the sparse cloud of `mound_recon reconstruct` beside it.

    .venv/bin/python tools/bench/bench_densify.py [--reps 3] [--threads 2]
        [--sets tumulus,flat] [--out runs/bench_densify] [--figure PNG]
        [densify options after --]

For each cloud: the height error |z - heightfield(x, y)| (bilinear) after the similarity
that takes the reconstruction's camera centres onto the true ones (the GPS frame's own
error is the reconstruction's, not the dense stage's), its median and 90th percentile;
completeness: the share of 0.25 m cells (the heightfield's spacing) of the mound's
footprint (r < D/2; the same disc on the flat control) holding at least one point, and
of 1 m cells over the whole nadir raster area. Prints min and median densify wall time
over --reps; the reference system is the sparse cloud of the same run. With --figure: the
GeoTIFFs of each dense cloud (`mound recon rasters --cloud`, 0.25 m cells) drawn side by
side (orthophoto, hillshade, local relief model; one row a site), and the facts of one
GeoTIFF as gdalinfo gives them (driver, size, CRS, origin, pixel size, bands, nodata).
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "python"))

from mound.cli import main as mound_main
from mound.paths import REPO_ROOT, build_dir
from mound.ply import read_ply
from mound.recon.defaults import SIM_RECONSTRUCT

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_recon import aligned_height_errors


def tool(args: list[str]) -> None:
    p = subprocess.run([str(build_dir() / "mound_recon"), *args], capture_output=True, text=True,
                       check=False)
    if p.returncode != 0:
        raise SystemExit(f"mound_recon {args[0]} exit {p.returncode}: {p.stderr.strip()}")


def centres(doc: dict, key: str) -> dict[str, np.ndarray]:
    out = {}
    for im in doc["images"]:
        if key == "recon" and im.get("registered"):
            out[im["file"]] = np.array(im["centre"], dtype=float)
        elif key == "truth":
            out[Path(im["file"]).name] = np.array(im["centre_enu_m"], dtype=float)
    return out


def measure(xyz: np.ndarray, recon: dict, truth: dict, site: Path, diameter_m: float,
            raster_half_m: float) -> dict:
    p, e = aligned_height_errors(xyz, centres(recon, "recon"), centres(truth, "truth"), site)

    def covered(cell: float, inside: Callable[[np.ndarray, np.ndarray], np.ndarray]) -> float:
        n = int(np.ceil(raster_half_m / cell))
        edges = np.arange(-n, n + 1) * cell
        cx = 0.5 * (edges[:-1] + edges[1:])
        gx, gy = np.meshgrid(cx, cx)
        want = inside(gx, gy)
        h, _, _ = np.histogram2d(p[:, 1], p[:, 0], bins=[edges, edges])
        return float(((h > 0) & want).sum() / want.sum())

    return {"points": int(len(xyz)), "median_m": float(np.median(e)),
            "p90_m": float(np.percentile(e, 90)),
            "footprint_covered": covered(0.25, lambda x, y: np.hypot(x, y) < diameter_m / 2),
            "raster_area_covered_1m": covered(1.0, lambda x, y: np.ones_like(x, dtype=bool))}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", default="tumulus,flat")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", default="runs/bench_densify")
    ap.add_argument("--figure", help="write the docs' figure of the rasters here (docs/figures/)")
    ap.add_argument("densify_args", nargs="*", help="extra mound_recon densify options (after --)")
    a = ap.parse_args()
    out = REPO_ROOT / a.out
    results = {}
    for name in a.sets.split(","):
        site, recon, dense = out / name / "site", out / name / "recon", out / name / "dense"
        if not (site / "site.json").exists():
            assert mound_main(["sim", "site", "--mound", "none" if name == "flat" else "tumulus",
                               "--threads", str(a.threads), "--out", str(site)]) == 0
        if not (recon / "recon.json").exists():
            tool(["reconstruct", str(site / "images"), "--out", str(recon), "--camera",
                  str(site / "camera.json"), "--gps", str(site / "poses.json"), "--threads",
                  str(a.threads), *SIM_RECONSTRUCT.argv()])
        times = []
        for _ in range(a.reps):
            t0 = time.perf_counter()
            tool(["densify", str(recon), "--out", str(dense), "--threads", str(a.threads),
                  *a.densify_args])
            times.append(time.perf_counter() - t0)
        spec = json.loads((site / "site.json").read_text())
        truth = json.loads((site / "poses.json").read_text())
        recon_doc = json.loads((recon / "recon.json").read_text())
        dense_doc = json.loads((dense / "dense.json").read_text())
        diameter = spec["terrain"]["diameter_m"]
        half = 0.5 * diameter  # the nadir raster covers D x D
        row = {"densify_s": {"min": min(times), "median": statistics.median(times), "runs": times},
               "stages_s": dense_doc["timings_s"],
               "dense": measure(read_ply(dense / "dense.ply")[0], recon_doc, truth, site,
                                diameter, half),
               "sparse": measure(read_ply(recon / "points.ply")[0], recon_doc, truth, site,
                                 diameter, half)}
        results[name] = row
        d, sp = row["dense"], row["sparse"]
        t = row["densify_s"]
        print(f"{name}: densify {t['min']:.1f} s min, {t['median']:.1f} s "
              f"median of {a.reps} ({a.threads} threads)")
        for label, m in (("dense", d), ("sparse", sp)):
            print(f"  {label:6s} {m['points']:>9,d} points, height error median "
                  f"{m['median_m'] * 100:.1f} cm, p90 {m['p90_m'] * 100:.1f} cm; footprint cells "
                  f"(0.25 m) covered {m['footprint_covered']:.1%}, raster area (1 m cells) "
                  f"{m['raster_area_covered_1m']:.1%}")
        print(f"  dense / sparse: {d['points'] / sp['points']:.0f}x the points, median error "
              f"{d['median_m'] / sp['median_m']:.2f}x, footprint coverage "
              f"{d['footprint_covered'] / sp['footprint_covered']:.2f}x")
    (out / "bench_densify.json").write_text(json.dumps(results, indent=1) + "\n")
    if a.figure:
        figure(out, a.sets.split(","), Path(a.figure))
    return 0


def figure(out: Path, names: list[str], png: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import rasterio

    fig, axes = plt.subplots(len(names), 3, figsize=(11, 3.4 * len(names)), squeeze=False)
    for row, name in zip(axes, names, strict=True):
        rdir = out / name / "rasters"
        assert mound_main(["recon", "rasters", str(out / name / "recon"), "--cloud",
                           str(out / name / "dense" / "dense.ply"), "--resolution-m", "0.25",
                           "--out", str(rdir)]) == 0
        with rasterio.open(rdir / "orthophoto.tif") as ds:
            b = ds.bounds
            extent = (b.left, b.right, b.bottom, b.top)
            row[0].imshow(np.moveaxis(ds.read(), 0, 2), extent=extent)
        with rasterio.open(rdir / "hillshade.tif") as ds:
            row[1].imshow(ds.read(1, masked=True).filled(np.nan), cmap="gray", vmin=0, vmax=255,
                          extent=extent)
        with rasterio.open(rdir / "lrm.tif") as ds:
            im = row[2].imshow(ds.read(1, masked=True).filled(np.nan), cmap="RdBu_r", vmin=-4,
                               vmax=4, extent=extent)
        fig.colorbar(im, ax=row[2], label="local relief (m)")
        for ax, what in zip(row, ("orthophoto", "hillshade of the DSM", "local relief model"),
                            strict=True):
            ax.set_title(f"{name}: {what}", fontsize=9)
            ax.ticklabel_format(useOffset=False, style="plain")
            ax.tick_params(labelsize=6)
            ax.set_xlabel("easting (EPSG:32635, m)", fontsize=7)
        row[0].set_ylabel("northing (m)", fontsize=7)
    fig.tight_layout()
    fig.savefig(png, dpi=80)
    with rasterio.open(out / names[0] / "rasters" / "dsm.tif") as ds:
        t = ds.transform
        print(f"{names[0]}/rasters/dsm.tif: driver {ds.driver}, size {ds.width} x {ds.height}, "
              f"{ds.count} band {ds.dtypes[0]}, CRS {ds.crs} ({ds.crs.to_wkt()[:40]}...), "
              f"origin ({t.c:.3f}, {t.f:.3f}), pixel size ({t.a}, {t.e}), nodata {ds.nodata}, "
              f"band 1 '{ds.descriptions[0]}', compression {ds.compression}")
    print(f"-> {png}")


if __name__ == "__main__":
    sys.exit(main())
