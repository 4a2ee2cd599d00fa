"""Logistic regression p(x) = 1 / (1 + exp(-w^T x)) with labels y in {-1, +1}.

The objective is the mean logistic loss plus an optional L2 penalty on the weights (not on
the bias, which is the last component):

    f(w) = (1/n) sum_i log(1 + exp(-y_i w^T x_i)) + (l2/2) |w_{:-1}|^2
    grad = -(1/n) sum_i y_i x_i sigma(-y_i w^T x_i) + l2 [w_{:-1}, 0]

`fit_gd` is plain gradient descent with the constant step 1/L, L = lambda_max(X^T X)/(4n)
+ l2 the Lipschitz constant of the gradient (so every step decreases f), as the paper
trains its classifier; `fit_lbfgs` minimises the same f with scipy's L-BFGS-B, and
`fit_bags` that f mixed with a multiple-instance loss on bags of rows (loss_and_grad_bags).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize
from scipy.special import expit


@dataclass
class Fit:
    w: np.ndarray
    iterations: int
    converged: bool
    loss: float
    grad_norm: float
    seconds: float
    solver: str


def _penalised(w: np.ndarray, loss: float, grad: np.ndarray,
               l2: float) -> tuple[float, np.ndarray]:
    """The loss and gradient plus the L2 penalty (l2/2) |w_{:-1}|^2, not on the bias."""
    if l2 > 0:
        reg = w.copy()
        reg[-1] = 0.0
        loss += 0.5 * l2 * float(reg @ reg)
        grad = grad + l2 * reg
    return loss, grad


def loss_and_grad(w: np.ndarray, x: np.ndarray, y: np.ndarray, l2: float = 0.0,
                  weight: np.ndarray | None = None) -> tuple[float, np.ndarray]:
    """Paper (coarse search): the mean logistic loss (1/n) sum log(1 + exp(-y w^T x)),
    the negative log-likelihood of the model below, and its gradient. `weight`: per-row
    weights (class balance), the loss becoming (1/n) sum weight_i log(...)."""
    z = y * (x @ w)
    if weight is None:
        loss = float(np.mean(np.logaddexp(0.0, -z)))
        grad = -(x.T @ (y * expit(-z))) / x.shape[0]
    else:
        loss = float(np.mean(weight * np.logaddexp(0.0, -z)))
        grad = -(x.T @ (weight * y * expit(-z))) / x.shape[0]
    return _penalised(w, loss, grad, l2)


def _bag_index(bags: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each row's bag numbered 0..m-1, and each bag's label; ValueError unless every row has
    a bag and every row of a bag the same label."""
    bags = np.asarray(bags)
    if len(bags) != len(y):
        raise ValueError("bags: one bag id per row")
    ub, inv = np.unique(bags, return_inverse=True)
    lo, hi = np.full(len(ub), np.inf), np.full(len(ub), -np.inf)
    np.minimum.at(lo, inv, y)
    np.maximum.at(hi, inv, y)
    if (lo != hi).any():
        raise ValueError("bags: every row of a bag has one label")
    return inv, lo


def _bag_loss_and_grad(w: np.ndarray, x: np.ndarray, y: np.ndarray, inv: np.ndarray,
                       yb: np.ndarray, mix: float, tau: float,
                       l2: float) -> tuple[float, np.ndarray]:
    """loss_and_grad_bags on bags already numbered (`inv`, `yb`: _bag_index's)."""
    f = x @ w
    z = y * f
    loss = (1 - mix) * float(np.mean(np.logaddexp(0.0, -z)))
    grad = -(1 - mix) * (x.T @ (y * expit(-z))) / x.shape[0]
    if mix > 0:
        m = len(yb)
        top = np.full(m, -np.inf)
        np.maximum.at(top, inv, f)
        e = np.exp((f - top[inv]) / tau)
        se = np.bincount(inv, e, m)
        zb = yb * (top + tau * np.log(se))
        loss += mix * float(np.mean(np.logaddexp(0.0, -zb)))
        gs = -(yb * expit(-zb)) / m
        grad = grad + mix * (x.T @ (gs[inv] * e / se[inv]))
    return _penalised(w, loss, grad, l2)


