"""Where a grid's terrain patches may lie on a DEM: squares of valid cells (no nodata)
inside the part of the DEM the grid draws from.

The DEM is split across its longer axis (columns when it is as wide as it is tall):
`train` is the first 60 % of it in file order (the west or north part), `heldout` the
rest, `all` the whole. Training grids drawn from `train` and held-out grids from
`heldout` never share a metre of terrain (a patch lies wholly inside its part). Sites are
placed by their centre, in the DEM's own CRS, which must be in metres (the patch's
offsets are metres).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mound.errors import InputError
from mound.geometry.dem import valid_cells

PARTS = ("all", "train", "heldout")
TRAIN_SHARE = 0.6
MARGIN_M = 2.0  # beyond the site's square: the bilinear reads of its edge


@dataclass
class DemPlaces:
    """The centres (DEM CRS) at which a square site fits on `path`'s valid cells within
    `part`."""

    path: str
    part: str
    valid: np.ndarray      # validity of the cells within the part (False outside it)
    transform: object      # affine: (col, row) of pixel corners -> CRS
    pixel_m: float         # the larger side of a pixel in the CRS, m
    _cache: dict[int, np.ndarray]

    @classmethod
    def open(cls, path: str, part: str = "all") -> DemPlaces:
        if part not in PARTS:
            raise InputError(f"--dem-part: expected one of {', '.join(PARTS)}, got {part!r}")
        valid, tf = valid_cells(path)
        h, w = valid.shape
        if part != "all":
            along_rows = h > w
            n = h if along_rows else w
            cut = int(round(TRAIN_SHARE * n))
            keep = np.zeros(n, dtype=bool)
            keep[:cut] = part == "train"
            keep[cut:] = part == "heldout"
            valid = valid & (keep[:, None] if along_rows else keep[None, :])
        a, b, d, e = tf.a, tf.b, tf.d, tf.e
        pixel = max(math.hypot(a, d), math.hypot(b, e))
        return cls(path, part, valid, tf, pixel, {})

    def _centres(self, half_px: int) -> np.ndarray:
        """(row, col) of the cells whose square of half-side `half_px` is all valid."""
        if half_px not in self._cache:
            bad = np.pad((~self.valid).astype(np.int64), ((1, 0), (1, 0))).cumsum(0).cumsum(1)
            h, w = self.valid.shape
            k = 2 * half_px + 1
            if k > h or k > w:
                self._cache[half_px] = np.zeros((0, 2), dtype=np.int64)
            else:
                count = bad[k:, k:] - bad[:-k, k:] - bad[k:, :-k] + bad[:-k, :-k]
                rows, cols = np.nonzero(count == 0)
                self._cache[half_px] = np.stack([rows + half_px, cols + half_px], axis=1)
        return self._cache[half_px]

    def half_px(self, size_m: float) -> int:
        return int(math.ceil((size_m / 2 + MARGIN_M) / self.pixel_m))

    def fits(self, size_m: float) -> bool:
        """Whether a site `size_m` across fits anywhere."""
        return len(self._centres(self.half_px(size_m))) > 0

    def draw(self, rng: np.random.Generator, size_m: float) -> tuple[float, float]:
        """A centre (DEM CRS) of a site `size_m` across, uniform over where it fits."""
        cells = self._centres(self.half_px(size_m))
        if not len(cells):
            raise InputError(f"--dem: {self.path}: no {size_m:g} m square of valid cells "
                             f"within its {self.part} part")
        r, c = cells[int(rng.integers(len(cells)))]
        x, y = self.transform @ (c + 0.5, r + 0.5)  # type: ignore[operator]
        return float(x), float(y)
