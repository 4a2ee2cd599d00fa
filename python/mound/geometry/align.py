"""Least-squares similarity between point sets (Umeyama, "Least-squares estimation of
transformation parameters between two point patterns", IEEE PAMI 1991): for evaluating
reconstructions against ground truth (the C++ side has its own, cpp/geometry/sim3)."""

from __future__ import annotations

import numpy as np


def umeyama(src: np.ndarray, dst: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """(s, R, t) minimising sum |dst - (s R src + t)|^2 over (n, 3) arrays, n >= 3."""
    ms, md = src.mean(0), dst.mean(0)
    a, b = src - ms, dst - md
    u, d, vt = np.linalg.svd(b.T @ a / len(src))
    sign = np.diag([1.0, 1.0, float(np.sign(np.linalg.det(u @ vt)))])
    r = u @ sign @ vt
    s = float(np.trace(np.diag(d) @ sign) / (a ** 2).sum(1).mean())
    return s, r, md - s * r @ ms


def apply(s: float, r: np.ndarray, t: np.ndarray, points: np.ndarray) -> np.ndarray:
    return (s * (r @ points.T)).T + t
