"""Learning the coarse-search model on labelled scenes, and judging it on scenes it has not
seen (leave-scenes-out cross-validation).

Training windows: every pixel within `POSITIVE_RADIUS_M` (4 m) of a known mound is a
positive (about 50 pixels a mound at 1 m); negatives are the explicit `not_mound` points'
pixels and, unless the labels give some, `negatives_per_scene` pixels drawn at random at
least `negative_distance_m` from every known mound (those inside the scenes and beyond their
edges: a field-walked inventory says nothing about the ground right beside a mound). The
classes are balanced by weights (each class half the loss).

Cross-validation folds are whole scenes (never pixels of one scene on both sides): the
regularisation l2 is chosen by the pooled out-of-fold log-loss of the windows; with it,
every held-out scene is scored whole, and its candidates (the survey's sites) give the
figures (AUC and average precision of mound pixels against background pixels, recall@k of
the known mounds) and the calibration: p(mound) of a candidate is the Platt-scaled logit
fitted on the out-of-fold candidates, labelled true when a known mound lies within
`FOUND_RADIUS_M` (15 m); the decision threshold maximises the out-of-fold candidates'
balanced accuracy.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial import cKDTree
from scipy.special import expit

from mound.classify import logistic
from mound.classify.features import Standardizer
from mound.errors import InputError
from mound.jsonio import JsonObject, JsonValue
from mound.scene import score as scoring
from mound.scene.features import FeatureSpec
from mound.scene.model import Band, SceneModel, expand
from mound.scene.raster import SceneInfo, open_scene
from mound.scene.vector import Label, labels_in_scene

POSITIVE_RADIUS_M = 4.0
BACKGROUND_MIN_M = 40.0
FOUND_RADIUS_M = 15.0
L2_GRID = (1e-3, 1e-2, 1e-1, 1.0, 10.0)
CANDIDATES_PER_SCENE = 20
RECALL_KS = (1, 5, 10)


@dataclass
class LabelledScene:
    scene: SceneInfo
    bands: list[int]
    mound_xy: np.ndarray            # (k, 2) known mounds inside the scene, scene CRS
    mound_ids: list[int]            # their indices into the label list
    all_mound_xy: np.ndarray        # every known mound, scene CRS (for distances)
    negative_xy: np.ndarray         # explicit not_mound points inside


@dataclass
class Samples:
    x: np.ndarray
    y: np.ndarray
    group: np.ndarray               # scene index of each row


@dataclass
class Prepared:
    scenes: list[LabelledScene]
    bands: list[Band]
    labels: list[Label]
    res_m: float


def prepare(paths: list[str], labels: list[Label], bands_arg: list[str] | None,
            band_names: list[str] | None, labels_path: str = "--labels") -> Prepared:
    """Opens the scenes, resolves the bands alike in each and places the labels; InputError
    when no label falls inside a scene or none of those is a mound."""
    if not paths:
        raise InputError("no scene given")
    scenes = [open_scene(p, band_names) for p in paths]
    first = scenes[0]
    idx0 = first.resolve_bands(bands_arg)
    chosen = [Band(k, first.band_names[k - 1]) for k in idx0]
    out = []
    n_in = 0
    for sc in scenes:
        if sc.count != first.count:
            raise InputError(f"{sc.path}: {sc.count} bands, {first.path} has {first.count}")
        if not math.isclose(sc.res_m, first.res_m, rel_tol=0.1):
            raise InputError(f"{sc.path}: pixels of {sc.res_m:g} m, {first.path} has "
                             f"{first.res_m:g} m (train on scenes of one resolution)")
        bands = [sc.band_names.index(b.name) + 1 if b.name and b.name in sc.band_names
                 else b.index for b in chosen]
        x, y, inside = labels_in_scene(labels, sc)
        is_m = np.array([lb.mound for lb in labels])
        n_in += int(inside.sum())
        ids = [int(i) for i in np.flatnonzero(inside & is_m)]
        out.append(LabelledScene(sc, bands, np.stack([x[ids], y[ids]], 1).reshape(-1, 2), ids,
                                 np.stack([x[is_m], y[is_m]], 1).reshape(-1, 2),
                                 np.stack([x[inside & ~is_m], y[inside & ~is_m]], 1
                                          ).reshape(-1, 2)))
    if n_in == 0:
        raise InputError(f"{labels_path}: none of the {len(labels)} labels falls inside the "
                         "scene(s)")
    if not any(len(s.mound_ids) for s in out):
        raise InputError(f"{labels_path}: none of the labels inside the scene(s) is a mound")
    return Prepared(out, chosen, labels, first.res_m)


def _pixels_near(sc: SceneInfo, xy: np.ndarray, radius_m: float) -> np.ndarray:
    """(row, col) of the pixels whose centres lie within radius_m of any point."""
    out = set()
    rad = radius_m / sc.res_m
    for x, y in xy:
        r, c = sc.pixel_of(np.array(x), np.array(y))
        for rr in range(int(math.floor(r - rad)), int(math.ceil(r + rad)) + 1):
            for cc in range(int(math.floor(c - rad)), int(math.ceil(c + rad)) + 1):
                if (0 <= rr < sc.height and 0 <= cc < sc.width
                        and (rr + 0.5 - r) ** 2 + (cc + 0.5 - c) ** 2 <= rad * rad):
                    out.add((rr, cc))
    return np.array(sorted(out), dtype=np.int64).reshape(-1, 2)


def _random_background(ls: LabelledScene, n: int, min_dist_m: float,
                       rng: np.random.Generator) -> np.ndarray:
    sc = ls.scene
    tree = cKDTree(ls.all_mound_xy) if len(ls.all_mound_xy) else None
    rows = rng.integers(0, sc.height, 4 * n + 64)
    cols = rng.integers(0, sc.width, 4 * n + 64)
    x = sc.west + (cols + 0.5) * sc.res_m
    y = sc.north - (rows + 0.5) * sc.res_m
    if tree is not None:
        d, _ = tree.query(np.stack([x, y], 1))
        keep = d >= min_dist_m
        rows, cols = rows[keep], cols[keep]
    rc = np.unique(np.stack([rows, cols], 1), axis=0)
    rng.shuffle(rc)
    return rc[:n]


def gather(scene: SceneInfo, bands: list[int], spec: FeatureSpec, rc: np.ndarray,
           block: int = 256) -> np.ndarray:
    """Features at scene pixels rc (k, 2), block by block (stride 1; paper: the coarse
    cell holding each pixel)."""
    cell = spec.cell_px(scene.res_m, 1)
    out = np.full((len(rc), len(spec.names())), np.nan)
    if not len(rc):
        return out
    cr, cc = rc[:, 0] // cell, rc[:, 1] // cell
    rows, cols = math.ceil(scene.height / cell), math.ceil(scene.width / cell)
    for r0 in range(0, rows, block):
        for c0 in range(0, cols, block):
            sel = np.flatnonzero((cr >= r0) & (cr < r0 + block) & (cc >= c0)
                                 & (cc < c0 + block))
            if not len(sel):
                continue
            n, m = min(block, rows - r0), min(block, cols - c0)
            f = scoring.features_block(scene, bands, spec, cell, r0, c0, n, m)
            out[sel] = f[(cr[sel] - r0) * m + (cc[sel] - c0)]
    return out


def sample(prep: Prepared, spec: FeatureSpec, negatives_per_scene: int,
           negative_distance_m: float, seed: int) -> Samples:
    rng = np.random.default_rng(seed)
    xs, ys, gs = [], [], []
    explicit = any(len(s.negative_xy) for s in prep.scenes)
    for k, ls in enumerate(prep.scenes):
        pos = _pixels_near(ls.scene, ls.mound_xy, POSITIVE_RADIUS_M)
        neg = _pixels_near(ls.scene, ls.negative_xy, POSITIVE_RADIUS_M)
        if not explicit:
            neg = _random_background(ls, negatives_per_scene, negative_distance_m, rng)
        for rc, label in ((pos, 1.0), (neg, -1.0)):
            f = gather(ls.scene, ls.bands, spec, rc)
            ok = np.isfinite(f).all(axis=1)
            xs.append(f[ok])
            ys.append(np.full(int(ok.sum()), label))
            gs.append(np.full(int(ok.sum()), k))
    s = Samples(np.vstack(xs), np.concatenate(ys), np.concatenate(gs))
    if not (s.y > 0).any():
        raise InputError("labels: no mound has a complete window in the scenes (too close "
                         "to an edge or to nodata)")
    if not (s.y < 0).any():
        raise InputError("labels: no background window could be drawn")
    return s


def balanced_weights(y: np.ndarray) -> np.ndarray:
    pos = (y > 0).mean()
    return np.where(y > 0, 0.5 / pos, 0.5 / (1 - pos))


def fit(x: np.ndarray, y: np.ndarray, spec: FeatureSpec, basis: str, l2: float,
        solver: str, bands: list[Band], res_m: float) -> SceneModel:
    scaler = Standardizer.fit(x)
    model = SceneModel(bands=bands, spec=spec, basis=basis, scaler=scaler,
                       w=np.zeros(1), res_m=res_m)
    d = model.design(x)
    fitted = logistic.fit(d, y, solver=solver, l2=l2, tol=1e-5, max_iter=50_000,
                          weight=balanced_weights(y))
    model.w = fitted.w
    model.info = {"fit": {"solver": solver, "l2": l2, "iterations": fitted.iterations,
                          "converged": fitted.converged, "loss": fitted.loss,
                          "grad_norm": fitted.grad_norm, "seconds": fitted.seconds}}
    return model


def folds_of(n_scenes: int, k: int, seed: int) -> np.ndarray:
    perm = np.random.default_rng(seed).permutation(n_scenes)
    out = np.empty(n_scenes, dtype=np.int64)
    out[perm] = np.arange(n_scenes) % k
    return out


# ------------------------------------------------------------------------ evaluation

def average_precision(score: np.ndarray, y: np.ndarray) -> float:
    order = np.argsort(-score, kind="stable")
    hit = y[order] > 0
    if not hit.any():
        return float("nan")
    prec = np.cumsum(hit) / np.arange(1, len(hit) + 1)
    return float(prec[hit].mean())


def roc_auc(score: np.ndarray, y: np.ndarray) -> float:
    from mound.classify.metrics import roc_auc as auc

    return auc(score, y)


@dataclass(frozen=True)
class KnownMound:
    """A known mound of a held-out scene: the rank of the first candidate within
    FOUND_RADIUS_M of it (None: none), that candidate's distance from the inventory's point
    (m), and the inventory's visibility and land use."""

    id: str
    rank: int | None
    offset_m: float | None
    visibility: JsonValue = None
    land_use: JsonValue = None

    def found_within(self, k: int) -> bool:
        return self.rank is not None and self.rank <= k

    def to_doc(self) -> JsonObject:
        return {"id": self.id, "rank": self.rank, "offset_m": self.offset_m,
                "visibility": self.visibility, "land_use": self.land_use}


