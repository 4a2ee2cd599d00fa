"""Benchmark (not a test): mound_recon reconstruct against ground truth and against COLMAP
(PyPI pycolmap, its incremental and global mappers) on the same images in the same run.

    .venv/bin/python tools/bench/bench_recon.py [--sets fountain,caliterra,sim] [--colmap]
        [--reps 1] [--threads 2] [--features sift|klt] [--recall] [--ours "FLAGS"]
        [--matching auto|exhaustive|sequential|retrieval]
        [--out runs/bench_recon]

fountain: Strecha fountain-P11 (11 images 3072 x 2048, K.txt): registered images and the
  camera-centre error after a similarity to the ground-truth cameras (ground-truth units).
caliterra: 40 nadir drone photos (EXIF intrinsics and GPS): registered, reprojection error,
  the GPS residual of the metric fit.
sim, flat: the default simulated site (40 images 1280 x 960, tumulus, camera.json + GPS)
  and its flat control;
survey, survey_flat: a site as the survey flies and simulates it (18 raster images 640 x 480,
  camera.json + the poses' noisy GPS, --max-features 4000 as the driver's; a tumulus of
  the height the driver draws for site s023 of field 0, and flat ground), simulated into
  --out once:
  centre error after a similarity to the truth, and the cloud's height error against the
  true heightfield.
With --recall, ours runs once more with exact nearest neighbours (`--matcher exact`, brute
force) on the same pairs: the share of its putative and verified matches the default
matcher keeps, and the camera centres the exact matches give.
Prints min and median wall time over --reps and, with --colmap, pycolmap's figures and the
time ratio (pycolmap / ours) beside ours, for each of --colmap-mappers: COLMAP's
incremental mapper and its global one (GLOMAP), each from feature extraction on.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "python"))

from mound.geometry.align import apply, umeyama
from mound.paths import REPO_ROOT, build_dir, shared_data_dir
from mound.ply import read_ply
from mound.sim.terrain import load_site_heightfield


def centre_errors(est: dict[str, np.ndarray], truth: dict[str, np.ndarray]) -> np.ndarray:
    names = sorted(set(est) & set(truth))
    a = np.array([est[n] for n in names])
    b = np.array([truth[n] for n in names])
    s, r, t = umeyama(a, b)
    return np.linalg.norm(apply(s, r, t, a) - b, axis=1)


def aligned_height_errors(xyz: np.ndarray, est: dict[str, np.ndarray],
                          truth: dict[str, np.ndarray], site: Path
                          ) -> tuple[np.ndarray, np.ndarray]:
    """The cloud mapped by the similarity that takes the estimated camera centres onto the
    true ones, and |z - heightfield| (bilinear) of its points over the grid."""
    names = sorted(set(est) & set(truth))
    s, r, t = umeyama(np.array([est[n] for n in names]), np.array([truth[n] for n in names]))
    p = apply(s, r, t, xyz)
    hf = load_site_heightfield(site)
    ok = hf.covers(p[:, 0], p[:, 1])
    return p, np.abs(p[ok, 2] - hf.height_at(p[ok, 0], p[ok, 1]))


def cloud_error_aligned(xyz: np.ndarray, est: dict[str, np.ndarray],
                        truth: dict[str, np.ndarray], site: Path) -> str:
    """Median and 90th percentile of aligned_height_errors."""
    p, e = aligned_height_errors(xyz, est, truth, site)
    return (f"median {np.median(e):.3f} m, 90th percentile {np.percentile(e, 90):.3f} m "
            f"({len(e) / len(p):.1%} of the points over the grid)")


def strecha_centres(folder: Path) -> dict[str, np.ndarray]:
    out = {}
    for f in sorted((folder / "gt_dense_cameras").glob("*.camera")):
        lines = [line for line in f.read_text().splitlines() if line.strip()]
        rows = [list(map(float, line.split())) for line in lines]
        out[f.name.replace(".camera", "")] = np.array(rows[7])  # K(3), zeros, R(3), centre
    return out


BIN: list[Path] = []  # --bin: another build's mound_recon


def survey_site(out: Path, mound: bool) -> Path:
    """The survey's site s023 of field 0 (index 22), simulated as the driver does."""
    from mound.formats.sites import Site, Truth
    from mound.geometry.geodesy import Origin
    from mound.sim import site as sim
    from mound.sim.card import survey_site_spec

    site = out / ("survey_site" if mound else "survey_site_flat")
    if not (site / "poses.json").exists():
        spec, _ = survey_site_spec(Site("s023", 0.0, 0.0, 0.0, truth=Truth(mound)), 22,
                                   Origin(38.5705, 27.9862, 95.0), 1, (640, 480), "raster",
                                   60.0)
        sim.simulate(spec, site)
    return site


