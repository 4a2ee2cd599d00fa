"""The reward of a candidate site: the binary entropy of its mound probability, in bits.

H(p) = -p log2 p - (1 - p) log2 (1 - p): 1 bit at p = 0.5 (the satellite data cannot
settle the site, so a close look tells most), 0 at p = 0 or 1 (nothing to learn).
"""

from __future__ import annotations

import numpy as np
from scipy.special import xlogy


def binary_entropy_bits(p: np.ndarray | float) -> np.ndarray:
    """Paper: a site's reward, the binary entropy of p(mound). Vectorised H(p) in bits;
    exact 0 at p = 0 and 1 (no NaN), p outside [0, 1] refused."""
    q = np.asarray(p, dtype=np.float64)
    if np.any(~np.isfinite(q)) or np.any(q < 0) or np.any(q > 1):
        raise ValueError("probabilities must be finite and in [0, 1]")
    return -(xlogy(q, q) + xlogy(1 - q, 1 - q)) / np.log(2.0)
