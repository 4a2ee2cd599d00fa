"""The verdict model fitted (`train`) and applied (`probability`): the basis (linear, hinge,
hinge products), the logistic fit with its multiple-instance loss, the selection by
cross-validation over sites, the Platt and beta calibration, the threshold and the
undecided band; verdict_model.py describes the model, verdict_eval.py judges it."""

from __future__ import annotations

import itertools
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy.special import expit

from mound.classify import logistic
from mound.classify.features import hinge_basis
from mound.classify.metrics import (
    expected_calibration_error,
    roc_auc,
)
from mound.errors import InputError
from mound.formats.verdict import Rise
from mound.recon.defaults import CANDIDATES
from mound.recon.grid_site import GridSite
from mound.recon.model_file import Beta, VerdictModel
from mound.recon.verdict_band import band_doc, band_goal, confusion_doc
from mound.training.verdict_blocks import (
    SecondLookNotKept,
    SecondLookRule,
    reason_thresholds,
    terrain_domain,
)
from mound.training.verdict_data import (
    GROUND_CLASSES,
    MAX_FA,
    found_by_ground,
    goal_tumulus,
    rise_features,
    rise_labels,
    site_folds,
    stands_clear,
)
from mound.training.verdict_second import MIN_SECOND_LOOK_GAIN, second_look_rule

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


CV_REPEATS = 10  # splits of the sites into folds for the calibration and threshold


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