def run_ours(images: Path, out: Path, args: list[str], threads: int) -> tuple[float, dict]:
    start = time.perf_counter()
    tool = BIN[0] if BIN else build_dir() / "mound_recon"
    r = subprocess.run([str(tool), "reconstruct", str(images), "--out",
                        str(out), "--threads", str(threads), *args], capture_output=True,
                       text=True, check=False)
    elapsed = time.perf_counter() - start
    if r.returncode != 0:
        raise SystemExit(f"mound_recon failed on {images}: {r.stderr.strip()}")
    return elapsed, json.loads((out / "recon.json").read_text())


def run_colmap(images: Path, out: Path, threads: int, max_size: int, camera: str | None,
               mapper: str = "incremental") -> tuple[float, dict[str, np.ndarray], dict]:
    import pycolmap

    out.mkdir(parents=True, exist_ok=True)
    db = out / "database.db"
    db.unlink(missing_ok=True)
    start = time.perf_counter()
    eo = pycolmap.FeatureExtractionOptions()
    eo.num_threads = threads
    eo.max_image_size = max_size
    ro = pycolmap.ImageReaderOptions()
    mode = pycolmap.CameraMode.SINGLE
    if camera:
        ro.camera_model = "PINHOLE"
        ro.camera_params = camera
    pycolmap.extract_features(db, images, camera_mode=mode, reader_options=ro,
                              extraction_options=eo)
    pycolmap.match_exhaustive(db)
    if mapper == "global":  # GLOMAP: rotation averaging, global positioning, one BA
        go = pycolmap.GlobalPipelineOptions()
        go.num_threads = threads
        go.random_seed = 1
        if camera:  # the intrinsics are known, as for the incremental mapper
            ba = go.mapper.bundle_adjustment
            ba.refine_focal_length = False
            ba.refine_extra_params = False
            ba.refine_principal_point = False
        recs = pycolmap.global_mapping(db, images, out, options=go)
    else:
        mo = pycolmap.IncrementalPipelineOptions()
        mo.num_threads = threads
        if camera:
            mo.ba_refine_focal_length = False
            mo.ba_refine_extra_params = False
            mo.ba_refine_principal_point = False
        recs = pycolmap.incremental_mapping(db, images, out, options=mo)
    if not recs:
        return time.perf_counter() - start, {}, {"registered": 0, "error_px": float("nan"),
                                                 "xyz": np.zeros((0, 3))}
    elapsed = time.perf_counter() - start
    best = max(recs.values(), key=lambda r: r.num_reg_images())
    centres = {im.name: im.projection_center() for im in best.images.values()}
    xyz = np.array([p.xyz for p in best.points3D.values()])
    return elapsed, centres, {"registered": best.num_reg_images(),
                              "error_px": best.compute_mean_reprojection_error(), "xyz": xyz}