@dataclass
class SceneEval:
    name: str
    auc: float | None
    ap: float | None
    mound_pixels: int
    background_pixels: int
    recall: dict[int, float | None]
    mounds: list[KnownMound]
    candidates: list[tuple[float, bool]] = field(default_factory=list)  # (logit, true?)


def judge_scene(ls: LabelledScene, logit: np.ndarray, grid: scoring.OutGrid,
                labels: list[Label], min_sep_m: float, name: str) -> SceneEval:
    """Pixel AUC/AP (<= 4 m from a known mound vs >= 40 m from all) and recall@k."""
    rr, cc = np.mgrid[0:grid.rows, 0:grid.cols]
    x, y = grid.centre(rr.ravel(), cc.ravel())
    ok = np.isfinite(logit.ravel())
    d = (cKDTree(ls.all_mound_xy).query(np.stack([x, y], 1))[0]
         if len(ls.all_mound_xy) else np.full(x.shape, np.inf))
    pos = ok & (d <= POSITIVE_RADIUS_M)
    neg = ok & (d >= BACKGROUND_MIN_M)
    auc = ap = None
    if pos.any() and neg.any():
        s = np.r_[logit.ravel()[pos], logit.ravel()[neg]]
        t = np.r_[np.ones(int(pos.sum())), -np.ones(int(neg.sum()))]
        auc, ap = roc_auc(s, t), average_precision(s, t)
    p = np.where(np.isfinite(logit), expit(logit), np.nan)
    cands = scoring.candidates_of_map(p, grid, min_sep_m, max(CANDIDATES_PER_SCENE,
                                                              max(RECALL_KS)))
    cxy = np.array([grid.centre(np.array(r), np.array(c)) for _, r, c in cands]).reshape(-1, 2)
    mounds: list[KnownMound] = []
    for j, (mx, my) in zip(ls.mound_ids, ls.mound_xy, strict=True):
        dist = np.hypot(cxy[:, 0] - mx, cxy[:, 1] - my) if len(cxy) else np.zeros(0)
        first = next((i + 1 for i, dd in enumerate(dist) if dd <= FOUND_RADIUS_M), None)
        # How far that candidate lies from the inventory's point (metres): the place a
        # later stage is told, to within this.
        offset = None if first is None else round(float(dist[first - 1]), 2)
        mounds.append(KnownMound(labels[j].id, first, offset,
                                 labels[j].props.get("visibility"),
                                 labels[j].props.get("land_use")))
    recall = {k: (float(np.mean([m.found_within(k) for m in mounds]))
                  if mounds else None) for k in RECALL_KS}
    tree = cKDTree(ls.all_mound_xy) if len(ls.all_mound_xy) else None
    judged = []
    for (_, r, c), (ex, ey) in zip(cands, cxy, strict=True):
        near = tree is not None and tree.query([ex, ey])[0] <= FOUND_RADIUS_M
        judged.append((float(logit[r, c]), bool(near)))
    return SceneEval(name, auc, ap, int(pos.sum()), int(neg.sum()), recall, mounds, judged)


