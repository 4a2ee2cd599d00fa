"""Features of a scene window around each scored position (pure numpy; no file I/O).

Two kinds, named in the model (`features.kind`):

- `paper`: the paper's (and Statlog's) 3 x 3 pixels of the chosen bands at a coarse ground
  resolution. The scene is first averaged over f x f pixel blocks, f = round(resample_m /
  pixel size) (area averaging, nodata left out); a position is one coarse cell, and its
  features are the 9 cells around it in row-major order, each with its bands in the chosen
  order: column n_bands * k + b, as Statlog's column 4k + b. Raw values: a model of these
  features is tied to the units it was trained on (digital numbers or reflectance).
- `multiscale` (default): rotation-invariant centre-surround descriptors for mounds that
  are 10-60 pixels across. For every chosen band (and NDVI when red and near-infrared are
  among them), at radii r = `radii_m` (square windows of half-side r, box sums from
  summed-area tables) against a background window of half-side `background_m`:
    contrast_r  = (mean of the centre window - mean of the ring out to 2r) / sigma_bg
    |contrast_r|  (a mound may be lighter or darker than its field)
    texture_r   = std of the centre window / sigma_bg
    dipole_r    = |(east half - west half, north half - south half)| / sigma_bg
                  (the lit and shaded flanks under an oblique sun, in any direction)
  sigma_bg being the band's standard deviation over the background window; plus the mean
  NDVI at the smallest radius and over the background, and each band's share of the
  bands' sum at the smallest radius (colour). Dividing by the local sigma makes every
  texture/contrast feature independent of a band's gain and offset, so digital numbers
  and reflectance give the same values (NDVI and the colour shares are ratios: offsets
  matter there, gains do not).

Positions lie on a grid of `stride` pixels: output cell (k, l) of a block whose core
starts at scene pixel (R0, C0) is evaluated at pixel (R0 + k stride + stride // 2, C0 + l
stride + stride // 2) (for `paper`, stride = f and the cell is the coarse cell). A position
whose centre pixel is nodata, or whose windows hold too few valid pixels, gets NaN features
(and no probability).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mound.errors import InputError
from mound.jsonio import JsonObject

DEFAULT_RADII_M = (3.0, 6.0, 12.0, 24.0)
DEFAULT_BACKGROUND_M = 48.0
MIN_VALID = 0.95  # share of the background window that must hold valid pixels


def _sat(a: np.ndarray) -> np.ndarray:
    """Summed-area table with a zero first row and column: P[i, j] = a[:i, :j].sum()."""
    p = np.zeros((a.shape[0] + 1, a.shape[1] + 1))
    np.cumsum(a, axis=0, out=p[1:, 1:])
    np.cumsum(p[1:, 1:], axis=1, out=p[1:, 1:])
    return p


@dataclass
class _Grid:
    """Positions i0 + k*st (k < n) by j0 + l*st (l < m) of a padded block."""
    i0: int
    j0: int
    n: int
    m: int
    st: int

    def box(self, p: np.ndarray, top: int, bottom: int, left: int, right: int) -> np.ndarray:
        """Sum over rows i-top..i+bottom, columns j-left..j+right at every position."""
        n, m, st = self.n, self.m, self.st

        def at(r: int, c: int) -> np.ndarray:
            return p[r:r + (n - 1) * st + 1:st, c:c + (m - 1) * st + 1:st]

        i, j = self.i0, self.j0
        return (at(i + bottom + 1, j + right + 1) - at(i - top, j + right + 1)
                - at(i + bottom + 1, j - left) + at(i - top, j - left))


@dataclass
class FeatureSpec:
    kind: str                                   # "multiscale" | "paper"
    radii_m: tuple[float, ...] = DEFAULT_RADII_M
    background_m: float = DEFAULT_BACKGROUND_M
    resample_m: float = 30.0                    # paper: the coarse ground resolution
    band_labels: list[str] = field(default_factory=list)  # names of the chosen bands

    def __post_init__(self) -> None:
        if self.kind not in ("multiscale", "paper"):
            raise InputError(f"features: unknown kind {self.kind!r} (multiscale, paper)")
        if self.kind == "multiscale":
            r = self.radii_m
            if not r or any(not (0 < x < 1e4) for x in r) or list(r) != sorted(set(r)):
                raise InputError("features.radii_m: increasing positive radii in metres")
            if not r[-1] < self.background_m < 1e4:
                raise InputError("features.background_m: must exceed the largest radius")
        elif not 0 < self.resample_m < 1e5:
            raise InputError("--resample-m: must be > 0 m")

    @property
    def has_ndvi(self) -> bool:
        return "red" in self.band_labels and "nir" in self.band_labels

    def factor(self, res_m: float) -> int:
        """paper: pixels per coarse cell."""
        return max(1, round(self.resample_m / res_m))

    def window_px(self, res_m: float) -> tuple[list[int], int]:
        """multiscale: the radii and the background half-side in pixels at `res_m`."""
        def px(metres: float) -> int:
            return max(1, round(metres / res_m))

        return [px(r) for r in self.radii_m], px(self.background_m)

    def halo_px(self, res_m: float, stride: int) -> int:
        """Pixels of context needed on each side of a block's core."""
        if self.kind == "paper":
            return self.factor(res_m)
        return self.reach_px(res_m) + stride + 1

    def reach_px(self, res_m: float) -> int:
        """multiscale: the half-side of the widest window, the background's or the outer
        ring's of the largest radius (2 r)."""
        radii, background = self.window_px(res_m)
        return max(background, 2 * radii[-1])

    def cell_px(self, res_m: float, stride: int) -> int:
        """The output grid's step in pixels."""
        return self.factor(res_m) if self.kind == "paper" else stride

    def names(self) -> list[str]:
        labels = self.band_labels
        if self.kind == "paper":
            return [f"p{k}_{b}" for k in range(9) for b in labels]
        chans = [*labels, "ndvi"] if self.has_ndvi else list(labels)
        out = []
        for c in chans:
            for r in self.radii_m:
                out += [f"{c}_contrast_{r:g}", f"{c}_abscontrast_{r:g}",
                        f"{c}_texture_{r:g}", f"{c}_dipole_{r:g}"]
        if self.has_ndvi:
            out += [f"ndvi_mean_{self.radii_m[0]:g}", f"ndvi_mean_bg{self.background_m:g}"]
        if len(labels) > 1:
            out += [f"{b}_share" for b in labels]
        return out

    def to_doc(self) -> JsonObject:
        if self.kind == "paper":
            return {"kind": "paper", "resample_m": self.resample_m, "pixels": "3x3"}
        return {"kind": "multiscale", "radii_m": list(self.radii_m),
                "background_m": self.background_m, "ndvi": self.has_ndvi}

    @classmethod
    def from_doc(cls, doc: dict[str, Any], band_labels: list[str]) -> FeatureSpec:
        kind = doc.get("kind")
        if kind == "paper":
            return cls("paper", resample_m=float(doc["resample_m"]), band_labels=band_labels)
        return cls(str(kind), radii_m=tuple(float(r) for r in doc["radii_m"]),
                   background_m=float(doc["background_m"]), band_labels=band_labels)

    # ------------------------------------------------------------------ computing

    def compute(self, block: np.ndarray, res_m: float, halo: int, stride: int, n: int,
                m: int) -> np.ndarray:
        """Features (n * m, F) of the n x m output cells of `block` (bands, rows, cols),
        whose core starts `halo` pixels in; rows with NaN where a position has none. The
        arithmetic is float64 whatever the block's type."""
        block = block.astype(np.float64, copy=False)
        if self.kind == "paper":
            return self._paper(block, res_m, halo, n, m)
        return self._multiscale(block, res_m, halo, stride, n, m)

    def _paper(self, block: np.ndarray, res_m: float, halo: int, n: int, m: int
               ) -> np.ndarray:
        f = self.factor(res_m)
        nb = block.shape[0]
        rows, cols = (n + 2) * f, (m + 2) * f
        a = block[:, halo - f:halo - f + rows, halo - f:halo - f + cols]
        with warnings.catch_warnings():  # all-NaN (nodata) cells rightly give NaN
            warnings.simplefilter("ignore", RuntimeWarning)
            coarse = np.nanmean(a.reshape(nb, n + 2, f, m + 2, f), axis=(2, 4))
        cols_out = []
        for dr in (0, 1, 2):
            for dc in (0, 1, 2):
                for b in range(nb):
                    cols_out.append(coarse[b, dr:dr + n, dc:dc + m].ravel())
        return np.stack(cols_out, axis=1)

    def _multiscale(self, block: np.ndarray, res_m: float, halo: int, stride: int, n: int,
                    m: int) -> np.ndarray:
        tables = self.tables(block, res_m, halo, stride, m)
        return np.concatenate([tables.rows(k, min(n, k + 64)) for k in range(0, n, 64)],
                              axis=1).T

    def tables(self, block: np.ndarray, res_m: float, halo: int, stride: int, m: int
               ) -> MultiscaleTables:
        """The summed-area tables of a block (multiscale), from which `rows` evaluates the
        features of any range of output rows (the scorer goes a few rows at a time, so that
        the intermediate arrays stay in the processor's cache)."""
        return MultiscaleTables(self, block.astype(np.float64, copy=False), res_m, halo,
                                stride, m)


