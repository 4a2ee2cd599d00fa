"""Experiment (not a test): the paper's comparison redone, and the reference-free
detector's detection limit, on simulated sites reconstructed by mound_recon.

    .venv/bin/python tools/bench/bench_verdict.py --paper [--seeds 1,2,3,4,5]
    .venv/bin/python tools/bench/bench_verdict.py --grid [--heights 0.5,1,2,4,8]
        [--diameters 15,30,60] [--grid-seeds 1] [--dense]
    options: [--size 640 480] [--out runs/bench_verdict] [--threads 2]

--paper: for each seed the bin_tepe tumulus site (60 m, 12 m) and its flat control (same
ground, same flight) are rendered and reconstructed; both clouds are compared with the
tumulus's reference surface (`mound_recon verdict --reference`: ICP with scale, distances
fitted by N(mu, sigma), threshold 0.05 x the reference's relief) and judged without it
(the reference-free verdict). Writes paper.json and paper.png (the distance histograms).
--grid: mounds of every height x diameter (spherical caps, the flight scaled to the
diameter as the simulator does) and the flat control of each flight; the reference-free
verdict of each; with --dense also `mound_recon densify` of each site and the verdict on
its dense cloud (`--cloud dense.ply`), the sparse and dense detection limits side by side.
Writes grid.json and grid.png.
Images are 640 x 480 by default (the 40-image flight), to keep a run to minutes.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "python"))

from mound.cli import main as mound_main
from mound.paths import REPO_ROOT, build_dir
from mound.ply import read_ply_fields
from mound.recon.defaults import SIM_RECONSTRUCT


def recon_tool(args: list[str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(build_dir() / "mound_recon"), *args], capture_output=True,
                          text=True, check=False)


def site_and_recon(out: Path, name: str, mound: str, seed: int, size: list[int], threads: int,
                   extra: list[str]) -> Path:
    site = out / name / "site"
    recon = out / name / "recon"
    if not (recon / "recon.json").exists():
        assert mound_main(["sim", "site", "--mound", mound, "--seed", str(seed), "--size",
                           str(size[0]), str(size[1]), "--threads", str(threads), "--out",
                           str(site), *extra]) == 0
        p = recon_tool(["reconstruct", str(site / "images"), "--out", str(recon), "--camera",
                        str(site / "camera.json"), "--gps", str(site / "poses.json"),
                        "--threads", str(threads), *SIM_RECONSTRUCT.argv()])
        if p.returncode not in (0, 3):
            raise SystemExit(p.stderr)
    return site


def verdict(recon: Path, out: Path, reference: Path | None = None,
            cloud: Path | None = None) -> dict:
    args = ["verdict", str(recon), "--out", str(out)]
    if reference is not None:
        args += ["--reference", str(reference)]
    if cloud is not None:
        args += ["--cloud", str(cloud)]
    p = recon_tool(args)
    if p.returncode not in (0, 3):
        raise SystemExit(p.stderr)
    return json.loads(out.read_text())


def paper(args: argparse.Namespace, out: Path) -> None:
    rows = []
    hist = {}
    for seed in args.seeds:
        tum = site_and_recon(out, f"tumulus_{seed}", "tumulus", seed, args.size, args.threads, [])
        flat_site = site_and_recon(out, f"flat_{seed}", "none", seed, args.size, args.threads, [])
        ref = tum / "reference.ply"
        for kind, site in (("tumulus", tum), ("flat", flat_site)):
            recon = site.parent / "recon"
            v = verdict(recon, site.parent / "verdict_paper.json", ref)
            f = verdict(recon, site.parent / "verdict_free.json")
            m = v.get("measurements", {})
            rows.append({"seed": seed, "site": kind, "status": v["status"],
                         "mu_m": m.get("mu_m"), "sigma_m": m.get("sigma_m"),
                         "threshold_m": m.get("threshold_m"), "paper_label": v.get("label"),
                         "free_label": f.get("label"), "free_reason": f.get("reason"),
                         "registered": json.loads((recon / "recon.json").read_text())
                         .get("registered")})
            print(json.dumps(rows[-1]))
            aligned = site.parent / "aligned"
            p = recon_tool(["compare", str(recon / "points.ply"), str(ref), "--out", str(aligned)])
            if p.returncode == 0:
                fields = read_ply_fields(aligned / "aligned.ply")
                hist.setdefault(kind, []).append(fields["distance"])
    (out / "paper.json").write_text(json.dumps(rows, indent=1))
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    top = max(np.percentile(np.concatenate(h), 99) for h in hist.values())
    bins = np.linspace(0, top, 60)
    for kind, colour in (("tumulus", "tab:blue"), ("flat", "tab:orange")):
        d = np.concatenate(hist[kind])
        fit = d[d <= np.percentile(d, 99)]  # as the verdict fits N(mu, sigma)
        ax.hist(d, bins=bins, density=True, alpha=0.5, color=colour,
                label=f"{kind}: N({fit.mean():.3f}, {fit.std():.3f}) m")
    thr = np.mean([r["threshold_m"] for r in rows if r["threshold_m"]])
    ax.axvline(thr, color="k", ls="--", label=f"threshold {thr:.2f} m")
    ax.set_xlabel("distance to the tumulus reference after ICP (m)")
    ax.set_ylabel("density (log)")
    ax.set_yscale("log")
    ax.set_title(f"reconstructions vs the tumulus reference, seeds {args.seeds}")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "paper.png", dpi=110)


def grid(args: argparse.Namespace, out: Path) -> None:
    rows = []
    for seed in args.grid_seeds:
        for d in args.diameters:
            for h in [0.0, *args.heights]:
                name = f"grid_d{d:g}_h{h:g}_s{seed}"
                extra = ["--diameter", str(d), "--height", str(h if h > 0 else 1.0)]
                site = site_and_recon(out, name, "tumulus" if h > 0 else "none", seed, args.size,
                                      args.threads, extra)
                recon = site.parent / "recon"
                v = verdict(recon, site.parent / "verdict_free.json")
                rise = v.get("measurements", {}).get("rise", {})
                rows.append({"seed": seed, "diameter_m": d, "height_m": h, "truth": h > 0,
                             "label": v.get("label"), "status": v["status"],
                             "correct": (v.get("label") == "mound") == (h > 0),
                             "rise_height_m": rise.get("height_m"),
                             "rise_diameter_m": rise.get("base_diameter_m")})
                if args.dense:
                    dense = site.parent / "dense"
                    if v["status"] == "ok" and not (dense / "dense.ply").exists():
                        p = recon_tool(["densify", str(recon), "--out", str(dense),
                                        "--threads", str(args.threads)])
                        if p.returncode not in (0, 3):
                            raise SystemExit(p.stderr)
                    dv = verdict(recon, site.parent / "verdict_dense.json",
                                 cloud=dense / "dense.ply") \
                        if (dense / "dense.ply").exists() else {"status": "failed"}
                    drise = dv.get("measurements", {}).get("rise", {})
                    rows[-1].update(dense_label=dv.get("label"), dense_status=dv["status"],
                                    dense_correct=(dv.get("label") == "mound") == (h > 0),
                                    dense_rise_height_m=drise.get("height_m"),
                                    dense_rise_diameter_m=drise.get("base_diameter_m"))
                print(json.dumps(rows[-1]))
    (out / "grid.json").write_text(json.dumps(rows, indent=1))
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    hs = [0.0, *args.heights]
    panels = [("sparse cloud", "correct")]
    if args.dense:
        panels.append(("dense cloud", "dense_correct"))
    fig, axes = plt.subplots(len(panels), 1, figsize=(7, 3.2 * len(panels)), squeeze=False)
    for ax, (title, key) in zip(axes[:, 0], panels, strict=True):
        acc = np.array([[np.mean([r[key] for r in rows
                                  if r["diameter_m"] == d and r["height_m"] == h]) for h in hs]
                        for d in args.diameters])
        ax.imshow(acc, cmap="RdYlGn", vmin=0, vmax=1, aspect="auto")
        ax.set_xticks(range(len(hs)), ["flat" if h == 0 else f"{h:g}" for h in hs])
        ax.set_yticks(range(len(args.diameters)), [f"{d:g}" for d in args.diameters])
        ax.set_xlabel("mound height (m)")
        ax.set_ylabel("diameter (m)")
        for i in range(acc.shape[0]):
            for j in range(acc.shape[1]):
                ax.text(j, i, f"{acc[i, j]:.0%}", ha="center", va="center")
        ax.set_title(f"reference-free verdict correct, {title}")
    fig.tight_layout()
    fig.savefig(out / "grid.png", dpi=110)


def ints(s: str) -> list[int]:
    return [int(x) for x in s.split(",")]


def floats(s: str) -> list[float]:
    return [float(x) for x in s.split(",")]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--paper", action="store_true")
    ap.add_argument("--grid", action="store_true")
    ap.add_argument("--seeds", type=ints, default=[1, 2, 3, 4, 5])
    ap.add_argument("--grid-seeds", type=ints, default=[1])
    ap.add_argument("--dense", action="store_true",
                    help="--grid: also densify each site and judge the dense cloud")
    ap.add_argument("--heights", type=floats, default=[0.5, 1, 2, 4, 8])
    ap.add_argument("--diameters", type=floats, default=[15, 30, 60])
    ap.add_argument("--size", type=int, nargs=2, default=[640, 480])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", default=str(REPO_ROOT / "runs" / "bench_verdict"))
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.paper:
        paper(args, out)
    if args.grid:
        grid(args, out)
    if not (args.paper or args.grid):
        ap.error("say --paper and/or --grid")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