def pixel_map(logit: np.ndarray, grid: scoring.OutGrid, scene: SceneInfo
              ) -> tuple[np.ndarray, scoring.OutGrid]:
    """A map of coarser cells (the paper's features, a stride) on the scene's pixel grid,
    so that every feature kind is judged at the same pixels."""
    if grid.cell == 1:
        return logit, grid
    c = grid.cell
    full = np.repeat(np.repeat(logit, c, axis=0), c, axis=1)[:scene.height, :scene.width]
    return full, scoring.OutGrid(1, scene.height, scene.width, scene.res_m, scene.west,
                                 scene.north)


def platt(logit: np.ndarray, truth: np.ndarray) -> dict[str, float]:
    """sigma(a s + b) fitted by maximum likelihood (a tiny ridge keeps it finite when the
    classes separate)."""
    y = np.where(truth, 1.0, -1.0)
    x = np.stack([logit, np.ones_like(logit)], 1)
    fitted = logistic.fit_lbfgs(x, y, l2=1e-4)
    return {"a": float(fitted.w[0]), "b": float(fitted.w[1])}


def best_threshold(p: np.ndarray, truth: np.ndarray) -> float:
    """The p threshold of the highest balanced accuracy (mid-way between neighbours)."""
    if truth.all() or not truth.any():
        return 0.5
    qs = np.unique(p)
    cuts = np.r_[qs[0] - 1e-9, (qs[:-1] + qs[1:]) / 2, qs[-1] + 1e-9]
    best, arg = -1.0, 0.5
    for t in cuts:
        lab = p >= t
        ba = 0.5 * (lab[truth].mean() + (~lab[~truth]).mean())
        if ba > best + 1e-12:
            best, arg = ba, float(t)
    return float(min(max(arg, 0.0), 1.0))