class MultiscaleTables:
    """A block's summed-area tables (float64: box sums are differences of large sums) of
    each channel and its square, and of the valid pixels unless every pixel is valid (then
    every window's count is its area)."""

    def __init__(self, spec: FeatureSpec, block: np.ndarray, res_m: float, halo: int,
                 stride: int, m: int) -> None:
        labels = spec.band_labels
        valid = np.isfinite(block).all(axis=0)
        chans = [np.where(valid, block[b], 0.0) for b in range(block.shape[0])]
        if spec.has_ndvi:
            red, nir = chans[labels.index("red")], chans[labels.index("nir")]
            den = nir + red
            ok = valid & (np.abs(den) > 1e-9)
            chans.append(np.where(ok, (nir - red) / np.where(ok, den, 1.0), 0.0))
            valid = ok
            chans = [np.where(valid, c, 0.0) for c in chans]
        self.n_bands = len(labels)
        self.has_ndvi = spec.has_ndvi
        self.valid = valid
        self.uniform = bool(valid.all())
        self.cnt_p = None if self.uniform else _sat(valid.astype(np.float64))
        self.p1 = [_sat(c) for c in chans]
        self.p2 = [_sat(c * c) for c in chans]
        self.hs, self.hbg = spec.window_px(res_m)
        self.i0 = self.j0 = halo + stride // 2
        self.stride = stride
        self.m = m
        self.n_features = len(spec.names())

    def _count(self, g: _Grid, top: int, bottom: int, left: int, right: int
               ) -> np.ndarray | float:
        if self.cnt_p is None:
            return float((top + bottom + 1) * (left + right + 1))
        return g.box(self.cnt_p, top, bottom, left, right)

    def rows(self, k0: int, k1: int) -> np.ndarray:
        """Features (F, (k1 - k0) * m) of output rows [k0, k1), NaN where a position has
        none."""
        st, m = self.stride, self.m
        g = _Grid(self.i0 + k0 * st, self.j0, k1 - k0, m, st)
        hs, hbg = self.hs, self.hbg
        sym = {h: self._count(g, h, h, h, h) for h in {*hs, *(2 * h for h in hs), hbg}}
        half = {h: (self._count(g, h, h, -1, h), self._count(g, h, h, h, -1),
                    self._count(g, h, -1, h, h), self._count(g, -1, h, h, h)) for h in hs}
        out = np.empty((self.n_features, g.n, m))
        k = 0
        with np.errstate(invalid="ignore", divide="ignore"):
            small_means = []
            bg_mean = None
            for p1, p2 in zip(self.p1, self.p2, strict=True):
                sums = {h: g.box(p1, h, h, h, h) for h in sym}
                n_bg = sym[hbg]
                mean_bg = sums[hbg] / n_bg
                var_bg = g.box(p2, hbg, hbg, hbg, hbg) / n_bg - mean_bg * mean_bg
                scale = np.sqrt(np.maximum(var_bg, 0.0, out=var_bg), out=var_bg)
                scale += 1e-3 * np.abs(mean_bg) + 1e-9
                inv = 1.0 / scale
                for h in hs:
                    mean = sums[h] / sym[h]
                    outer = 2 * h if 2 * h in sums else hbg
                    ring = (sums[outer] - sums[h]) / np.maximum(sym[outer] - sym[h], 1.0)
                    c = out[k]
                    np.subtract(mean, ring, out=c)
                    c *= inv
                    np.abs(c, out=out[k + 1])
                    var = g.box(p2, h, h, h, h) / sym[h] - mean * mean
                    np.sqrt(np.maximum(var, 0.0, out=var), out=out[k + 2])
                    out[k + 2] *= inv
                    e, w, no, so = half[h]
                    de = g.box(p1, h, h, -1, h) / e - g.box(p1, h, h, h, -1) / w
                    dn = g.box(p1, h, -1, h, h) / no - g.box(p1, -1, h, h, h) / so
                    np.hypot(de, dn, out=out[k + 3])
                    out[k + 3] *= inv
                    k += 4
                small_means.append(sums[hs[0]] / sym[hs[0]])
                bg_mean = mean_bg
            if self.has_ndvi:
                out[k], out[k + 1] = small_means[-1], bg_mean
                k += 2
            nb = self.n_bands
            if nb > 1:
                total = sum(small_means[:nb])
                for b in range(nb):
                    np.divide(small_means[b], total, out=out[k])
                    k += 1
        out = out.reshape(self.n_features, -1)
        # Complete enough windows: a position near the scene's edge or a nodata hole would
        # get its background statistics from a truncated window (a bias that, on stamps
        # cut around known mounds, tells the centre from the edge).
        centre_ok = self.valid[g.i0:g.i0 + (g.n - 1) * st + 1:st,
                               g.j0:g.j0 + (m - 1) * st + 1:st]
        enough = centre_ok & (sym[hbg] >= MIN_VALID * (2 * hbg + 1) ** 2)
        bad = ~enough.ravel() | ~np.isfinite(out).all(axis=0)
        out[:, bad] = np.nan
        return out