def loss_and_grad_bags(w: np.ndarray, x: np.ndarray, y: np.ndarray, bags: np.ndarray,
                       mix: float, tau: float, l2: float = 0.0) -> tuple[float, np.ndarray]:
    """The per-row logistic loss mixed with a multiple-instance one: rows are grouped into
    `bags` (integer ids; every row of a bag has the same label), a bag's score is the smooth
    maximum S = tau log sum_i exp(w^T x_i / tau) of its rows' scores (-> the maximum as
    tau -> 0) and it takes the logistic loss of S with its label. f(w) = (1 - mix) (1/n)
    sum_i log(1 + exp(-y_i w^T x_i)) + mix (1/m) sum_bags log(1 + exp(-y_b S_b)) + the L2
    penalty (not on the bias). A bag's gradient is spread over its rows by the softmax
    weights exp((w^T x_i - S) / tau). Used where a decision is the maximum over rows (a
    site's verdict is its highest rise's): the bag loss weighs a negative site's highest
    rows, which decide, above its many low ones, which do not."""
    return _bag_loss_and_grad(w, x, y, *_bag_index(bags, y), mix, tau, l2)


def fit_bags(x: np.ndarray, y: np.ndarray, bags: np.ndarray, mix: float, tau: float,
             l2: float = 0.0, tol: float = 1e-6, max_iter: int = 10_000) -> Fit:
    """Minimises loss_and_grad_bags with L-BFGS-B from w = 0 (mix = 0: fit_lbfgs's f); the
    bags are numbered once, not at every step."""
    if not 0 <= mix <= 1 or not tau > 0:
        raise ValueError(f"fit_bags: mix {mix} (0..1), tau {tau} (> 0)")
    inv, yb = _bag_index(bags, y)
    start = time.perf_counter()
    res = minimize(_bag_loss_and_grad, np.zeros(x.shape[1]),
                   args=(x, y, inv, yb, mix, tau, l2), jac=True, method="L-BFGS-B",
                   options={"gtol": tol, "maxiter": max_iter, "ftol": 0.0})
    loss, grad = _bag_loss_and_grad(res.x, x, y, inv, yb, mix, tau, l2)
    gn = float(np.linalg.norm(grad))
    return Fit(res.x, int(res.nit), gn <= tol, loss, gn, time.perf_counter() - start,
               "lbfgs-bags")


def lipschitz(x: np.ndarray, l2: float, weight: np.ndarray | None = None) -> float:
    xw = x if weight is None else x * np.sqrt(weight)[:, None]
    return float(np.linalg.eigvalsh(xw.T @ xw / x.shape[0])[-1]) / 4.0 + l2


def fit_gd(x: np.ndarray, y: np.ndarray, l2: float = 0.0, tol: float = 1e-6,
           max_iter: float = 200_000, weight: np.ndarray | None = None) -> Fit:
    """Paper (coarse search): gradient descent w <- w - (1/L) grad from w = 0 until
    |grad| <= tol, L the Lipschitz constant of the gradient. A fractional `max_iter`
    stops part-way along the last step (t = 13.4: 13 steps and 0.4 of the 14th), so that
    early stopping can be set continuously."""
    start = time.perf_counter()
    step = 1.0 / lipschitz(x, l2, weight)
    w = np.zeros(x.shape[1])
    loss, grad = loss_and_grad(w, x, y, l2, weight)
    it = 0
    while it < max_iter and np.linalg.norm(grad) > tol:
        w = w - min(1.0, max_iter - it) * step * grad
        loss, grad = loss_and_grad(w, x, y, l2, weight)
        it += 1
    gn = float(np.linalg.norm(grad))
    return Fit(w, it, gn <= tol, loss, gn, time.perf_counter() - start, "gd")


def fit_lbfgs(x: np.ndarray, y: np.ndarray, l2: float = 0.0, tol: float = 1e-6,
              max_iter: int = 10_000, weight: np.ndarray | None = None,
              w0: np.ndarray | None = None) -> Fit:
    start = time.perf_counter()
    res = minimize(loss_and_grad, np.zeros(x.shape[1]) if w0 is None else w0,
                   args=(x, y, l2, weight), jac=True,
                   method="L-BFGS-B", options={"gtol": tol, "maxiter": max_iter, "ftol": 0.0})
    loss, grad = loss_and_grad(res.x, x, y, l2, weight)
    gn = float(np.linalg.norm(grad))
    return Fit(res.x, int(res.nit), gn <= tol, loss, gn, time.perf_counter() - start, "lbfgs")


def fit(x: np.ndarray, y: np.ndarray, solver: str = "gd", l2: float = 0.0,
        tol: float = 1e-6, max_iter: float = 200_000,
        weight: np.ndarray | None = None) -> Fit:
    if solver == "gd":
        return fit_gd(x, y, l2, tol, max_iter, weight)
    if solver == "lbfgs":
        return fit_lbfgs(x, y, l2, tol, weight=weight)
    raise ValueError(f"unknown solver {solver!r} (gd, lbfgs)")


def predict_proba(w: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Paper (coarse search): the logistic model p(mound | x) = 1 / (1 + exp(-w^T x))."""
    return expit(x @ w)