@dataclass
class CVResult:
    l2: float
    l2_table: list[dict[str, float]]
    scenes: list[SceneEval]
    calibration: dict[str, float]
    threshold: float
    seconds: float
    maps: dict[str, np.ndarray] = field(default_factory=dict)  # held-out logits kept

    def summary(self) -> JsonObject:
        aucs = [s.auc for s in self.scenes if s.auc is not None]
        aps = [s.ap for s in self.scenes if s.ap is not None]
        mounds = [m for s in self.scenes for m in s.mounds]
        out: JsonObject = {
            "folds": "leave-scenes-out", "l2": self.l2, "l2_grid": self.l2_table,
            "scenes": len(self.scenes), "mounds": len(mounds),
            "auc_mean": float(np.mean(aucs)) if aucs else None,
            "auc_median": float(np.median(aucs)) if aucs else None,
            "ap_mean": float(np.mean(aps)) if aps else None}
        for k in RECALL_KS:
            out[f"recall_at_{k}"] = (float(np.mean([m.found_within(k) for m in mounds]))
                                     if mounds else None)
        cands = [c for s in self.scenes for c in s.candidates]
        if cands:
            lg = np.array([c[0] for c in cands])
            tr = np.array([c[1] for c in cands])
            p = expit(self.calibration["a"] * lg + self.calibration["b"])
            from mound.classify.metrics import expected_calibration_error

            out["candidates"] = {"count": len(cands), "true": int(tr.sum()),
                                 "ece_calibrated": expected_calibration_error(
                                     p, np.where(tr, 1.0, -1.0))}
        return out


