"""The verdict model (`mound.verdict_model` v1): learned on one grid of simulated sites
(`mound sim grid`), judged on another.

Model: the paper's own tool, a logistic regression (eqs. (2)-(3), mound.classify.logistic)
on the standardised detector features that `mound_recon verdict` writes for each judged
rise of a site (measurements.judged_rises[].features: the most prominent rises, since a
scan of real ground holds natural rises, often larger than the tumulus; the names and
their order are the detector's, VerdictFeatureNames() in cpp/terrain), on a linear or
hinge basis, or the hinge basis with the products of every two of the rise's form and place
features (`hinge_products`, PRODUCT_FEATURES). A rise is a positive when it is the
tumulus's own, a negative when it lies
clear of any tumulus, and left out of the fit when it overlaps one otherwise
(`rise_labels`); the fit's loss is the rises' logistic loss, mixed with a multiple-instance
one over the sites' bags of rises (MIL_MIXES: the site's decision is its highest rise's).
A site's score is its highest rise's; that score is Platt-calibrated on the sites (folded into the
weights: the file stays one logistic regression and a max). Sites without a rise get
`p_no_rise`, the share of mounds among the training sites without one (Laplace-smoothed).
Basis, L2 penalty and that mix are chosen by 5-fold cross-validation over sites (the sites' log loss
after calibration). `z_clip` c bounds each standardised feature to [-c, c] before the
basis (c = 3, Z_CLIPS): a hinge is linear beyond the data, a product grows as the square,
and a rise whose feature lies far outside the training range (a torn cloud's, a real
site's) would otherwise score on an extrapolation. The chosen model's out-of-fold scores
are then taken over CV_REPEATS splits of the sites into folds (the first the selection's):
the Platt calibration is fitted on all of them, then a beta calibration of the Platt p
(the file's "calibration", `_calibrated`: the site's highest score is not logistic in the
truth), and the threshold is the lowest p >= 0.5 whose out-of-fold false-alarm rate over
them is <= 1 % — one split's rate rests on the three or four highest of some 360
negatives and moves with the split by several hundredths.

Evaluation on a held-out grid (other seeds: other sites, sun and lens): accuracy, false
alarms and missed detections per class, kind and profile; reliability table, Brier score
and ECE; the goal's subsets (mounds >= 2 m high and >= 15 m across; no-mound sites); the
old hand-set rule (height >= 1 m, base >= 8 m, roundness >= 0.6, dome R^2 >= 0.6) on the
same sites; and the detection limit, the detection rate over height x diameter.
"""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
from scipy.special import expit, logit

from mound.classify import logistic
from mound.classify.features import hinge_basis
from mound.classify.metrics import (
    clopper_pearson,
    ece_consistency,
    expected_calibration_error,
    reliability,
    roc_auc,
)
from mound.errors import InputError
from mound.recon.verdict_band import band_doc, band_goal, three_answers
from mound.sim import terrain
from mound.sim.grid import SECOND_LOOK_FACTOR, SECOND_LOOK_P, SECOND_LOOKS

SCHEMA = "mound.verdict_model"
VERSION = 1
L2_GRID = (1e-4, 1e-3, 1e-2, 1e-1)
BASES = ("linear", "hinge", "hinge_products")
# `hinge_products`: the hinge basis and the products of every two of these features (the
# rise's form — size, shape, fit, texture — and its place in the scan), each factor bounded
# to +-PRODUCT_CLIP: the additive hinge model scores a steep flank alike on a 7 m haystack
# and a 20 m cone, a low rise alike smooth or rough; the products let one feature's weight
# depend on another's value.
PRODUCT_FEATURES = ("log_height", "log_diameter", "log_aspect", "dome_r2", "roundness",
                    "symmetry", "roughness", "flank_slope", "offset", "clipped")
PRODUCT_CLIP = 3.0
# Each standardised feature is bounded to +-3 before the basis, not chosen by CV: CV on
# simulated sites cannot judge what unbounded scores do on a site unlike them (their CV log
# losses differ by 0.0005 on the dense grid).
Z_CLIPS: tuple[float | None, ...] = (3.0,)
# The fit's loss: the rises' logistic loss mixed, with weight `mil` (chosen by CV), with a
# multiple-instance one over the sites' bags of rises (mound.classify.logistic.fit_bags):
# a site's decision is its highest rise's, and a bare site on real ground holds some thirty
# natural rises, of which the few highest decide. Each site gives two bags, its tumulus's
# rises and its other rises, scored by a smooth maximum of temperature MIL_TAU (in logits:
# near the maximum, still smooth). On the dense training grid CV chose a mix of 0.5 (with
# L2 0.001): CV log loss 0.167 -> 0.156, goal tumuli out of fold 179.8 -> 180.7 of 190.
MIL_MIXES = (0.0, 0.3, 0.5)
MIL_TAU = 0.25
MAX_FA = 0.01
CV_REPEATS = 10  # splits of the sites into folds for the calibration and threshold
OPERATING_THRESHOLDS = (0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95)
# The second look: a site whose first p lies in [p_low, threshold) is flown again with a
# scan SECOND_LOOK_FACTOR x as wide and decided by that flight (mound.sim.grid's
# SECOND_LOOK_FACTOR and SECOND_LOOK_P, within which the band must lie).
SECOND_LOOK_P_MIN = SECOND_LOOK_P[0]
SECOND_LOOK_P_LOWS = (0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7)
# A second look is kept only when, out of fold, it finds at least this many more tumuli
# than the first look alone at as many false alarms (mean over the CV splits): flights
# that change nothing are not asked for. Out of fold is nested (SECOND_LOOK_FOLDS). "As
# many": the first look's ROC read at the two looks' false alarms (`_first_look_at`),
# since the file's threshold lies on a 0.01 grid below the 1 % budget and a second look
# that measures nothing would otherwise "find" the tumuli that the spare false alarms
# buy — 6.8 of 1,023 on a synthetic grid whose second look is noise.
MIN_SECOND_LOOK_GAIN = 1.0
# The second look's own choices (band, threshold, combination) are judged nested: the sites
# in this many folds, each labelled by the rule chosen on the others. Judged on the sites
# that chose it, a rule flatters itself: on the dense training grid the shipped rule
# "found" 183.8 of 190 there, and the same procedure on the same grid less 3 sites
# (other folds) chose another band and found 181.3.
SECOND_LOOK_FOLDS = 5
SECOND_LOOK_FOLD_SEED = 7
# A tumulus stands clear of its ground when its prominence over the ground around it is at
# least this many times that ground's clutter (terrain.mound_relief, on the true surface);
# below it the ground undulates at the tumulus's own scale nearly as high as the tumulus
# stands, and the verdict, which reads the cloud's shape alone, cannot tell it from the
# ground's own rises. The goal's rates are reported for both (evaluate: goal_by_ground).
# Set from the training grid's out-of-fold misses (dense: every one of the 12 goal
# tumuli under 5 lies on the laser DEM, found 4.5 of 12 times; at 5 or more, 176.2 of 178)
# and checked on the held-out grid.
CLEAR_OF_GROUND = 5.0
# A rise over a tumulus wider than this many times its diameter is the ground that holds it
# (rise_labels)
RISE_MAX_SCALE = 2.5
# The goal's tumuli by ground, as stands_clear() says: (name, its value)
GROUND_CLASSES = (("clear", True), ("masked", False))