def _platt(s: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    f = logistic.fit(np.stack([s, np.ones_like(s)], axis=1), np.where(y, 1.0, -1.0),
                     solver="lbfgs", l2=0.0, tol=1e-8)
    return float(f.w[0]), float(f.w[1])


def _log_loss(p: np.ndarray, y: np.ndarray) -> float:
    return float(-np.mean(np.where(y, np.log(np.clip(p, 1e-12, 1)),
                                   np.log(np.clip(1 - p, 1e-12, 1)))))


def _calibrated(u: np.ndarray | float, cal: Beta | None) -> np.ndarray:
    """The logit of p from the Platt logit u (the model's score): with the file's
    "calibration" {"method": "beta", "a", "b", "c"} (`cal`), Kull et al.'s beta calibration of
    q = sigmoid(u), logit p = a ln q - b ln(1 - q) + c = b softplus(u) - a softplus(-u) + c
    (a, b >= 0, a + b > 0: increasing in u; a = b = 1, c = 0 the identity); without, u."""
    u = np.asarray(u, dtype=float)
    if not cal:
        return u
    with np.errstate(invalid="ignore"):  # -inf (no rise): -inf, as without
        out = (cal.b * np.logaddexp(0.0, u) - cal.a * np.logaddexp(0.0, -u) + cal.c)
    return np.where(np.isneginf(u), -np.inf, np.where(np.isposinf(u), np.inf, out))


def _fit_beta(u: np.ndarray, y: np.ndarray) -> Beta:
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
    return Beta(a, b, c)


def _site_scores(z: np.ndarray, site_of: np.ndarray, n_sites: int, w: np.ndarray,
                 basis: str, z_clip: float | None, pairs: Pairs = ()) -> np.ndarray:
    """Each site's highest rise score (-inf for a site without a rise)."""
    s = _logit(w, z, basis, z_clip, pairs)
    out = np.full(n_sites, -np.inf)
    np.maximum.at(out, site_of, s)
    return out


Key = tuple[str, float, float | None, float]  # basis, L2, z_clip, multiple-instance mix


@dataclass
class _Rises:
    """The training sites' judged rises, standardised: every rise counts in its site's
    score (`z_all`, `site_idx`), only those with a label are fitted (`fitted`: `z`,
    `y_rise`, `bags`); the second looks' rises (`z2_all`, `site_idx2`)."""

    sites: list[GridSite]
    y_site: np.ndarray
    mean: np.ndarray
    std: np.ndarray
    z_all: np.ndarray
    site_idx: np.ndarray
    fitted: np.ndarray
    z: np.ndarray
    y_rise: np.ndarray
    bags: np.ndarray
    z2_all: np.ndarray
    site_idx2: np.ndarray
    pairs: Pairs


def _rises(sites: list[GridSite], names: list[str]) -> _Rises:
    feats, site_of, y = [], [], []
    for i, r in enumerate(sites):
        for rise, label in zip(r.rises, rise_labels(r), strict=True):
            feats.append(rise_features(rise, names, f"{r.where}/verdict.json"))
            site_of.append(i)
            y.append(label)
    x_all, site_idx = np.array(feats), np.array(site_of)
    fitted = np.array([v is not None for v in y])
    x, y_rise = x_all[fitted], np.array([bool(v) for v in y])[fitted]
    mean = x.mean(axis=0)
    std = np.where(x.std(axis=0) > 0, x.std(axis=0), 1.0)
    z_all = (x_all - mean) / std
    # the second looks' rises (mound sim grid --second-look), scored by the same folds' models
    feats2, site_of2 = [], []
    for i, r in enumerate(sites):
        for rise in r.second or ():
            feats2.append(rise_features(rise, names, f"{r.where}/second/verdict.json"))
            site_of2.append(i)
    return _Rises(
        sites, np.array([r.truth.mound for r in sites]), mean, std, z_all,
        site_idx, fitted, z_all[fitted], y_rise,
        site_idx[fitted] * 2 + y_rise,  # a site's tumulus rises, and its other rises
        (np.array(feats2).reshape(-1, len(names)) - mean) / std,
        np.array(site_of2, dtype=int), product_pairs(names))


def _out_of_fold(d: _Rises, split: int, key: Key, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Each site's score by the model fitted on the other folds of split `split`, and its
    second look's (-inf: none)."""
    basis, l2, z_clip, mil = key
    n = len(d.sites)
    fold_of_site = site_folds(n, 5, seed + split)
    folds_all = fold_of_site[d.site_idx]
    folds = folds_all[d.fitted]
    oof = np.full(n, -np.inf)
    oof2 = np.full(n, -np.inf)
    for k in range(5):
        w = _fit(d.z[folds != k], d.y_rise[folds != k], l2, basis, z_clip, d.pairs,
                 d.bags[folds != k], mil)
        out = folds_all == k
        sc = _site_scores(d.z_all[out], d.site_idx[out], n, w, basis, z_clip, d.pairs)
        oof = np.where(fold_of_site == k, sc, oof)
        out2 = fold_of_site[d.site_idx2] == k
        if out2.any():
            sc2 = _site_scores(d.z2_all[out2], d.site_idx2[out2], n, w, basis, z_clip, d.pairs)
            oof2 = np.where(fold_of_site == k, sc2, oof2)
    return oof, oof2


def _kept(second: SecondLookRule | None
          ) -> tuple[SecondLookRule | None, SecondLookNotKept | None]:
    """The second look's rule if it gains enough out of fold (MIN_SECOND_LOOK_GAIN), else
    None and why it was not kept."""
    if second is None:
        return None, None
    o = second["trained"]["out_of_fold"]
    gain = o["found"] - o["found_first_look_same_fa"]
    if gain >= MIN_SECOND_LOOK_GAIN:
        return second, None
    return None, {"p_low": second["p_low"], "threshold": second["threshold"],
                  "out_of_fold": o,
                  "selected_in_sample": second["trained"]["selected_in_sample"],
                  "why": f"out of fold (nested) it finds {gain:.1f} more tumuli than the "
                         f"first look at as many false alarms (< {MIN_SECOND_LOOK_GAIN:g})"}


def _cloud_of(measured: list[GridSite]) -> str:
    """The cloud the sites' verdicts judged (verdict.json's `cloud`; sites made otherwise:
    unknown), "mixed" for several."""
    clouds = sorted({r.cloud for r in measured})
    return clouds[0] if len(clouds) == 1 else "mixed"


def candidates_of(measured: Sequence[GridSite]) -> str:
    """The candidate set the sites' verdicts measured (GridSite.candidates): one for all, or
    InputError naming a site of each (a model learns one set's rises)."""
    seen: dict[str, str] = {}
    for r in measured:
        seen.setdefault(r.candidates, r.where)
    if len(seen) > 1:
        raise InputError("the sites were measured with different candidate rises ("
                         + "; ".join(f"{c} at {w}" for c, w in seen.items())
                         + "): remeasure the grids with one (mound sim grid --candidates)")
    return next(iter(seen), CANDIDATES[0])


def check_candidates(model: VerdictModel, measured: Sequence[GridSite]) -> None:
    """InputError when a site was measured with other candidate rises than the model was
    trained on (its p would not be the model's to give)."""
    for r in measured:
        if r.candidates != model.candidates:
            raise InputError(f"{r.where}: measured with {r.candidates} candidate rises, the "
                             f"model was trained on {model.candidates} ones (remeasure the "
                             f"grid: mound sim grid --candidates {model.candidates})")


def cloud_settings(measured: list[GridSite]) -> dict[str, str | float] | None:
    """How the training sites' clouds were made (the model's `cloud_settings`): a sparse
    cloud, or the densify options of DENSE_SETTINGS from each site's dense/dense.json, which
    must agree; None where a site's cannot be read (old grids: the model then records
    none and `mound_recon verdict` checks nothing)."""
    from mound.recon.defaults import DENSE_SETTINGS

    cloud = _cloud_of(measured)
    if cloud == "sparse":
        return {"cloud": "sparse"}
    if cloud != "dense":
        return None
    seen: dict[tuple[object, ...], str] = {}
    for r in measured:
        path = Path(r.grid) / r.dir / "dense" / "dense.json"
        try:
            options = json.loads(path.read_text()).get("options", {})
        except (OSError, ValueError, AttributeError):
            return None
        seen.setdefault(tuple(options.get(k) for k in DENSE_SETTINGS), r.where)
    if len(seen) > 1:
        raise InputError("the training sites' dense clouds were made with different settings "
                         f"({', '.join(DENSE_SETTINGS)}: "
                         + "; ".join(f"{v} at {w}" for v, w in list(seen.items())[:3])
                         + "): a model learns one kind of cloud")
    (values,) = seen
    numbers = [v for v in values if isinstance(v, int | float)]
    if len(numbers) != len(values):
        return None
    return {"cloud": "dense", **dict(zip(DENSE_SETTINGS, numbers, strict=True))}


def train(rows: list[GridSite], names: list[str], sources: list[str],
          seed: int = 0, mil_mixes: tuple[float, ...] = MIL_MIXES) -> dict[str, Any]:
    """The model document from measured training sites (see the module text): a logistic
    regression on the judged rises (the tumulus's own rise a positive, every other rise a
    negative), the site's score its highest rise's, Platt- and beta-calibrated on the
    sites."""
    measured = [r for r in rows if r.measured]
    sites = [r for r in measured if r.rises]
    no_rise = [r for r in measured if not r.rises]
    n_mounds = sum(1 for r in sites if r.truth.mound)
    if len(sites) < 20 or n_mounds in (0, len(sites)):
        raise InputError("train-verdict: needs >= 20 measured sites with a rise, of both "
                         f"classes (got {len(sites)}, {n_mounds} mounds)")
    d = _rises(sites, names)
    y_site = d.y_site
    cv: dict[Key, float] = {}
    oof_by: dict[Key, tuple[np.ndarray, np.ndarray]] = {}
    bases = [b for b in BASES if b != "hinge_products" or d.pairs]  # none without them
    for key in itertools.product(bases, L2_GRID, Z_CLIPS, mil_mixes):
        oof_by[key] = _out_of_fold(d, 0, key, seed)
        a, b = _platt(oof_by[key][0], y_site)
        cv[key] = _log_loss(expit(a * oof_by[key][0] + b), y_site)
    best = min(cv, key=lambda k: cv[k])
    basis, l2, z_clip, mil = best
    # the chosen model's out-of-fold scores over CV_REPEATS splits (the first the one above)
    repeats = [oof_by[best]] + [_out_of_fold(d, rep, best, seed)
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
    w = _fit(d.z, d.y_rise, l2, basis, z_clip, d.pairs, d.bags, mil)
    neg = p_oof[~y_oof]
    thr = _threshold(neg)
    goal_site = np.array([goal_tumulus(r.truth) for r in sites])
    # the goal's tumuli that stand clear of their ground, and those it masks (stands_clear)
    ground = {name: goal_site & np.array([stands_clear(r.relief) is want for r in sites])
              for name, want in GROUND_CLASSES}
    second, not_kept = _kept(second_look_rule(
        g_oof.reshape(len(oofs), -1),
        _calibrated(a * np.stack([o2 for _, o2 in repeats]) + b, cal),
        thr, y_site, goal_site, ground))
    n_nr = len(no_rise)
    m_nr = sum(1 for r in no_rise if r.truth.mound)
    # the undecided band, on every site's out-of-fold p (those without a rise at p_no_rise)
    p_all = np.concatenate([p_oof.reshape(len(oofs), -1),
                            np.full((len(oofs), n_nr), (m_nr + 1) / (n_nr + 2))], axis=1)
    truths = [r.truth for r in sites + no_rise]
    slope = np.array([(r.ground or {}).get("site_slope_rad", math.nan)
                      for r in sites + no_rise])
    undecided = band_doc(p_all, np.array([t.mound for t in truths]),
                         np.array([band_goal(t) for t in truths]), thr, slope)
    confusion = confusion_doc(p_all, truths, undecided, slope)
    return {
        "schema": SCHEMA, "version": VERSION, "features": names,
        "mean": d.mean.tolist(), "std": d.std.tolist(), "basis": basis,
        **({"z_clip": z_clip} if z_clip is not None else {}),
        **({"products": [[names[i], names[j]] for i, j in d.pairs],
            "product_clip": PRODUCT_CLIP} if basis == "hinge_products" else {}),
        "weights": (a * w[:-1]).tolist(), "bias": float(a * w[-1] + b),
        "calibration": {"method": "beta", **cal._asdict()},
        "threshold": thr, "p_no_rise": (m_nr + 1) / (n_nr + 2),
        **({"second_look": second} if second else {}),
        "undecided": undecided,
        **({"cloud_settings": cs} if (cs := cloud_settings(measured)) else {}),
        **({"terrain_domain": td} if (td := terrain_domain(measured, sources)) else {}),
        **({"reasons": rs} if (rs := reason_thresholds(sites)) else {}),
        **({"detector": {"candidates": c}} if (c := candidates_of(measured)) != CANDIDATES[0]
           else {}),
        "trained": {"grids": sources, "cloud": _cloud_of(measured),
                    "sites": len(measured), "with_rise": len(sites),
                    "rises": len(d.z_all), "fitted_rises": len(d.z),
                    "mound_rises": int(d.y_rise.sum()),
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
                    "confusion": confusion,
                    **({"second_look_not_kept": not_kept} if not_kept else {}),
                    "out_of_fold": {"auc": roc_auc(p_oof, y_oof.astype(float)),
                                    "ece": expected_calibration_error(p_oof,
                                                                      y_oof.astype(float)),
                                    "false_alarm_rate": float(np.mean(neg >= thr)),
                                    "detection_rate": float(np.mean(p_oof[y_oof] >= thr)),
                                    "goal_found_by_ground": found_by_ground(
                                        p_oof.reshape(len(oofs), -1) >= thr, ground)},
                    "method": "logistic regression on the judged rises (L-BFGS, basis, L2, "
                              "z_clip and the share of the sites' multiple-instance loss by "
                              "5-fold CV over sites), the site's highest rise score "
                              "Platt-calibrated, then beta-calibrated, on out-of-fold "
                              f"predictions over {len(oofs)} splits into folds, the "
                              "threshold from them"},
    }


def _threshold(p_neg: np.ndarray) -> float:
    """The first look's threshold: the lowest p >= 0.5 (in steps of 0.01, at most 0.99) at
    which at most MAX_FA of `p_neg`, the p of sites without a tumulus, are called one."""
    thr = 0.5
    while thr < 0.99 and np.mean(p_neg >= thr) > MAX_FA:
        thr = round(thr + 0.01, 2)
    return thr


def probability(model: VerdictModel, rises: Sequence[Sequence[Rise]]) -> np.ndarray:
    """p(mound) of each site by its judged rises: the same formula as the C++ VerdictModel
    (the highest over its rises; p_no_rise without one). `model` is valid (model_file's
    reader, or train's own)."""
    names = model.features
    mean, std = np.array(model.mean), np.array(model.std)
    w = np.array(model.weights)
    basis, z_clip = model.basis, model.z_clip
    pairs = tuple((names.index(i), names.index(j)) for i, j in model.products)
    clip = PRODUCT_CLIP if model.product_clip is None else model.product_clip
    cal = model.calibration
    out = np.empty(len(rises))
    for k, site in enumerate(rises):
        if not site:
            out[k] = model.p_no_rise
            continue
        f = np.array([[q.features[n] for n in names] for q in site])
        out[k] = expit(_calibrated(model.bias + float(np.max(
            expand((f - mean) / std, basis, z_clip, pairs, clip) @ w)), cal))
    return out
