"""Training, band selection and evaluation of the coarse-search classifier."""

from __future__ import annotations

from typing import TypedDict

import numpy as np

from mound.classify import logistic, metrics, statlog
from mound.classify.defaults import DEFAULT_BAND, DEFAULT_L2
from mound.classify.features import BAND_NAMES, Standardizer, band_columns
from mound.classify.model import SCHEMA as MODEL_SCHEMA
from mound.classify.model import VERSION as MODEL_VERSION
from mound.classify.model import Model
from mound.classify.statlog import Split
from mound.jsonio import read_json


def train(data: Split, band: int | None, solver: str = "gd", l2: float = DEFAULT_L2,
          tol: float = 1e-6, max_iter: float = 200_000,
          extra: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> Model:
    """Fits on `data`; `max_iter` < convergence gives an early-stopped (less confident) model
    (gd: fractional values stop part-way along the last step). `extra`: more examples
    (x (m, 36), y in {-1, +1}, weight > 0 each, where `data`'s rows weigh 1), e.g. the sites
    a survey verified; the standardisation stays that of `data`."""
    x = data.x[:, band_columns(band)]
    scaler = Standardizer.fit(x)
    y, weight = data.y, None
    if extra is not None and len(extra[1]):
        ex, ey, ew = extra
        x = np.vstack([x, ex[:, band_columns(band)]])
        y = np.concatenate([y, ey])
        weight = np.concatenate([np.ones(len(data.y)), ew])
    fit = logistic.fit(scaler.design(x), y, solver=solver, l2=l2, tol=tol,
                       max_iter=max_iter, weight=weight)
    info = {"iterations": fit.iterations, "converged": fit.converged, "loss": fit.loss,
            "grad_norm": fit.grad_norm, "train_seconds": fit.seconds, "rows": len(data.y)}
    if extra is not None:
        info["extra_rows"] = len(extra[1])
        info["extra_weight"] = float(np.sum(extra[2]))
    return Model(band=band, scaler=scaler, w=fit.w, l2=l2, solver=solver, info=info)


class Evaluation(TypedDict):
    """A classifier judged on a split (mound.classifier_eval's members)."""
    accuracy: float
    majority_accuracy: float
    auc: float
    log_loss: float
    ece: float
    reliability: list[dict[str, float]]
    rows: int


class BandChoice(TypedDict):
    """A band's held-out figures (select_band); band None: all 36 features."""
    band: int | None
    name: str
    auc: float
    accuracy: float
    log_loss: float


def evaluate(model: Model, data: Split) -> Evaluation:
    p = model.predict(data.x)
    s = metrics.summary(p, data.y)
    return {"accuracy": s["accuracy"], "majority_accuracy": s["majority_accuracy"],
            "auc": s["auc"], "log_loss": s["log_loss"], "ece": s["ece"],
            "reliability": metrics.reliability(p, data.y), "rows": len(data.y)}


def holdout_split(data: Split, fraction: float, seed: int) -> tuple[Split, Split]:
    """Stratified random split of `data` (per class) into (train, held-out)."""
    rng = np.random.default_rng(seed)
    held = np.zeros(len(data.cls), dtype=bool)
    for c in np.unique(data.cls):
        idx = np.flatnonzero(data.cls == c)
        rng.shuffle(idx)
        held[idx[: round(fraction * len(idx))]] = True
    return (Split(data.x[~held], data.cls[~held]), Split(data.x[held], data.cls[held]))


def select_band(train_data: Split, fraction: float = 0.25, seed: int = 0,
                l2: float = DEFAULT_L2) -> list[BandChoice]:
    """Held-out evaluation of each band (and all 36 features) on sat.trn only."""
    fit_part, held = holdout_split(train_data, fraction, seed)
    rows: list[BandChoice] = []
    for band in (0, 1, 2, 3, None):
        m = train(fit_part, band, solver="lbfgs", l2=l2)
        s = evaluate(m, held)
        rows.append({"band": band, "name": "all 36" if band is None else BAND_NAMES[band],
                     "auc": s["auc"], "accuracy": s["accuracy"], "log_loss": s["log_loss"]})
    return rows


def load_model(path: str | None) -> Model:
    """The classifier of the file `path` (mound.classify_model), or None: the default band
    trained on sat.trn."""
    if path is None:
        return train(statlog.load("sat.trn"), DEFAULT_BAND)
    return Model.from_doc(read_json(path, MODEL_SCHEMA, MODEL_VERSION), path)