def summary(times: list[float]) -> str:
    return f"min {min(times):.1f} s, median {statistics.median(times):.1f} s"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", default="fountain,caliterra,sim,flat")
    ap.add_argument("--features", default="sift", help="sift or klt (mound_recon --features)")
    ap.add_argument("--matching", default="auto",
                    help="auto, exhaustive, sequential or retrieval (mound_recon --matching)")
    ap.add_argument("--colmap", action="store_true", help="run pycolmap on the same images")
    ap.add_argument("--colmap-mappers", default="incremental,global",
                    help="pycolmap's mappers to run with --colmap (incremental, global)")
    ap.add_argument("--reps", type=int, default=1)
    ap.add_argument("--ours", default="",
                    help="more mound_recon flags, e.g. \"--contrast-threshold 0.01 "
                    "--max-features 6000\" (after the set's own)")
    ap.add_argument("--recall", action="store_true",
                    help="run ours once more with exact matching (--matcher exact)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", default="runs/bench_recon")
    ap.add_argument("--bin", help="mound_recon of another build (default: build/)")
    args = ap.parse_args()
    if args.bin:
        BIN.append(Path(args.bin))
    out = Path(args.out)
    data = shared_data_dir() / "images"
    for name in args.sets.split(","):
        print(f"== {name}")
        site: Path | None = None  # a simulated site
        if name == "fountain":
            folder = data / "fountain-P11"
            extra = ["--camera", str(folder / "K.txt")]
            truth = strecha_centres(folder)
            images = folder / "images"
        elif name == "caliterra":
            folder = data / "caliterra"
            images = folder / "images"
            extra = ["--gps", "exif"]
            truth = {}
        elif name in ("sim", "flat", "survey", "survey_flat"):
            if name.startswith("survey"):
                site = survey_site(out, name == "survey")
            else:
                folder_name = "site_tumulus" if name == "sim" else "site_flat"
                site = REPO_ROOT / "runs" / "figures" / folder_name
            if not (site / "poses.json").exists():
                raise SystemExit(f"{site} missing: run `make figures` first")
            images = site / "images"
            extra = ["--camera", str(site / "camera.json"), "--gps", str(site / "poses.json")]
            if name.startswith("survey"):
                extra += ["--max-features", "4000"]
            poses = json.loads((site / "poses.json").read_text())
            truth = {im["file"].split("/")[-1]: np.array(im["centre_enu_m"])
                     for im in poses["images"]}
        else:
            raise SystemExit(f"unknown set {name}")
        times = []
        for _ in range(args.reps):
            t, doc = run_ours(images, out / name, [*extra, "--features", args.features,
                                                            "--matching", args.matching,
                                                            *args.ours.split()],
                              args.threads)
            times.append(t)
        reg = f"{doc['registered']}/{len(doc['images'])}"
        line = (f"ours: {reg} registered, {doc['inputs']['pairs_matched']} pairs "
                f"({doc['inputs'].get('pairing', 'exhaustive or sequential')}), "
                f"{doc['points']} points, RMSE "
                f"{doc['reprojection_rmse_px']:.3f} px, {summary(times)} "
                f"({', '.join(f'{k} {v:.1f}' for k, v in doc['timings_s'].items())})")
        print(line)
        est = {im["file"]: np.array(im["centre"]) for im in doc["images"] if im["registered"]}
        if truth:
            e = centre_errors(est, truth)
            print(f"  camera centres after a similarity to the truth: mean {e.mean():.4f}, "
                  f"max {e.max():.4f}")
        if args.recall:
            _, exact = run_ours(images, out / f"{name}_exact",
                                [*extra, "--features", args.features, "--matching",
                                 args.matching, *args.ours.split(), "--matcher", "exact"],
                                args.threads)
            got, ref = doc["inputs"], exact["inputs"]
            line = (f"  matching recall against exact nearest neighbours on the same pairs: "
                    f"putative {got['matches_putative'] / ref['matches_putative']:.3f}, "
                    f"verified {got['matches_verified'] / ref['matches_verified']:.3f} "
                    f"({ref['matches_verified']} verified exact matches)")
            if truth:
                ex = {im["file"]: np.array(im["centre"]) for im in exact["images"]
                      if im["registered"]}
                ee = centre_errors(ex, truth)
                line += f"; exact matching's centres: mean {ee.mean():.4f}, max {ee.max():.4f}"
            print(line)
        if "gps_fit" in doc:
            g = doc["gps_fit"]
            print(f"  GPS fit: {g.get('inliers')}/{g.get('images')} inliers, RMS "
                  f"{g.get('rmse_m', 0):.2f} m (horizontal {g.get('rmse_horizontal_m', 0):.2f}, "
                  f"vertical "
                  f"{g.get('rmse_vertical_m', 0):.2f})")
        if site is not None:
            xyz, _ = read_ply(out / name / "points.ply")
            hf = load_site_heightfield(site)
            err = np.abs(xyz[:, 2] - hf.height_at(xyz[:, 0], xyz[:, 1]))
            print(f"  cloud height error in the GPS frame: median "
                  f"{np.median(err):.3f} m, 90th percentile {np.percentile(err, 90):.3f} m")
            print(f"  the same after the cameras' similarity to the truth (the shape): "
                  f"{cloud_error_aligned(xyz, est, truth, site)}")
        if args.colmap:
            cam = None
            if name == "fountain":
                k = np.loadtxt(folder / "K.txt")
                cam = f"{k[0, 0]},{k[1, 1]},{k[0, 2] + 0.5},{k[1, 2] + 0.5}"
            elif site is not None:
                k = np.array(json.loads((site / "camera.json").read_text())["K"])
                cam = f"{k[0, 0]},{k[1, 1]},{k[0, 2] + 0.5},{k[1, 2] + 0.5}"
            for mapper in args.colmap_mappers.split(","):
                cts = []
                for _ in range(args.reps):
                    ct, ccentres, cinfo = run_colmap(images, out / f"{name}_colmap_{mapper}",
                                                     args.threads, 2000, cam, mapper)
                    cts.append(ct)
                print(f"pycolmap {mapper}: {cinfo['registered']} registered, mean "
                      f"reprojection error {cinfo['error_px']:.3f} px, {summary(cts)}; time "
                      f"ratio pycolmap / ours (minima) {min(cts) / min(times):.2f}")
                if truth and ccentres:
                    e = centre_errors(ccentres, truth)
                    print(f"  pycolmap {mapper} camera centres after a similarity: mean "
                          f"{e.mean():.4f}, max {e.max():.4f}")
                if site is not None and ccentres:
                    print(f"  pycolmap {mapper} cloud after the cameras' similarity to the "
                          f"truth: {cloud_error_aligned(cinfo['xyz'], ccentres, truth, site)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