def load_grid(folder: str | Path, second_look: str = "wider") -> list[dict[str, Any]]:
    """The measured sites of a grid: truth, features (None without a rise), the verdict, and
    the second look of kind `second_look` (mound.sim.grid.SECOND_LOOKS) where flown."""
    if second_look not in SECOND_LOOKS:
        raise InputError(f"--second-look-kind: one of {', '.join(SECOND_LOOKS)}")
    root = Path(folder)
    gpath = root / "grid.json"
    if gpath.is_file():
        try:
            grid = json.loads(gpath.read_text())
        except json.JSONDecodeError as e:
            raise InputError(f"{gpath}: not JSON ({e})") from None
        if grid.get("schema") != "mound.verdict_grid":
            raise InputError(f"{gpath}: schema: expected mound.verdict_grid")
    elif root.is_dir():  # a grid still running or interrupted: its finished sites
        grid = {"rows": []}
        for t in sorted(root.glob("*/sim/truth.json")):
            site = t.parent.parent
            truth = {k: v for k, v in json.loads(t.read_text()).items()
                     if k not in ("schema", "version", "frame", "origin")}
            done = (site / "verdict.json").is_file()
            grid["rows"].append({"dir": site.name, "truth": truth,
                                 "status": "ok" if done else "running"})
    else:
        raise InputError(f"{root}: no grid (make one with `mound sim grid`)")
    out = []
    for row in grid["rows"]:
        vpath = root / row["dir"] / "verdict.json"
        if row.get("status") != "ok" or not vpath.is_file():
            out.append({**row, "features": None, "rises": [], "measured": False})
            continue
        v = json.loads(vpath.read_text())
        m = v.get("measurements", {})
        out.append({**row, "measured": v.get("status") == "ok", "features": m.get("features"),
                    "rises": m.get("judged_rises", []), "verdict": v, "rise": m.get("rise"),
                    "grid": str(root),
                    "second": _second_look(root / row["dir"] / SECOND_LOOKS[second_look]),
                    "relief": _relief(root / row["dir"], row["truth"])})
    return out


def _relief(site: Path, truth: dict[str, Any]) -> dict[str, float] | None:
    """How far the site's tumulus stands out of its ground (terrain.mound_relief), from the
    true surface the site was rendered from (NNNN/sim/heightfield.npy); None without a
    tumulus or without that surface."""
    if not truth.get("mound") or not (site / "sim" / "site.json").is_file():
        return None
    hf = terrain.load_site_heightfield(site / "sim")
    return terrain.mound_relief(hf, truth["centre_enu_m"][:2], float(truth["diameter_m"]))


def site_terrain(row: dict[str, Any], where: str) -> terrain.TerrainSpec:
    """A grid row's terrain (its spec.terrain), without its confusers: the ground and the
    tumulus the site was drawn with; InputError naming `where` when the row holds none."""
    try:
        t = dict(row["spec"]["terrain"])
        t["confusers"] = ()
        return terrain.TerrainSpec(**t)
    except (KeyError, TypeError) as e:
        raise InputError(f"{where}: spec.terrain: not a simulated site's terrain ({e})") \
            from None


def stands_clear(row: dict[str, Any]) -> bool | None:
    """Whether a tumulus stands clear of its ground: its prominence at least CLEAR_OF_GROUND
    times the ground's clutter (None: relief unknown)."""
    rel = row.get("relief")
    if not rel:
        return None
    return bool(rel["prominence_m"] >= CLEAR_OF_GROUND * rel["ground_clutter_m"])


def _second_look(folder: Path) -> dict[str, Any] | None:
    """A site's second look (GRID/NNNN/second/verdict.json, `mound sim grid
    --second-look`; second_lower/ for the lower one): None when it was not flown or allowed
    no verdict."""
    path = folder / "verdict.json"
    if not path.is_file():
        return None
    try:
        v = json.loads(path.read_text())
    except json.JSONDecodeError as e:
        raise InputError(f"{path}: not JSON ({e})") from None
    if v.get("status") != "ok":
        return None
    m = v.get("measurements", {})
    return {"measured": True, "rises": m.get("judged_rises", []), "verdict": v}


def rise_labels(row: dict[str, Any]) -> list[bool | None]:
    """What each judged rise of a site is, for training: on a site without a tumulus every
    rise is a negative. On a tumulus site a rise is the tumulus's (a positive) when its
    centre lies within max(8 m, the tumulus's radius) of the true centre and it is at least
    0.4 x the tumulus's diameter across; a rise that overlaps the tumulus otherwise (a pit's
    rim, a shoulder, the tumulus with the ground around it) is left out (None: no truth
    says whether it is the mound), and one clear of it is a negative. Left out too (since
    2026-11-28): a rise over the tumulus more than RISE_MAX_SCALE x its diameter across (a
    swell of the ground that holds it, not it), and every rise over a tumulus that stands
    less high than its ground's own clutter around it (`buried`: no cloud shows it). Labelled
    positives, such rises taught the model that low wide swells of bare ground are tumuli:
    a 0.35 m x 67 m swell of undulating ground scored p 0.93 (issue 56)."""
    t = row["truth"]
    out: list[bool | None] = []
    rel = row.get("relief")
    buried = bool(t["mound"] and rel and rel["prominence_m"] < rel["ground_clutter_m"])
    for r in row["rises"]:
        if not t["mound"]:
            out.append(False)
            continue
        d = math.hypot(r["centre_enu_m"][0] - t["centre_enu_m"][0],
                       r["centre_enu_m"][1] - t["centre_enu_m"][1])
        size = float(r.get("base_diameter_m", t["diameter_m"]))
        near = d <= max(8.0, t["diameter_m"] / 2)
        if near and (buried or size > RISE_MAX_SCALE * t["diameter_m"]):
            out.append(None)
        elif near and size >= 0.4 * t["diameter_m"]:
            out.append(True)
        elif d < (t["diameter_m"] + size) / 2:
            out.append(None)
        else:
            out.append(False)
    return out


Pairs = tuple[tuple[int, int], ...]


def product_pairs(names: list[str]) -> Pairs:
    """The (i, j) positions in `names` of every two PRODUCT_FEATURES, in that order."""
    idx = [names.index(n) for n in PRODUCT_FEATURES if n in names]
    return tuple((a, b) for k, a in enumerate(idx) for b in idx[k + 1:])


def expand(z: np.ndarray, basis: str, z_clip: float | None = None,
           pairs: Pairs = (), product_clip: float = PRODUCT_CLIP) -> np.ndarray:
    """The basis on standardised features, each first bounded to [-z_clip, z_clip] when
    given: `linear` z itself; `hinge` z, max(z - 1, 0) and max(-z - 1, 0) per feature (a
    piecewise-linear response, still a logistic regression); `hinge_products` that and, per
    pair (i, j), z_i z_j with each factor bounded to +-product_clip."""
    if z_clip is not None:
        z = np.clip(z, -z_clip, z_clip)
    if basis == "linear":
        return z
    if basis == "hinge":
        return hinge_basis(z)
    if basis != "hinge_products" or not pairs:
        raise ValueError(f"expand: basis {basis!r} (hinge_products needs pairs)")
    zc = np.clip(z, -product_clip, product_clip)
    a, b = np.array(pairs).T
    return np.hstack([hinge_basis(z), zc[:, a] * zc[:, b]])


