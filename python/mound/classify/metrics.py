"""Evaluation of probabilistic binary predictions (labels y in {-1, +1})."""

from __future__ import annotations

import numpy as np
from scipy.stats import beta, rankdata

# The paper's decision rule, in one place: the classifier labels a site a mound when
# p(mound) >= 0.5 (Table I's error rates, the survey's labels of sites not flown).
DECISION_P = 0.5


def says_mound(p: float) -> bool:
    """The classifier's label of a site of probability p(mound)."""
    return bool(p >= DECISION_P)


def accuracy(p: np.ndarray, y: np.ndarray) -> float:
    return float(np.mean(np.where(p >= DECISION_P, 1.0, -1.0) == y))


def majority_accuracy(y: np.ndarray) -> float:
    pos = float(np.mean(y > 0))
    return max(pos, 1.0 - pos)


def roc_auc(p: np.ndarray, y: np.ndarray) -> float:
    """Area under the ROC curve by the Mann-Whitney rank statistic (ties count half)."""
    pos = y > 0
    n_pos, n_neg = int(pos.sum()), int((~pos).sum())
    if n_pos == 0 or n_neg == 0:
        raise ValueError("ROC AUC needs both classes")
    ranks = rankdata(p)
    return float((ranks[pos].sum() - n_pos * (n_pos + 1) / 2) / (n_pos * n_neg))


def log_loss(p: np.ndarray, y: np.ndarray, eps: float = 1e-15) -> float:
    q = np.clip(p, eps, 1 - eps)
    return float(-np.mean(np.where(y > 0, np.log(q), np.log(1 - q))))


def reliability(p: np.ndarray, y: np.ndarray, bins: int = 10) -> list[dict[str, float]]:
    """Calibration table: per equal-width bin of p, the count, mean p and observed rate."""
    edges = np.linspace(0.0, 1.0, bins + 1)
    idx = np.clip(np.digitize(p, edges[1:-1]), 0, bins - 1)
    table = []
    for b in range(bins):
        m = idx == b
        n = int(m.sum())
        table.append({
            "lo": float(edges[b]), "hi": float(edges[b + 1]), "count": n,
            "mean_p": float(p[m].mean()) if n else float("nan"),
            "observed": float(np.mean(y[m] > 0)) if n else float("nan"),
        })
    return table


def expected_calibration_error(p: np.ndarray, y: np.ndarray, bins: int = 10) -> float:
    n = len(p)
    return float(sum(r["count"] / n * abs(r["mean_p"] - r["observed"])
                     for r in reliability(p, y, bins) if r["count"]))


def clopper_pearson(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """The exact (Clopper-Pearson) two-sided interval of a rate of k successes in n trials:
    it covers the true rate in at least `level` of repeated samples. 78 of 78 gives
    [0.954, 1]: no sample of 78 can show a rate of 99 %."""
    if not 0 <= k <= n or n == 0:
        raise ValueError(f"clopper_pearson: need 0 <= k <= n, n > 0 (got k={k}, n={n})")
    a = (1 - level) / 2
    lo = 0.0 if k == 0 else float(beta.ppf(a, k, n - k + 1))
    hi = 1.0 if k == n else float(beta.ppf(1 - a, k + 1, n - k))
    return lo, hi


def ece_consistency(p: np.ndarray, y: np.ndarray, bins: int = 10, draws: int = 2000,
                    seed: int = 0) -> dict[str, float]:
    """Is an ECE distinguishable from that of a calibrated forecast? Consistency resampling
    (Broecker and Smith 2007): outcomes drawn from p itself are calibrated by construction,
    and their ECE is what sampling alone gives on these forecasts. Returns the observed ECE,
    the 95th percentile of the calibrated draws' ECE, and the fraction of draws at or above
    the observed one (a p-value: small means miscalibrated)."""
    rng = np.random.default_rng(seed)
    obs = expected_calibration_error(p, y, bins)
    null = np.array([expected_calibration_error(p, (rng.random(len(p)) < p).astype(float), bins)
                     for _ in range(draws)])
    return {"ece": obs, "ece_if_calibrated_95": float(np.quantile(null, 0.95)),
            "p_value": float(np.mean(null >= obs))}


def summary(p: np.ndarray, y: np.ndarray) -> dict[str, float]:
    return {
        "accuracy": accuracy(p, y), "majority_accuracy": majority_accuracy(y),
        "auc": roc_auc(p, y), "log_loss": log_loss(p, y),
        "ece": expected_calibration_error(p, y),
    }


def detection_error_rates(labels: list[bool], truth: list[bool | None]
                          ) -> tuple[float | None, float | None]:
    """The paper's error rates of mound labels: eps_MD, the fraction of true mounds labelled
    "no mound" (missed detections), and eps_FA, the fraction of the other sites labelled
    "mound" (false alarms). Sites of unknown truth (None) are left out; a rate over no
    site is None."""
    pos = [lab for lab, t in zip(labels, truth, strict=True) if t is True]
    neg = [lab for lab, t in zip(labels, truth, strict=True) if t is False]
    md = sum(1 for lab in pos if not lab) / len(pos) if pos else None
    fa = sum(1 for lab in neg if lab) / len(neg) if neg else None
    return md, fa