def cross_validate(prep: Prepared, spec: FeatureSpec, basis: str, samples: Samples,
                   solver: str, folds: int, seed: int, min_sep_m: float,
                   l2_grid: tuple[float, ...] = L2_GRID, threads: int = 1,
                   progress: Any = None, keep_maps: tuple[str, ...] = ()) -> CVResult:
    start = time.perf_counter()
    n = len(prep.scenes)
    k = min(folds, n)
    if k < 2:
        raise InputError("cross-validation needs at least 2 scenes (folds are whole scenes)")
    fold = folds_of(n, k, seed)
    row_fold = fold[samples.group]
    table = []
    for l2 in l2_grid:
        losses = []
        for f in range(k):
            tr = row_fold != f
            if not (samples.y[tr] > 0).any() or not (samples.y[~tr] > 0).any():
                continue
            m = fit(samples.x[tr], samples.y[tr], spec, basis, l2, "lbfgs", prep.bands,
                    prep.res_m)
            q = m.logit(samples.x[~tr])
            yy = samples.y[~tr]
            w = balanced_weights(yy)
            losses.append(float(np.sum(w * np.logaddexp(0, -yy * q))))
        total = float(np.sum(losses)) / len(samples.y)
        table.append({"l2": l2, "oof_log_loss": total})
        if progress:
            progress(f"l2 {l2:g}: out-of-fold log-loss {total:.4f}")
    best = min(table, key=lambda r: (r["oof_log_loss"], -r["l2"]))["l2"]
    evals: list[SceneEval] = []
    maps: dict[str, np.ndarray] = {}
    for f in range(k):
        tr = row_fold != f
        held = [i for i in range(n) if fold[i] == f]
        if not (samples.y[tr] > 0).any():
            continue
        m = fit(samples.x[tr], samples.y[tr], spec, basis, best, solver, prep.bands,
                prep.res_m)
        for i in held:
            ls = prep.scenes[i]
            lg, grid = pixel_map(*scoring.logit_map(ls.scene, m, threads=threads), ls.scene)
            evals.append(judge_scene(ls, lg, grid, prep.labels, min_sep_m,
                                     Path(ls.scene.path).name))
            if evals[-1].name in keep_maps:
                maps[evals[-1].name] = lg
        if progress:
            progress(f"fold {f + 1}/{k}: {len(held)} held-out scenes scored")
    cands = [c for s in evals for c in s.candidates]
    lg = np.array([c[0] for c in cands])
    truth = np.array([c[1] for c in cands], dtype=bool)
    if len(cands) >= 4 and truth.any() and not truth.all():
        cal = platt(lg, truth)
        thr = best_threshold(expit(cal["a"] * lg + cal["b"]), truth)
    else:
        cal, thr = {"a": 1.0, "b": 0.0}, 0.5
    return CVResult(best, table, evals, cal, thr, time.perf_counter() - start, maps)


def chance(prep: Prepared, spec: FeatureSpec, basis: str, min_sep_m: float, seed: int
           ) -> JsonObject:
    """The same figures for a ranking by independent noise, on the positions that `spec`
    scores (a chance ranking of the same candidates' ground)."""
    rng = np.random.default_rng(seed)
    n = len(spec.names())
    blank = SceneModel(bands=prep.bands, spec=spec, basis=basis,
                       scaler=Standardizer(np.zeros(n), np.ones(n)),
                       w=np.zeros(expanded_width(spec, basis)), res_m=prep.res_m)
    evals = []
    for ls in prep.scenes:
        zero, grid = pixel_map(*scoring.logit_map(ls.scene, blank), ls.scene)
        noise = zero + rng.standard_normal(zero.shape)
        evals.append(judge_scene(ls, noise, grid, prep.labels, min_sep_m,
                                 Path(ls.scene.path).name))
    res = CVResult(0.0, [], evals, {"a": 1.0, "b": 0.0}, 0.5, 0.0)
    return res.summary()


def expanded_width(spec: FeatureSpec, basis: str) -> int:
    return len(expand(np.zeros((1, len(spec.names()))), basis)[0]) + 1
