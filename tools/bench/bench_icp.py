"""Benchmark (not a test): mound_recon compare (ICP with scale) against Open3D's ICP on
the same clouds in the same run.

    .venv/bin/python tools/bench/bench_icp.py [--points 100000] [--reps 3]
        [--site runs/figures/site_tumulus] [--out runs/bench_icp]

Clouds: two independent random samples of --points from the simulated site's reference
surface (`make figures`); the second cropped to 80 % of the site (partial overlap), with
2 cm noise and 10 % outliers, then moved by a known similarity of GPS size (2 degrees,
1.8 m, scale 1.03). Each method starts from the identity (both clouds georeferenced) and is
scored by the error of its similarity against the truth: rotation, scale, and the RMS
displacement of the site's points. Prints min and median wall time over --reps and the
ratio Open3D / ours; Open3D runs on all cores (OpenMP), ours on one.
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

from mound.paths import REPO_ROOT, build_dir
from mound.ply import read_ply, write_ply


def rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    a = axis / np.linalg.norm(axis)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def score(m: np.ndarray, truth: np.ndarray, pts: np.ndarray) -> str:
    """m, truth: 4x4 reference_from_cloud; pts: cloud points of the site."""
    a, b = m[:3, :3], truth[:3, :3]
    sa, sb = np.cbrt(np.linalg.det(a)), np.cbrt(np.linalg.det(b))
    d = (a / sa) @ (b / sb).T
    ang = np.degrees(np.arccos(np.clip((np.trace(d) - 1) / 2, -1, 1)))
    disp = (pts @ a.T + m[:3, 3]) - (pts @ b.T + truth[:3, 3])
    rms = np.sqrt(np.mean(np.sum(disp**2, axis=1)))
    return (f"rotation error {ang:.3f} deg, scale error {abs(sa / sb - 1):.2e}, "
            f"site points moved {rms:.3f} m RMS")


def summary(t: list[float]) -> str:
    return f"min {min(t):.2f} s, median {statistics.median(t):.2f} s"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=100000)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--site", default=str(REPO_ROOT / "runs" / "figures" / "site_tumulus"))
    ap.add_argument("--out", default=str(REPO_ROOT / "runs" / "bench_icp"))
    args = ap.parse_args()
    site, out = Path(args.site), Path(args.out)
    if not (site / "reference.ply").exists():
        raise SystemExit(f"{site}/reference.ply missing: run `make figures` first")
    out.mkdir(parents=True, exist_ok=True)
    surface, _ = read_ply(site / "reference.ply")
    rng = np.random.default_rng(1)
    n = args.points
    ref = surface[rng.choice(len(surface), n, replace=False)]
    cloud = surface[rng.choice(len(surface), n, replace=False)]
    half = 0.8 * np.abs(surface[:, 0]).max()
    cloud = cloud[cloud[:, 0] < -np.abs(surface[:, 0]).max() + 2 * half]
    cloud = cloud + rng.normal(0, 0.02, cloud.shape)
    lo, hi = cloud.min(axis=0), cloud.max(axis=0)
    outliers = rng.uniform(lo, hi + np.array([0, 0, 20]), (n // 10, 3))
    clean = cloud
    cloud = np.vstack([cloud, outliers])[:n]
    s, r = 1.03, rotation(np.array([0.3, -0.2, 1.0]), np.radians(2.0))
    t = np.array([1.2, -1.0, 0.9])
    cloud_from_ref = np.eye(4)
    cloud_from_ref[:3, :3], cloud_from_ref[:3, 3] = s * r, t
    cloud = cloud @ (s * r).T + t
    clean_moved = clean @ (s * r).T + t
    truth = np.linalg.inv(cloud_from_ref)
    write_ply(out / "reference.ply", ref)
    write_ply(out / "cloud.ply", cloud)
    print(f"{len(cloud)} cloud points ({len(outliers)} outliers, {len(clean)} on 80 % of the site) "
          f"vs {len(ref)} reference points")

    times, icp_times = [], []
    for _ in range(args.reps):
        start = time.perf_counter()
        p = subprocess.run([str(build_dir() / "mound_recon"), "compare", str(out / "cloud.ply"),
                            str(out / "reference.ply"), "--out", str(out / "ours")],
                           capture_output=True, text=True, check=False)
        times.append(time.perf_counter() - start)
        if p.returncode != 0:
            raise SystemExit(p.stderr)
        doc = json.loads((out / "ours" / "compare.json").read_text())
        icp_times.append(doc["timings_s"]["icp_s"])
    f = doc["reference_from_cloud"]
    m = np.eye(4)
    m[:3, :3] = f["scale"] * np.array(f["R"])
    m[:3, 3] = f["t"]
    print(f"ours (point-to-plane with scale, 1 thread): ICP {summary(icp_times)}; whole command "
          f"with PLY I/O and distances {summary(times)}; {doc['iterations']} iterations, "
          f"converged {doc['converged']}; {score(m, truth, clean_moved[:20000])}")

    import open3d as o3d

    reg = o3d.pipelines.registration
    src = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(cloud))
    tgt = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(ref))
    for name, est, iters in (("point-to-point with scale", "p2p", 30),
                             ("point-to-point with scale", "p2p", 200),
                             ("point-to-plane (no scale)", "p2l", 30)):
        t_icp, t_norm = [], []
        for _ in range(args.reps):
            t0 = time.perf_counter()
            if est == "p2l":
                tgt.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(10))
            t_norm.append(time.perf_counter() - t0)
            method = (reg.TransformationEstimationPointToPoint(with_scaling=True) if est == "p2p"
                      else reg.TransformationEstimationPointToPlane())
            t0 = time.perf_counter()
            res = reg.registration_icp(src, tgt, 3.0, np.eye(4), method,
                                       reg.ICPConvergenceCriteria(max_iteration=iters))
            t_icp.append(time.perf_counter() - t0)
        extra = f" + normals {summary(t_norm)}" if est == "p2l" else ""
        print(f"Open3D {name}, max {iters} iterations: ICP {summary(t_icp)}{extra}; ratio to ours "
              f"{min(t_icp) / min(icp_times):.1f}x; fitness {res.fitness:.3f}; "
              f"{score(np.asarray(res.transformation), truth, clean_moved[:20000])}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