def _fit(z: np.ndarray, y: np.ndarray, l2: float, basis: str,
         z_clip: float | None, pairs: Pairs = (), bags: np.ndarray | None = None,
         mil: float = 0.0) -> np.ndarray:
    """The weights (bias last) on the rises `z` labelled `y`; with `mil` > 0 the loss mixes
    in the multiple-instance one over `bags` (the rises' bag ids: site and label)."""
    d = np.hstack([expand(z, basis, z_clip, pairs), np.ones((len(z), 1))])
    if mil > 0:
        if bags is None:
            raise ValueError("_fit: mil > 0 needs the rises' bags")
        f = logistic.fit_bags(d, np.where(y, 1.0, -1.0), bags, mil, MIL_TAU, l2=l2, tol=1e-7)
    else:
        f = logistic.fit(d, np.where(y, 1.0, -1.0), solver="lbfgs", l2=l2, tol=1e-7)
    return np.asarray(f.w)


def _logit(w: np.ndarray, z: np.ndarray, basis: str, z_clip: float | None,
           pairs: Pairs = ()) -> np.ndarray:
    return expand(z, basis, z_clip, pairs) @ w[:-1] + w[-1]


def _folds(n: int, k: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).permutation(n) % k


def _platt(s: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    f = logistic.fit(np.stack([s, np.ones_like(s)], axis=1), np.where(y, 1.0, -1.0),
                     solver="lbfgs", l2=0.0, tol=1e-8)
    return float(f.w[0]), float(f.w[1])


def _log_loss(p: np.ndarray, y: np.ndarray) -> float:
    return float(-np.mean(np.where(y, np.log(np.clip(p, 1e-12, 1)),
                                   np.log(np.clip(1 - p, 1e-12, 1)))))


def _calibrated(u: np.ndarray, cal: dict[str, Any] | None) -> np.ndarray:
    """The logit of p from the Platt logit u (the model's score): with the file's
    "calibration" {"method": "beta", "a", "b", "c"}, Kull et al.'s beta calibration of
    q = sigmoid(u), logit p = a ln q - b ln(1 - q) + c = b softplus(u) - a softplus(-u) + c
    (a, b >= 0, a + b > 0: increasing in u; a = b = 1, c = 0 the identity); without, u."""
    u = np.asarray(u, dtype=float)
    if not cal:
        return u
    with np.errstate(invalid="ignore"):  # -inf (no rise): -inf, as without
        out = (cal["b"] * np.logaddexp(0.0, u) - cal["a"] * np.logaddexp(0.0, -u) + cal["c"])
    return np.where(np.isneginf(u), -np.inf, np.where(np.isposinf(u), np.inf, out))


def _fit_beta(u: np.ndarray, y: np.ndarray) -> dict[str, Any]:
    """Beta calibration (see _calibrated) of the Platt logits u by maximum likelihood, a and
    b held >= 0 (L-BFGS-B, from the identity)."""
    from scipy.optimize import minimize

    ok = np.isfinite(u)
    u, t = u[ok], y[ok].astype(float)
    sp, sm = np.logaddexp(0.0, u), np.logaddexp(0.0, -u)

    def loss(v: np.ndarray) -> tuple[float, np.ndarray]:
        z = v[1] * sp - v[0] * sm + v[2]
        r = expit(z) - t  # d loss / d z
        return (float(np.sum(np.logaddexp(0.0, z) - t * z)),
                np.array([-(r @ sm), r @ sp, r.sum()]))

    res = minimize(loss, np.array([1.0, 1.0, 0.0]), jac=True, method="L-BFGS-B",
                   bounds=[(0.0, 1e3), (0.0, 1e3), (-1e3, 1e3)])
    a, b, c = (float(x) for x in res.x)
    if not a + b > 0:
        raise InputError("train-verdict: the beta calibration found no increasing map of the "
                         "scores (a = b = 0): more or other training sites are needed")
    return {"method": "beta", "a": a, "b": b, "c": c}


def _site_scores(z: np.ndarray, site_of: np.ndarray, n_sites: int, w: np.ndarray,
                 basis: str, z_clip: float | None, pairs: Pairs = ()) -> np.ndarray:
    """Each site's highest rise score (-inf for a site without a rise)."""
    s = _logit(w, z, basis, z_clip, pairs)
    out = np.full(n_sites, -np.inf)
    np.maximum.at(out, site_of, s)
    return out


def _features(rise: dict[str, Any], names: list[str], where: str) -> list[float]:
    """A judged rise's features in the order of `names`; InputError naming the verdict file
    `where` when one is missing (measured by another detector)."""
    missing = [n for n in names if n not in rise["features"]]
    if missing:
        raise InputError(f"{where}: features: no {missing[0]!r} (remeasure the grid with this "
                         "detector: mound sim grid --remeasure)")
    return [float(rise["features"][n]) for n in names]


def train(rows: list[dict[str, Any]], names: list[str], sources: list[str],
          seed: int = 0, mil_mixes: tuple[float, ...] = MIL_MIXES) -> dict[str, Any]:
    """The model document from measured training sites (see the module text): a logistic
    regression on the judged rises (the tumulus's own rise a positive, every other rise a
    negative), the site's score its highest rise's, Platt- and beta-calibrated on the
    sites."""
    measured = [r for r in rows if r["measured"]]
    sites = [r for r in measured if r["rises"]]
    no_rise = [r for r in measured if not r["rises"]]
    y_site = np.array([bool(r["truth"]["mound"]) for r in sites])
    if len(sites) < 20 or y_site.all() or not y_site.any():
        raise InputError("train-verdict: needs >= 20 measured sites with a rise, of both "
                         f"classes (got {len(sites)}, {int(y_site.sum())} mounds)")
    feats, site_of, y = [], [], []
    for i, r in enumerate(sites):
        for rise, label in zip(r["rises"], rise_labels(r), strict=True):
            feats.append(_features(rise, names, f"{r['grid']}/{r['dir']}/verdict.json"))
            site_of.append(i)
            y.append(label)
    # every rise counts in its site's score; only those with a label are fitted
    x_all, site_idx = np.array(feats), np.array(site_of)
    fitted = np.array([v is not None for v in y])
    x, y_rise = x_all[fitted], np.array([bool(v) for v in y])[fitted]
    mean = x.mean(axis=0)
    std = np.where(x.std(axis=0) > 0, x.std(axis=0), 1.0)
    z_all = (x_all - mean) / std
    z = z_all[fitted]
    bags = site_idx[fitted] * 2 + y_rise  # a site's tumulus rises, and its other rises
    pairs = product_pairs(names)
    # the second looks' rises (mound sim grid --second-look), scored by the same folds' models
    feats2, site_of2 = [], []
    for i, r in enumerate(sites):
        for rise in (r.get("second") or {}).get("rises", []):
            feats2.append(_features(rise, names, f"{r['grid']}/{r['dir']}/second/verdict.json"))
            site_of2.append(i)
    z2_all = (np.array(feats2).reshape(-1, len(names)) - mean) / std
    site_idx2 = np.array(site_of2, dtype=int)

    Key = tuple[str, float, float | None, float]

    def out_of_fold(split: int, key: Key) -> tuple[np.ndarray, np.ndarray]:
        """Each site's score by the model fitted on the other folds of split `split`, and
        its second look's (-inf: none)."""
        basis, l2, z_clip, mil = key
        fold_of_site = _folds(len(sites), 5, seed + split)
        folds_all = fold_of_site[site_idx]
        folds = folds_all[fitted]
        oof = np.full(len(sites), -np.inf)
        oof2 = np.full(len(sites), -np.inf)
        for k in range(5):
            w = _fit(z[folds != k], y_rise[folds != k], l2, basis, z_clip, pairs,
                     bags[folds != k], mil)
            out = folds_all == k
            sc = _site_scores(z_all[out], site_idx[out], len(sites), w, basis, z_clip, pairs)
            oof = np.where(fold_of_site == k, sc, oof)
            out2 = fold_of_site[site_idx2] == k
            if out2.any():
                sc2 = _site_scores(z2_all[out2], site_idx2[out2], len(sites), w, basis, z_clip,
                                   pairs)
                oof2 = np.where(fold_of_site == k, sc2, oof2)
        return oof, oof2

    cv: dict[Key, float] = {}
    oof_by: dict[Key, np.ndarray] = {}
    bases = [b for b in BASES if b != "hinge_products" or pairs]  # none without the features
    oof2_by: dict[Key, np.ndarray] = {}
    for key in itertools.product(bases, L2_GRID, Z_CLIPS, mil_mixes):
        oof, oof2_by[key] = out_of_fold(0, key)
        a, b = _platt(oof, y_site)
        cv[key] = _log_loss(expit(a * oof + b), y_site)
        oof_by[key] = oof
    best = min(cv, key=lambda k: cv[k])
    basis, l2, z_clip, mil = best
    # the chosen model's out-of-fold scores over CV_REPEATS splits (the first the one above)
    repeats = [(oof_by[best], oof2_by[best])] + [out_of_fold(rep, best)
                                                 for rep in range(1, CV_REPEATS)]
    oofs = [o for o, _ in repeats]
    s_oof, y_oof = np.concatenate(oofs), np.tile(y_site, len(oofs))
    a, b = _platt(s_oof, y_oof)
    if not a > 0:
        raise InputError("train-verdict: the rises' scores do not rank the sites (Platt slope "
                         f"{a:.3g} <= 0): more or other training sites are needed")
    # the Platt logits recalibrated (beta calibration): the site's highest score is not
    # logistic in the truth (Platt alone over-states the low p and under-states the high)
    u_oof = a * s_oof + b  # the Platt logits, CV_REPEATS splits end to end
    cal = _fit_beta(u_oof, y_oof)
    g_oof = _calibrated(u_oof, cal)
    p_oof = expit(g_oof)
    w = _fit(z, y_rise, l2, basis, z_clip, pairs, bags, mil)
    neg = p_oof[~y_oof]
    thr = _threshold(neg)
    goal_site = np.array([_goal(r["truth"]) for r in sites])
    # the goal's tumuli that stand clear of their ground, and those it masks (stands_clear)
    ground = {name: goal_site & np.array([stands_clear(r) is want for r in sites])
              for name, want in GROUND_CLASSES}
    second = _second_look_rule(
        g_oof.reshape(len(oofs), -1),
        _calibrated(a * np.stack([o2 for _, o2 in repeats]) + b, cal),
        thr, y_site, goal_site, ground)
    not_kept = None
    if second is not None:
        o = second["trained"]["out_of_fold"]
        gain = o["found"] - o["found_first_look_same_fa"]
        if gain < MIN_SECOND_LOOK_GAIN:
            not_kept = {"p_low": second["p_low"], "threshold": second["threshold"],
                        "out_of_fold": o,
                        "selected_in_sample": second["trained"]["selected_in_sample"],
                        "why": f"out of fold (nested) it finds {gain:.1f} more tumuli than "
                               "the first look at as many false alarms (< "
                               f"{MIN_SECOND_LOOK_GAIN:g})"}
            second = None
    n_nr = len(no_rise)
    m_nr = sum(1 for r in no_rise if r["truth"]["mound"])
    # the undecided band, on every site's out-of-fold p (those without a rise at p_no_rise)
    p_all = np.concatenate([p_oof.reshape(len(oofs), -1),
                            np.full((len(oofs), n_nr), (m_nr + 1) / (n_nr + 2))], axis=1)
    truths = [r["truth"] for r in sites + no_rise]
    undecided = band_doc(p_all, np.array([bool(t["mound"]) for t in truths]),
                         np.array([band_goal(t) for t in truths]), thr)
    # the cloud the sites' verdicts judged (verdict.json's `cloud`; rows made otherwise:
    # unknown)
    clouds = sorted({("dense" if str(r["verdict"].get("cloud", "")).endswith("dense.ply")
                      else "sparse") if isinstance(r.get("verdict"), dict) else "unknown"
                     for r in measured})
    return {
        "schema": SCHEMA, "version": VERSION, "features": names,
        "mean": mean.tolist(), "std": std.tolist(), "basis": basis,
        **({"z_clip": z_clip} if z_clip is not None else {}),
        **({"products": [[names[i], names[j]] for i, j in pairs],
            "product_clip": PRODUCT_CLIP} if basis == "hinge_products" else {}),
        "weights": (a * w[:-1]).tolist(), "bias": float(a * w[-1] + b),
        "calibration": cal,
        "threshold": thr, "p_no_rise": (m_nr + 1) / (n_nr + 2),
        **({"second_look": second} if second else {}),
        "undecided": undecided,
        "trained": {"grids": sources, "cloud": clouds[0] if len(clouds) == 1 else "mixed",
                    "sites": len(measured), "with_rise": len(sites),
                    "rises": len(x_all), "fitted_rises": len(x),
                    "mound_rises": int(y_rise.sum()),
                    "mounds": int(y_site.sum()), "no_rise": n_nr, "no_rise_mounds": m_nr,
                    "basis": basis, "l2": l2, "z_clip": z_clip,
                    "mil": mil, "mil_tau": MIL_TAU,
                    "cv_log_loss": {f"{k[0]} {k[1]:g}"
                                    + (f" clip {k[2]:g}" if k[2] is not None else "")
                                    + (f" mil {k[3]:g}" if k[3] else ""): v
                                    for k, v in cv.items()},
                    "platt": {"a": a, "b": b},
                    "calibration_log_loss": {"platt": _log_loss(expit(u_oof), y_oof),
                                             "beta": _log_loss(p_oof, y_oof)},
                    "cv_repeats": len(oofs),
                    **({"second_look_not_kept": not_kept} if not_kept else {}),
                    "out_of_fold": {"auc": roc_auc(p_oof, y_oof.astype(float)),
                                    "ece": expected_calibration_error(p_oof,
                                                                      y_oof.astype(float)),
                                    "false_alarm_rate": float(np.mean(neg >= thr)),
                                    "detection_rate": float(np.mean(p_oof[y_oof] >= thr)),
                                    "goal_found_by_ground": _found_by_ground(
                                        p_oof.reshape(len(oofs), -1) >= thr, ground)},
                    "method": "logistic regression on the judged rises (L-BFGS, basis, L2, "
                              "z_clip and the share of the sites' multiple-instance loss by "
                              "5-fold CV over sites), the site's highest rise score "
                              "Platt-calibrated, then beta-calibrated, on out-of-fold "
                              f"predictions over {len(oofs)} splits into folds, the "
                              "threshold from them"},
    }


def _goal(truth: dict[str, Any]) -> bool:
    """A tumulus of the issue's goal: >= 2 m high and >= 15 m across."""
    return bool(truth["mound"]) and truth["height_m"] >= 2 and truth["diameter_m"] >= 15


def _combine(u1: np.ndarray, u2: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
    """The logistic regression of the truth on the two looks' logits: (first, second, bias)."""
    f = logistic.fit(np.stack([u1, u2, np.ones_like(u1)], axis=1), np.where(y, 1.0, -1.0),
                     solver="lbfgs", l2=0.0, tol=1e-8)
    return float(f.w[0]), float(f.w[1]), float(f.w[2])


def _first_look_at(p1: np.ndarray, y: np.ndarray, goal: np.ndarray,
                   false_alarms: float) -> tuple[float, float]:
    """The first look alone (CV_REPEATS x sites of p) at the lowest threshold whose false
    alarms, pooled over the splits, are at most `false_alarms` a split: (goal tumuli found,
    tumuli found), a split's mean — its ROC curve read at those false alarms."""
    neg = np.sort(p1[:, ~y].ravel())[::-1]
    k = int(math.floor(false_alarms * len(p1) + 1e-9))  # false alarms allowed in the pool
    above = p1 > neg[k] if k < len(neg) else np.ones_like(p1, dtype=bool)
    return float(above[:, goal].sum() / len(p1)), float(above[:, y].sum() / len(p1))


def _threshold(p_neg: np.ndarray) -> float:
    """The first look's threshold: the lowest p >= 0.5 (in steps of 0.01, at most 0.99) at
    which at most MAX_FA of `p_neg`, the p of sites without a tumulus, are called one."""
    thr = 0.5
    while thr < 0.99 and np.mean(p_neg >= thr) > MAX_FA:
        thr = round(thr + 0.01, 2)
    return thr


def _found_by_ground(found: np.ndarray, ground: dict[str, np.ndarray]) -> dict[str, Any]:
    """Of the sites in each of `ground`'s masks, how many `found` (CV splits x sites) holds,
    the mean over the splits."""
    return {"clear_of_ground": CLEAR_OF_GROUND,
            **{name: {"sites": int(sel.sum()), "found": float(found[:, sel].sum() / len(found))}
               for name, sel in ground.items()}}


Rule = tuple[float, float, tuple[float, float, float]]  # p_low, threshold, combine


def _choose_second_look(u1: np.ndarray, u2: np.ndarray, thr: float, y: np.ndarray,
                        goal: np.ndarray) -> Rule | None:
    """The second look's band, threshold and combination chosen on these sites (see
    _second_look_rule); None when they hold too few second looks."""
    p1 = expit(u1)
    has2 = np.isfinite(u2)
    fit = has2 & (p1 >= SECOND_LOOK_P_MIN) & (p1 < thr)
    yy = np.broadcast_to(y, p1.shape)
    if fit.sum() < 20 * len(p1) or yy[fit].all() or not yy[fit].any():
        return None
    combine = _combine(u1[fit], u2[fit], yy[fit])
    if not combine[1] > 0:
        return None
    # the false alarms allowed: MAX_FA, or the first look's own where they exceed it (a
    # subset of the sites, in the nested evaluation, can hold more than the budget)
    budget = max(MAX_FA, float(np.mean((p1 >= thr)[~yy])))
    best: tuple[tuple[float, ...], Rule] | None = None
    for p_low in SECOND_LOOK_P_LOWS:
        if p_low >= thr:
            continue
        t2 = 0.5
        while True:
            final, flown = _second_look_labels(u1, u2, thr, (p_low, t2, combine))
            if np.mean(final[~yy]) <= budget or t2 >= 0.99:
                break
            t2 = round(t2 + 0.01, 2)
        if np.mean(final[~yy]) > budget:
            continue
        key = (float(final[:, goal].sum()), float(final[:, y].sum()), -float(flown.sum()))
        if best is None or key > best[0]:
            best = (key, (p_low, t2, combine))
    return best[1] if best else None


def _second_look_labels(u1: np.ndarray, u2: np.ndarray, thr: float,
                        rule: Rule) -> tuple[np.ndarray, np.ndarray]:
    """The labels under `rule` (a site in the band with a second look decided by both
    looks' combined p, any other by its first p) and which sites were flown."""
    p_low, t2, (c1, c2, c0) = rule
    p1 = expit(u1)
    has2 = np.isfinite(u2)
    flown = has2 & (p1 >= p_low) & (p1 < thr)
    p2 = np.where(has2, expit(c1 * u1 + c2 * np.where(has2, u2, 0.0) + c0), 0.0)
    return np.where(flown, p2 >= t2, p1 >= thr), flown


def _second_look_rule(u1: np.ndarray, u2: np.ndarray, thr: float,
                      y: np.ndarray, goal: np.ndarray,
                      ground: dict[str, np.ndarray] | None = None) -> dict[str, Any] | None:
    """The second look (see the module text) from the out-of-fold logits of the model's
    calibrated p of the sites' first and second looks (CV_REPEATS x sites; -inf: no rise,
    or no second look): a logistic
    regression of the truth on the model's logits of both looks, fitted on the sites whose
    first p lies in [SECOND_LOOK_P_MIN, thr) (CV over those sites preferred both looks to
    either alone: log loss 0.327 against 0.392 for the second and 0.368 for the first, on
    the dense training grid); then for each p_low of SECOND_LOOK_P_LOWS the lowest second
    threshold that keeps the out-of-fold false alarms of both looks together within MAX_FA,
    and of those the p_low that finds the most of the goal's tumuli (then the most tumuli,
    then the fewest flights). That choice, made on every site, is the file's; its figures
    on the same sites flatter it (`selected_in_sample`). The figures `out_of_fold` are
    nested: the sites split into SECOND_LOOK_FOLDS folds, each fold's sites labelled by the
    rule chosen on the others (the first look's threshold the file's); beside them the
    first look alone at that threshold and at as many false alarms. `ground`, masks
    of the goal's sites by how they stand of their ground (stands_clear), gives the goal's
    tumuli found in each. None when the grid has too few second looks."""
    rule = _choose_second_look(u1, u2, thr, y, goal)
    if rule is None:
        return None
    reps = len(u1)
    neg = ~y
    p1 = expit(u1)
    final_in, flown_in = _second_look_labels(u1, u2, thr, rule)
    # nested: each fold's sites by the rule chosen on the others (the first look's threshold
    # the file's: what is judged is what the second look adds)
    final = np.zeros_like(final_in)
    flown = np.zeros_like(flown_in)
    fold_of = _folds(len(y), SECOND_LOOK_FOLDS, SECOND_LOOK_FOLD_SEED)
    unchosen = 0
    for k in range(SECOND_LOOK_FOLDS):
        out = fold_of == k
        inner = _choose_second_look(u1[:, ~out], u2[:, ~out], thr, y[~out], goal[~out])
        if inner is None:  # too few second looks without this fold: its first looks decide
            unchosen += 1
            final[:, out] = p1[:, out] >= thr
            continue
        final[:, out], flown[:, out] = _second_look_labels(u1[:, out], u2[:, out], thr, inner)
    p_low, t2, (c1, c2, c0) = rule
    band = np.isfinite(u2) & (p1 >= SECOND_LOOK_P_MIN) & (p1 < thr)
    same_goal, same = _first_look_at(p1, y, goal, float(final[:, neg].sum() / reps))
    return {"p_low": p_low, "threshold": t2, "scan_factor": SECOND_LOOK_FACTOR,
            "combine": {"first": c1, "second": c2, "bias": c0},
            "trained": {"fitted_sites": int(band.sum() / reps),
                        "fitted_mounds": int(band[:, y].sum() / reps),
                        # nested (the first look at the file's threshold beside it, and
                        # its ROC read at the two looks' false alarms)
                        "out_of_fold": {
                            "flights": float(flown.sum() / reps),
                            "goal_found": float(final[:, goal].sum() / reps),
                            "goal_found_first_look": float((p1 >= thr)[:, goal].sum() / reps),
                            "goal_sites": int(goal.sum()),
                            **({"goal_found_by_ground": _found_by_ground(final, ground)}
                               if ground else {}),
                            "found": float(final[:, y].sum() / reps),
                            "found_first_look": float((p1 >= thr)[:, y].sum() / reps),
                            "goal_found_first_look_same_fa": same_goal,
                            "found_first_look_same_fa": same,
                            "false_alarms": float(final[:, neg].sum() / reps),
                            "false_alarms_first_look": float((p1 >= thr)[:, neg].sum() / reps),
                            "negatives": int(neg.sum()),
                            "folds": SECOND_LOOK_FOLDS,
                            "folds_without_a_rule": unchosen},
                        "selected_in_sample": {
                            "flights": float(flown_in.sum() / reps),
                            "goal_found": float(final_in[:, goal].sum() / reps),
                            "found": float(final_in[:, y].sum() / reps),
                            "false_alarms": float(final_in[:, neg].sum() / reps)},
                        "method": "logistic regression of the truth on the model's logits "
                                  "of both looks, fitted on the sites the first left in "
                                  f"[{SECOND_LOOK_P_MIN:g}, threshold) over the "
                                  f"{reps} CV splits; p_low and threshold from their "
                                  "out-of-fold scores; out_of_fold: each of "
                                  f"{SECOND_LOOK_FOLDS} folds of the sites labelled by the "
                                  "rule chosen on the others"}}


def probability(model: dict[str, Any], rows: list[dict[str, Any]]) -> np.ndarray:
    """p(mound) of each measured row: the same formula as the C++ VerdictModel (the highest
    over its judged rises; p_no_rise without one). `model` is valid (model_file's reader,
    or train's own)."""
    names = model["features"]
    mean, std = np.array(model["mean"]), np.array(model["std"])
    w = np.array(model["weights"])
    basis = model.get("basis", "linear")
    z_clip = model.get("z_clip")
    pairs = tuple((names.index(i), names.index(j)) for i, j in model.get("products", []))
    clip = float(model.get("product_clip", PRODUCT_CLIP))
    cal = model.get("calibration")
    out = np.empty(len(rows))
    for k, r in enumerate(rows):
        rises = r.get("rises") or []
        if not rises:
            out[k] = model["p_no_rise"]
            continue
        f = np.array([[float(q["features"][n]) for n in names] for q in rises])
        out[k] = expit(_calibrated(model["bias"] + float(np.max(
            expand((f - mean) / std, basis, z_clip, pairs, clip) @ w)), cal))
    return out


def _old_rule(r: dict[str, Any]) -> bool:
    rise = r.get("rise")
    return bool(rise and rise["height_m"] >= 1.0 and rise["base_diameter_m"] >= 8.0
                and rise["roundness"] >= 0.6 and rise["dome_r2"] >= 0.6)


def _reach_m(truth: dict[str, Any]) -> float:
    """How far from the site centre a tumulus reaches (its centre's offset + its radius)."""
    return math.hypot(*truth["centre_enu_m"][:2]) + truth["diameter_m"] / 2


def _rate(flags: list[bool]) -> float | None:
    return float(np.mean(flags)) if flags else None


def _interval(k: int, n: int) -> list[float] | None:
    """The rate's exact 95 % interval (Clopper-Pearson); None over no site."""
    return list(clopper_pearson(k, n)) if n else None


def _goal_rates(lab: np.ndarray, big: list[int], neg: list[int],
                rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The issue's goals under labels `lab`: the goal's tumuli (`big`) found and the sites
    without a mound (`neg`) called one, each with its exact 95 % interval; and the goal's
    tumuli apart for those that stand clear of their ground and those it masks
    (`stands_clear`), the masked ones listed with their relief."""
    right, fa = int(sum(lab[k] for k in big)), int(sum(lab[k] for k in neg))
    by_ground: dict[str, Any] = {"clear_of_ground": CLEAR_OF_GROUND}
    for name, want in GROUND_CLASSES:
        idx = [k for k in big if stands_clear(rows[k]) is want]
        found = int(sum(lab[k] for k in idx))
        by_ground[name] = {"sites": len(idx), "right": found,
                           "rate": _rate([bool(lab[k]) for k in idx]),
                           "rate_95ci": _interval(found, len(idx))}
        if not want:
            by_ground[name]["tumuli"] = [{"dir": rows[k]["dir"], **rows[k]["relief"],
                                          "found": bool(lab[k])} for k in idx]
    by_ground["relief_unknown"] = sum(1 for k in big if stands_clear(rows[k]) is None)
    return {"goal_mounds_2m_15m": {"sites": len(big), "right": right,
                                   "rate": _rate([bool(lab[k]) for k in big]),
                                   "rate_95ci": _interval(right, len(big)),
                                   "by_ground": by_ground},
            "goal_no_mound": {"sites": len(neg), "false_alarms": fa,
                              "rate": _rate([bool(lab[k]) for k in neg]),
                              "rate_95ci": _interval(fa, len(neg))}}


def evaluate(model: dict[str, Any], rows: list[dict[str, Any]]) -> dict[str, Any]:
    measured = [r for r in rows if r["measured"]]
    p = probability(model, measured)
    thr = model["threshold"]
    y = np.array([bool(r["truth"]["mound"]) for r in measured])
    lab = p >= thr
    old = np.array([_old_rule(r) for r in measured])
    groups: dict[str, list[int]] = {}
    for k, r in enumerate(measured):
        t = r["truth"]
        key = f"tumulus/{t['profile']}" if t["mound"] else f"no mound/{t['kind']}"
        groups.setdefault(key, []).append(k)
    per = {}
    for key, idx in sorted(groups.items()):
        per[key] = {"sites": len(idx), "right": int(sum(lab[i] == y[i] for i in idx)),
                    "old_rule_right": int(sum(old[i] == y[i] for i in idx))}
    big = [k for k, r in enumerate(measured) if r["truth"]["mound"]
           and r["truth"]["height_m"] >= 2 and r["truth"]["diameter_m"] >= 15]
    neg = [k for k in range(len(measured)) if not y[k]]
    clipped = [k for k in big if measured[k]["verdict"].get("coverage", {}).get("status")
               == "clipped"]
    wider = [k for k in big if measured[k]["truth"]["diameter_m"] > 60]
    beyond = [k for k in wider if _reach_m(measured[k]["truth"]) > float(
        measured[k]["verdict"].get("measurements", {}).get("site_radius_m", math.inf))]
    goal = _goal_rates(lab, big, neg, measured)
    goal["goal_mounds_2m_15m"]["old_rule_rate"] = _rate([bool(old[k]) for k in big])
    return {
        "sites": len(rows), "measured": len(measured),
        "failed": [r["dir"] for r in rows if not r["measured"]],
        "threshold": thr,
        "accuracy": float(np.mean(lab == y)), "old_rule_accuracy": float(np.mean(old == y)),
        "false_alarm_rate": _rate([bool(lab[k]) for k in neg]),
        "missed_rate": _rate([not lab[k] for k in range(len(y)) if y[k]]),
        "old_rule_false_alarm_rate": _rate([bool(old[k]) for k in neg]),
        "old_rule_missed_rate": _rate([not old[k] for k in range(len(y)) if y[k]]),
        **goal,
        "wider_than_scan": {"sites": len(wider), "right": int(sum(lab[k] for k in wider)),
                            "coverage_warned": int(sum(1 for k in wider if k in clipped)),
                            "beyond_the_cloud": len(beyond),
                            "beyond_the_cloud_warned": int(sum(1 for k in beyond
                                                               if k in clipped))},
        "auc": roc_auc(p, y.astype(float)),
        "brier": float(np.mean((p - y) ** 2)),
        "ece": expected_calibration_error(p, y.astype(float)),
        # the ECE beside what a calibrated forecast would show on these sites by chance
        "calibration": ece_consistency(p, y.astype(float)),
        "reliability": [{k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                         for k, v in r.items()} for r in reliability(p, y.astype(float))],
        "per_group": per,
        # what another threshold would give: the goal's mounds found, the false alarms
        "operating_points": [
            {"threshold": t, "mounds_2m_15m_found": int(sum(p[k] >= t for k in big)),
             "false_alarms": int(sum(p[k] >= t for k in neg)),
             "mounds_found": int(sum(p[k] >= t for k in range(len(y)) if y[k]))}
            for t in OPERATING_THRESHOLDS],
        "detection_limit": detection_limit(measured, lab),
        "errors": [{"dir": measured[k]["dir"], "truth": measured[k]["truth"],
                    "p_mound": float(p[k])} for k in range(len(y)) if lab[k] != y[k]],
        **({"two_looks": two_looks(model, measured, p, big, neg)}
           if model.get("second_look") else {}),
        **({"three_answers": three_answers(
            p, [{**r["truth"], "dir": r["dir"]} for r in measured],
            (model["undecided"]["p_low"], model["undecided"]["p_high"]), thr)}
           if model.get("undecided") else {}),
    }


def second_look_p(model: dict[str, Any], p_first: float | np.ndarray,
                  p_second: float | np.ndarray) -> np.ndarray:
    """The second look's calibrated p from the model's p of the first flight and of the
    wider one (the formula of mound_recon verdict --second-look)."""
    c = model["second_look"]["combine"]
    q1, q2 = (np.clip(np.asarray(q, dtype=float), 1e-12, 1 - 1e-12)
              for q in (p_first, p_second))
    return expit(c["first"] * logit(q1) + c["second"] * logit(q2) + c["bias"])


def two_looks(model: dict[str, Any], measured: list[dict[str, Any]], p: np.ndarray,
              big: list[int], neg: list[int]) -> dict[str, Any]:
    """The verdict with the second look: each site whose first p lies in [p_low, threshold)
    decided by its second flight (NNNN/second/), at the second look's calibration and
    threshold; a site in the band without one keeps its first verdict (`not_flown`)."""
    sl = model["second_look"]
    thr = model["threshold"]
    y = np.array([bool(r["truth"]["mound"]) for r in measured])
    final_p, lab = p.copy(), p >= thr
    band = [k for k in range(len(p)) if sl["p_low"] <= p[k] < thr]
    flown = [k for k in band if measured[k].get("second")]
    if flown:
        p2 = second_look_p(model, p[flown],
                           probability(model, [measured[k]["second"] for k in flown]))
        for k, q in zip(flown, p2, strict=True):
            final_p[k], lab[k] = q, q >= sl["threshold"]
    return {"p_low": sl["p_low"], "threshold": sl["threshold"],
            "band": len(band), "flown": len(flown),
            "not_flown": [measured[k]["dir"] for k in band if k not in flown],
            **_goal_rates(lab, big, neg, measured),
            "accuracy": float(np.mean(lab == y)),
            "ece": expected_calibration_error(final_p, y.astype(float)),
            "calibration": ece_consistency(final_p, y.astype(float)),
            "second_looks": [{"dir": measured[k]["dir"], "mound": bool(y[k]),
                              "p_first": float(p[k]), "p_second": float(final_p[k]),
                              "label": bool(lab[k])} for k in flown],
            "errors": [{"dir": measured[k]["dir"], "truth": measured[k]["truth"],
                        "p_mound": float(final_p[k]), "second_look": k in flown}
                       for k in range(len(y)) if lab[k] != y[k]]}


def paper_agreement(folder: str | Path, model: dict[str, Any], work: str | Path,
                    limit: int | None = None) -> dict[str, Any]:
    """The paper's test (`mound_recon verdict --reference`) beside the learned verdict on the
    sites of a grid. The reference is what a tumulus there should look like: the site's own
    ground (same seed, slope or DEM patch; no confuser) with its own tumulus, or, on a site
    without one, a 40 m x 6 m spherical cap at the centre (the paper compared its flat
    control with the tumulus's reference). Returns both labels per site and their
    agreement."""
    from dataclasses import replace

    from mound import native
    from mound.errors import ToolNoResultError
    from mound.ply import write_ply
    from mound.sim import terrain

    root, out = Path(folder), Path(work)
    out.mkdir(parents=True, exist_ok=True)
    grid = json.loads((root / "grid.json").read_text())
    rows = load_grid(root)
    p = probability(model, rows)
    sites: list[dict[str, Any]] = []
    for row, spec_doc, q in zip(rows, grid["rows"], p, strict=True):
        if not row["measured"] or (limit is not None and len(sites) >= limit):
            continue
        spec = site_terrain(spec_doc, f"{root / 'grid.json'}: {row['dir']}")
        if not spec.mound:
            spec = replace(spec, mound=True, profile="spherical_cap", diameter_m=40.0,
                           height_m=6.0, mound_x_m=0.0, mound_y_m=0.0, erosion_m=2.0)
        hf = terrain.build(replace(spec, resolution_m=1.0))
        ref = out / f"{row['dir']}_reference.ply"
        write_ply(ref, hf.points(), None, comment="mound.reference v1 (grid paper test)")
        res = out / f"{row['dir']}_paper.json"
        try:
            native.run_tool("mound_recon", ["verdict", str(root / row["dir"] / "recon"),
                                            "--reference", str(ref), "--out", str(res)], 600)
        except ToolNoResultError:
            pass
        doc = json.loads(res.read_text())
        paper = doc.get("label") if doc.get("status") == "ok" else "failed"
        sites.append({"dir": row["dir"], "truth": bool(row["truth"]["mound"]),
                      "kind": row["truth"]["kind"], "paper": paper,
                      "learned": "mound" if q >= model["threshold"] else "no_mound"})
        ref.unlink()
    judged = [s for s in sites if s["paper"] != "failed"]
    return {
        "sites": len(sites), "paper_failed": len(sites) - len(judged),
        "agree": sum(1 for s in judged if s["paper"] == s["learned"]),
        "paper_right": sum(1 for s in judged if (s["paper"] == "mound") == s["truth"]),
        "learned_right": sum(1 for s in judged if (s["learned"] == "mound") == s["truth"]),
        "judged": len(judged),
        "paper_false_alarms": sum(1 for s in judged if s["paper"] == "mound" and not s["truth"]),
        "paper_missed": sum(1 for s in judged if s["paper"] != "mound" and s["truth"]),
        "rows": sites}


HEIGHT_BINS = (0.5, 1.0, 2.0, 4.0, 8.0, 30.0)
DIAMETER_BINS = (10.0, 15.0, 30.0, 60.0, 150.0)


def detection_limit(rows: list[dict[str, Any]], lab: np.ndarray) -> dict[str, Any]:
    """Detection rate of the mounds per height x diameter bin, and the detection limit: the
    smallest (height, diameter) from which on the mounds are detected at >= 95 %."""
    table = []
    for i in range(len(HEIGHT_BINS) - 1):
        for j in range(len(DIAMETER_BINS) - 1):
            idx = [k for k, r in enumerate(rows) if r["truth"]["mound"]
                   and HEIGHT_BINS[i] <= r["truth"]["height_m"] < HEIGHT_BINS[i + 1]
                   and DIAMETER_BINS[j] <= r["truth"]["diameter_m"] < DIAMETER_BINS[j + 1]]
            table.append({"height_m": [HEIGHT_BINS[i], HEIGHT_BINS[i + 1]],
                          "diameter_m": [DIAMETER_BINS[j], DIAMETER_BINS[j + 1]],
                          "mounds": len(idx), "detected": int(sum(lab[k] for k in idx))})
    # corners (h, d): the mounds at least h high and d across; those detected at >= 95 %
    # (at least 5 mounds), and of them the ones no other such corner lies below and left of
    corners = []
    for h in HEIGHT_BINS[:-1]:
        for d in DIAMETER_BINS[:-1]:
            idx = [k for k, r in enumerate(rows) if r["truth"]["mound"]
                   and r["truth"]["height_m"] >= h and r["truth"]["diameter_m"] >= d]
            if len(idx) >= 5 and sum(lab[k] for k in idx) / len(idx) >= 0.95:
                corners.append({"height_m_at_least": h, "diameter_m_at_least": d,
                                "mounds": len(idx), "detected": int(sum(lab[k] for k in idx))})
    limit = [c for c in corners if not any(
        o is not c and o["height_m_at_least"] <= c["height_m_at_least"]
        and o["diameter_m_at_least"] <= c["diameter_m_at_least"] for o in corners)] or None
    return {"table": table, "limit": limit}


def figure(report: dict[str, Any], out: str | Path) -> None:
    """Reliability diagram and the detection rate over height x diameter."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.6))
    rel = [r for r in report["reliability"] if r["count"]]
    a.plot([0, 1], [0, 1], color="0.6", lw=1)
    a.plot([r["mean_p"] for r in rel], [r["observed"] for r in rel], "o-", color="C0")
    for r in rel:
        a.annotate(str(r["count"]), (r["mean_p"], r["observed"]), fontsize=7,
                   xytext=(3, -9), textcoords="offset points")
    a.set_xlabel("predicted p(mound)")
    a.set_ylabel("observed share of mounds")
    a.set_title(f"held-out reliability: ECE {report['ece']:.3f}, Brier {report['brier']:.3f}")
    tab = report["detection_limit"]["table"]
    nh, nd = len(HEIGHT_BINS) - 1, len(DIAMETER_BINS) - 1
    rate = np.full((nh, nd), np.nan)
    for k, c in enumerate(tab):
        if c["mounds"]:
            rate[k // nd, k % nd] = c["detected"] / c["mounds"]
    im = b.imshow(rate, origin="lower", cmap="RdYlGn", vmin=0, vmax=1, aspect="auto")
    for k, c in enumerate(tab):
        if c["mounds"]:
            b.text(k % nd, k // nd, f"{c['detected']}/{c['mounds']}", ha="center",
                   va="center", fontsize=8)
    b.set_xticks(range(nd), [f"{DIAMETER_BINS[j]:g}-{DIAMETER_BINS[j + 1]:g}"
                             for j in range(nd)])
    b.set_yticks(range(nh), [f"{HEIGHT_BINS[i]:g}-{HEIGHT_BINS[i + 1]:g}" for i in range(nh)])
    b.set_xlabel("diameter, m")
    b.set_ylabel("height, m")
    fa = report["goal_no_mound"]
    b.set_title(f"detected (held-out mounds); false alarms {fa['false_alarms']}/{fa['sites']}")
    fig.colorbar(im, ax=b, fraction=0.046)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def grid_cloud(folder: str | Path) -> str:
    """The cloud a grid's verdicts judged (`sparse` or `dense`): its grid.json's `cloud`
    (grids made before the field existed were sparse); a grid still running (no grid.json)
    by the cloud its finished verdicts name (dense/dense.ply or recon/points.ply).
    InputError when neither says (until 2026-11-28 such a grid was taken for sparse)."""
    root = Path(folder)
    if (root / "grid.json").is_file():
        try:
            doc = json.loads((root / "grid.json").read_text())
        except json.JSONDecodeError as e:
            raise InputError(f"{root}/grid.json: not JSON ({e})") from None
        return str(doc.get("cloud", "sparse"))
    for v in sorted(root.glob("*/verdict.json")):
        try:
            cloud = str(json.loads(v.read_text()).get("cloud", ""))
        except json.JSONDecodeError:
            continue
        if cloud:
            return "dense" if cloud.endswith("dense.ply") else "sparse"
    raise InputError(f"{root}: no grid.json and no finished verdict: which cloud it judges "
                     "is unknown")


def grid_label(folder: str | Path) -> str:
    """How a grid was flown and which cloud was judged, from its grid.json."""
    try:
        doc = json.loads((Path(folder) / "grid.json").read_text())
    except (OSError, json.JSONDecodeError):
        return Path(folder).name
    flight = doc.get("flight") or {}
    w, h = (flight.get("image_size") or [0, 0])[:2]
    what = "full flight (raster + orbit)" if flight.get("pattern") == "both" else \
        "survey flight (raster)"
    camera = ", photo card (EXIF, lens held by a prior)" if doc.get("camera") == "exif" else ""
    pop = doc.get("population", "uniform")
    pop = "" if pop == "uniform" else ", Kazanlak-measured tumuli" if "kazanlak" in str(
        pop.get("file", "") if isinstance(pop, dict) else pop) else ", measured tumuli"
    part = doc.get("dem_part", "all")
    part = f", DEM part {part}" if part != "all" else ""
    return (f"{what}, {doc.get('cloud', 'sparse')} cloud{camera}{pop}{part}, {w} x {h}, "
            f"seed {doc.get('seed')}")


def detection_figure(panels: list[tuple[str, dict[str, Any]]], out: str | Path) -> None:
    """The detection rate over height x diameter, one panel per grid (its label, its
    report), with each grid's false alarms and detection limit in the title."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    nh, nd = len(HEIGHT_BINS) - 1, len(DIAMETER_BINS) - 1
    cols = min(3, len(panels))
    rows = -(-len(panels) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(5.2 * cols, 4.6 * rows), squeeze=False)
    for ax in axes.flat[len(panels):]:
        ax.axis("off")
    for ax, (label, rep) in zip(axes.flat, panels, strict=False):
        rate = np.full((nh, nd), np.nan)
        for k, c in enumerate(rep["detection_limit"]["table"]):
            if c["mounds"]:
                rate[k // nd, k % nd] = c["detected"] / c["mounds"]
                ax.text(k % nd, k // nd, f"{c['detected']}/{c['mounds']}", ha="center",
                        va="center", fontsize=8)
        ax.imshow(rate, origin="lower", cmap="RdYlGn", vmin=0, vmax=1, aspect="auto")
        ax.set_xticks(range(nd), [f"{DIAMETER_BINS[j]:g}-{DIAMETER_BINS[j + 1]:g}"
                                  for j in range(nd)])
        ax.set_yticks(range(nh), [f"{HEIGHT_BINS[i]:g}-{HEIGHT_BINS[i + 1]:g}"
                                  for i in range(nh)])
        ax.set_xlabel("diameter, m")
        ax.set_ylabel("height, m")
        fa = rep["goal_no_mound"]
        lim = rep["detection_limit"]["limit"] or []
        ax.set_title(f"{label}\nfalse alarms {fa['false_alarms']}/{fa['sites']}; >= 95 % from "
                     + (", ".join(f"{c['height_m_at_least']:g} m x {c['diameter_m_at_least']:g} m"
                                  for c in lim) or "none"), fontsize=9)
    fig.tight_layout()
    fig.savefig(out, dpi=100)
    plt.close(fig)


def feature_names_of(rows: list[dict[str, Any]]) -> list[str]:
    for r in rows:
        if r["measured"] and r.get("rises"):
            return list(r["rises"][0]["features"].keys())
    raise InputError("train-verdict: no measured site with a rise in the grid")

