"""`mound scene eval`: leave-scenes-out cross-validation of the paper's 3 x 3 features, the
multiscale features and a chance ranking, side by side, per scene and per `visibility`."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from mound.scene import train
from mound.scene.features import FeatureSpec
from mound.scene.vector import read_labels

MIN_SEP_M = 30.0


def _by(mounds: list[train.KnownMound], key: str, k: int = 5) -> dict[str, dict[str, float]]:
    """The mounds found in the top k per value of their inventory's `key`."""
    out: dict[str, dict[str, float]] = {}
    for m in mounds:
        g = out.setdefault(str(getattr(m, key)), {"mounds": 0, "found": 0})
        g["mounds"] += 1
        g["found"] += int(m.found_within(k))
    for g in out.values():
        g[f"recall_at_{k}"] = g["found"] / g["mounds"]
    return out


def _offsets(mounds: list[train.KnownMound], k: int = 5) -> dict[str, float]:
    """How far the first candidate on each mound found in the top k lies from the
    inventory's point (metres): how closely the coarse search tells a later stage where
    the mound is (the inventory's own points carry their survey's error too)."""
    d = np.array([m.offset_m for m in mounds if m.found_within(k)], dtype=np.float64)
    if not len(d):
        return {"k": k, "mounds": 0}
    return {"k": k, "mounds": int(len(d)), "median_m": float(np.median(d)),
            "p90_m": float(np.percentile(d, 90)), "max_m": float(d.max()),
            **{f"within_{r}_m": int((d <= r).sum()) for r in (2, 5, 10)}}


def run(scenes: list[str], labels_path: str, *, band_names: list[str] | None = None,
        bands: list[str] | None = None, folds: int = 5, seed: int = 0,
        paper_resample_m: float = 8.0, figure: str | None = None,
        json_out: str | None = None, threads: int = 1, progress: Any = None
        ) -> dict[str, Any]:
    from mound.jsonio import write_json

    labels = read_labels(labels_path)
    prep = train.prepare(scenes, labels, bands, band_names, labels_path)
    names = [b.label for b in prep.bands]
    kinds = {"paper": (FeatureSpec("paper", resample_m=paper_resample_m, band_labels=names),
                       "none"),
             "multiscale": (FeatureSpec("multiscale", band_labels=names), "hinge")}
    per_mound = {len(s.mound_ids): Path(s.scene.path).name for s in prep.scenes}
    shown = tuple(sorted({Path(s.scene.path).name for s in prep.scenes},
                         key=lambda n: -max(k for k, v in per_mound.items() if v == n)
                         if n in per_mound.values() else 0)[:4])
    doc: dict[str, Any] = {"schema": "mound.scene_eval", "version": 1,
                           "scenes": [Path(s).name for s in scenes],
                           "labels": Path(labels_path).name, "kinds": {}}
    results = {}
    for kind, (spec, basis) in kinds.items():
        if progress:
            progress(f"{kind} features: sampling windows")
        samples = train.sample(prep, spec, 1500, train.BACKGROUND_MIN_M, seed)
        cv = train.cross_validate(prep, spec, basis, samples, "lbfgs", folds, seed, MIN_SEP_M,
                                  threads=threads, progress=progress, keep_maps=shown)
        results[kind] = cv
        mounds = [m for s in cv.scenes for m in s.mounds]
        doc["kinds"][kind] = {
            **cv.summary(), "features": spec.to_doc(), "basis": basis,
            "by_visibility": _by(mounds, "visibility"), "by_land_use": _by(mounds, "land_use"),
            "offset_at_5": _offsets(mounds),
            "per_mound": [{"scene": s.name, **m.to_doc()} for s in cv.scenes for m in s.mounds],
            "per_scene": [{"scene": s.name, "auc": s.auc, "ap": s.ap,
                           "mounds": len(s.mounds),
                           **{f"recall_at_{k}": v for k, v in s.recall.items()}}
                          for s in cv.scenes]}
    doc["kinds"]["chance"] = train.chance(prep, kinds["multiscale"][0], "hinge", MIN_SEP_M,
                                          seed)
    if figure:
        _figure(prep, results["multiscale"], shown, Path(figure))
        doc["figure"] = figure
    if json_out:
        write_json(json_out, doc)
    return doc


def _figure(prep: train.Prepared, cv: train.CVResult, shown: tuple[str, ...],
            path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from scipy.special import expit

    from mound.jsonio import staged_file

    by_name = {Path(s.scene.path).name: s for s in prep.scenes}
    evals = {s.name: s for s in cv.scenes}
    names = [n for n in shown if n in cv.maps]
    fig, axes = plt.subplots(1, len(names), figsize=(3.2 * len(names), 3.4), squeeze=False)
    for ax, name in zip(axes[0], names, strict=True):
        ls = by_name[name]
        sc = ls.scene
        p = np.where(np.isfinite(cv.maps[name]),
                     expit(cv.calibration["a"] * cv.maps[name] + cv.calibration["b"]), np.nan)
        w, s, e, n = sc.bounds()
        im = ax.imshow(p, extent=(0, e - w, 0, n - s), cmap="magma", vmin=0, vmax=1)
        for mx, my in ls.mound_xy:
            ax.plot(mx - w, my - s, "o", mfc="none", mec="cyan", ms=14, mew=1.5)
        ev = evals[name]
        ax.set_title(f"{name}: AUC {ev.auc:.2f}" if ev.auc is not None else name, fontsize=9)
        ax.set_xlabel("m east")
        ax.tick_params(labelsize=7)
    axes[0][0].set_ylabel("m north")
    fig.colorbar(im, ax=axes[0].tolist(), shrink=0.8, label="p(mound), held-out")
    fig.suptitle("Held-out p(mound) (multiscale features); cyan: known mounds", fontsize=10)
    path.parent.mkdir(parents=True, exist_ok=True)
    with staged_file(path, ".png") as tmp:
        fig.savefig(tmp, dpi=90, format="png")
    plt.close(fig)


def format_table(doc: dict[str, Any]) -> str:
    rows = [f"{'features':<12} {'AUC mean':>9} {'median':>7} {'AP':>6} {'R@1':>6} {'R@5':>6} "
            f"{'R@10':>6}  mounds"]
    for kind, d in doc["kinds"].items():
        def f(v: Any) -> str:
            return "   n/a" if v is None else f"{v:6.3f}"
        rows.append(f"{kind:<12} {f(d['auc_mean']):>9} {f(d['auc_median']):>7} "
                    f"{f(d['ap_mean'])} {f(d['recall_at_1'])} {f(d['recall_at_5'])} "
                    f"{f(d['recall_at_10'])}  {d['mounds']}")
    ms = doc["kinds"].get("multiscale")
    if ms:
        rows.append("multiscale recall@5 by visibility: " + ", ".join(
            f"{k} {v['found']}/{v['mounds']}" for k, v in ms["by_visibility"].items()))
        o = ms.get("offset_at_5", {})
        if o.get("mounds"):
            rows.append(f"multiscale offset of the first candidate on each of the {o['mounds']} "
                        f"mounds found in the top 5: median {o['median_m']:.1f} m, 90 % "
                        f"{o['p90_m']:.1f} m, max {o['max_m']:.1f} m; within 2 / 5 / 10 m: "
                        f"{o['within_2_m']} / {o['within_5_m']} / {o['within_10_m']}")
    return "\n".join(rows)
