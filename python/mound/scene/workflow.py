"""The scene stage as library functions (the `mound scene` verbs and the survey driver call
them): a scene model learnt from GeoTIFF scenes and a field-checked inventory."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING

from mound.errors import InputError

if TYPE_CHECKING:
    from mound.scene.model import SceneModel


def say(text: str) -> None:
    print(f"scene: {text}", file=sys.stderr, flush=True)


def train_model(scenes: list[str], labels_path: str, out: str | None, *,
                bands: list[str] | None = None, band_names: list[str] | None = None,
                features: str = "multiscale", resample_m: float = 8.0, basis: str = "hinge",
                negative_distance_m: float = 40.0, negatives_per_scene: int = 1500,
                folds: int = 5, l2: float | None = None, solver: str = "gd", seed: int = 0,
                min_sep_m: float = 30.0, threads: int = 1) -> SceneModel:
    """Learns a scene model (and writes it when `out` is given); the survey calls it too."""
    from mound.datasets import sha256_of
    from mound.jsonio import write_json
    from mound.scene import train
    from mound.scene.features import FeatureSpec
    from mound.scene.vector import read_labels

    if not 0 < negative_distance_m < 1e5:
        raise InputError("--negative-distance-m: must be > 0 m")
    if not 10 <= negatives_per_scene <= 1_000_000:
        raise InputError("--negatives-per-scene: must be 10 .. 1,000,000")
    if l2 is not None and not 0 <= l2 < 1e6:
        raise InputError("--l2: must be >= 0")
    labels = read_labels(labels_path)
    prep = train.prepare(scenes, labels, bands, band_names, labels_path)
    spec = FeatureSpec(features, resample_m=resample_m,
                       band_labels=[b.label for b in prep.bands])
    basis = "none" if features == "paper" else basis
    samples = train.sample(prep, spec, negatives_per_scene, negative_distance_m, seed)
    n_pos, n_neg = int((samples.y > 0).sum()), int((samples.y < 0).sum())
    say(f"{len(scenes)} scenes, {sum(len(s.mound_ids) for s in prep.scenes)} known mounds "
         f"inside, {n_pos} mound and {n_neg} background windows, {len(spec.names())} features")
    cv = None
    if len(scenes) >= 2:
        grid = (l2,) if l2 is not None else train.L2_GRID
        cv = train.cross_validate(prep, spec, basis, samples, solver="lbfgs", folds=folds,
                                  seed=seed, min_sep_m=min_sep_m, l2_grid=grid,
                                  threads=threads, progress=say)
        chosen = cv.l2
    else:
        say("one scene: no cross-validation (folds are whole scenes); l2 = 0.01, "
             "calibration: none")
        chosen = 0.01 if l2 is None else l2
    model = train.fit(samples.x, samples.y, spec, basis, chosen, solver, prep.bands,
                      prep.res_m)
    fit_info = model.info["fit"]
    if cv is not None:
        model.calibration, model.threshold = cv.calibration, cv.threshold
    model.info = {
        "fit": fit_info, "band_count": prep.scenes[0].scene.count,
        "training": {
            "scenes": [{"file": Path(s).name, "sha256": sha256_of(Path(s))} for s in scenes],
            "labels": {"file": Path(labels_path).name, "sha256": sha256_of(Path(labels_path)),
                       "points": len(labels),
                       "mounds_inside": sum(len(s.mound_ids) for s in prep.scenes)},
            "windows": {"mound": n_pos, "background": n_neg,
                        "positive_radius_m": train.POSITIVE_RADIUS_M,
                        "negative_distance_m": negative_distance_m,
                        "negatives_per_scene": negatives_per_scene, "seed": seed,
                        "class_weights": "balanced"}},
        "cross_validation": cv.summary() if cv is not None else None,
        "calibration_method": ("Platt scaling of out-of-fold candidates (true: a known mound "
                               f"within {train.FOUND_RADIUS_M:g} m)") if cv else "none",
        "threshold_method": ("highest balanced accuracy of the out-of-fold candidates"
                             if cv else "0.5 (no cross-validation)")}
    if out:
        write_json(out, model.to_doc())
    return model
