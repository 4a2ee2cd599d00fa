"""Feature selection and standardisation for the Statlog 3 x 3 x 4 pixel blocks."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

N_PIXELS = 9
N_BANDS = 4
BAND_NAMES = ("green", "red", "near-infrared 1", "near-infrared 2")  # Landsat MSS bands 1-4


def band_columns(band: int | None) -> list[int]:
    """Columns of one band (0..3) for the 9 pixels, or all 36 columns for None."""
    if band is None:
        return list(range(N_PIXELS * N_BANDS))
    if not 0 <= band < N_BANDS:
        raise ValueError(f"band must be 0..{N_BANDS - 1}, got {band}")
    return [N_BANDS * k + band for k in range(N_PIXELS)]


@dataclass
class Standardizer:
    mean: np.ndarray
    std: np.ndarray

    @classmethod
    def fit(cls, x: np.ndarray) -> Standardizer:
        std = x.std(axis=0)
        return cls(mean=x.mean(axis=0), std=np.where(std > 0, std, 1.0))

    def design(self, x: np.ndarray) -> np.ndarray:
        """Standardised features with a trailing bias column of ones: rows are x for w^T x."""
        z = (x - self.mean) / self.std
        return np.hstack([z, np.ones((x.shape[0], 1))])


def hinge_basis(z: np.ndarray) -> np.ndarray:
    """z, max(z - 1, 0) and max(-z - 1, 0) side by side (standardised features z, rows are
    samples): a piecewise-linear response per feature that keeps a logistic regression
    linear in its weights (the scene model's and the verdict model's `hinge` basis)."""
    return np.hstack([z, np.maximum(z - 1.0, 0.0), np.maximum(-z - 1.0, 0.0)])
