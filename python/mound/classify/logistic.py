"""Logistic regression p(x) = 1 / (1 + exp(-w^T x)) with labels y in {-1, +1}.

The objective is the mean logistic loss plus an optional L2 penalty on the weights (not on
the bias, which is the last component):

    f(w) = (1/n) sum_i log(1 + exp(-y_i w^T x_i)) + (l2/2) |w_{:-1}|^2
    grad = -(1/n) sum_i y_i x_i sigma(-y_i w^T x_i) + l2 [w_{:-1}, 0]

`fit_gd` is plain gradient descent with the constant step 1/L, L = lambda_max(X^T X)/(4n)
+ l2 the Lipschitz constant of the gradient (so every step decreases f), as the paper
trains its classifier; `fit_lbfgs` minimises the same f with scipy's L-BFGS-B.
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
    if l2 > 0:
        reg = w.copy()
        reg[-1] = 0.0
        loss += 0.5 * l2 * float(reg @ reg)
        grad = grad + l2 * reg
    return loss, grad


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
