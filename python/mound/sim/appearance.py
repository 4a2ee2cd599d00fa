"""Appearance of a site: albedo texture and Lambertian shading on the heightfield grid.

Albedo: a soil colour modulated by value noise at coarse scales (tens of metres), grass
patches from a low-frequency mask, and fine detail (octaves from 40 texels down to two,
dark tufts, scattered stones), so that features can be tracked at every scale.
Shading: Lambertian, I = ambient + (1 - ambient) * max(0, n . s) with n the surface normal
from the height gradient and s the unit vector towards the sun (azimuth clockwise from
north, elevation above the horizon, radians). Deterministic for a seed; colours are 8-bit
RGB, per grid vertex (shaded_colours) or on a finer texture grid (shaded_texture).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mound.errors import InputError
from mound.sim.terrain import Heightfield

SOIL = np.array([150.0, 118.0, 84.0])
GRASS = np.array([96.0, 122.0, 60.0])
STONE = np.array([200.0, 196.0, 186.0])


SUN_AZIMUTH_RAD = math.radians(135.0)  # from the south-east
SUN_ELEVATION_RAD = math.radians(40.0)


@dataclass(frozen=True)
class Lighting:
    sun_azimuth_rad: float = SUN_AZIMUTH_RAD
    sun_elevation_rad: float = SUN_ELEVATION_RAD
    ambient: float = 0.35

    def sun_vector(self) -> np.ndarray:
        if not 0 < self.sun_elevation_rad <= np.pi / 2:
            raise InputError("lighting: sun elevation must be in (0, pi/2] rad")
        if not 0 <= self.ambient < 1:
            raise InputError("lighting: ambient must be in [0, 1)")
        ce = np.cos(self.sun_elevation_rad)
        return np.array([ce * np.sin(self.sun_azimuth_rad), ce * np.cos(self.sun_azimuth_rad),
                         np.sin(self.sun_elevation_rad)])


# Rows per block when a texture is built: every field of a block stays in the cache while
# the octaves, colours and light are combined (the result is the same as whole arrays).
_BLOCK_ROWS = 32


class _ValueNoise:
    """Smooth noise in [0, 1]: random values on a (cells+1)^2 lattice, bicubic-smoothstep
    interpolated to `shape`; the lattice is drawn on construction, rows on demand."""

    def __init__(self, shape: tuple[int, int], cells: int, rng: np.random.Generator) -> None:
        lattice = rng.random((cells + 1, cells + 1))
        fy = np.linspace(0, cells, shape[0], endpoint=False)
        fx = np.linspace(0, cells, shape[1], endpoint=False)
        self.i, j = fy.astype(int), fx.astype(int)
        ty, tx = fy - self.i, fx - j
        self.ty = (ty * ty * (3 - 2 * ty)).astype(np.float32)[:, None]
        tx = (tx * tx * (3 - 2 * tx)).astype(np.float32)
        # Separable: along x on the lattice rows, then along y.
        self.along_x = (lattice[:, j] * (1 - tx) + lattice[:, j + 1] * tx).astype(np.float32)

    def rows(self, r0: int, r1: int) -> np.ndarray:
        i = self.i[r0:r1]
        top = self.along_x[i]
        top += (self.along_x[i + 1] - top) * self.ty[r0:r1]
        return top


class _Octaves:
    """Sum of value-noise octaves (wavelength halving from `longest_m` down to
    `shortest_m`), octave k weighted decay^k, centred on 0; lattices drawn on construction."""

    def __init__(self, shape: tuple[int, int], size_m: float, longest_m: float,
                 shortest_m: float, decay: float, rng: np.random.Generator) -> None:
        self.shape = shape
        self.octaves: list[tuple[float, _ValueNoise]] = []
        cells, weight = max(1, int(round(size_m / longest_m))), 1.0
        while size_m / cells >= shortest_m and cells <= max(shape) // 2:
            self.octaves.append((weight, _ValueNoise(shape, cells, rng)))
            cells *= 2
            weight *= decay

    def rows(self, r0: int, r1: int) -> np.ndarray:
        out = np.zeros((r1 - r0, self.shape[1]), dtype=np.float32)
        for weight, noise in self.octaves:
            out += weight * (noise.rows(r0, r1) - 0.5)
        return out


def _blocks(n: int) -> list[tuple[int, int]]:
    return [(r, min(n, r + _BLOCK_ROWS)) for r in range(0, n, _BLOCK_ROWS)]


def albedo_grid(shape: tuple[int, int], texel_m: float, seed: int = 0,
                light: np.ndarray | None = None) -> np.ndarray:
    """(ny, nx, 3) float32 albedo in [0, 255] on a grid of `shape` with `texel_m` spacing
    (with `light`, an (ny, nx) factor: uint8 albedo x light, clipped, instead).

    Scales are in texels, so the texture suits a camera whose ground pixel is about one
    texel at any preset (at 5 cm texels: coarse soil brightness from a quarter of the site
    down to 4 m, grass patches; fine detail a standardised sum of octaves from 2 m down to
    two texels (+-22 % brightness), dark tufts up to 0.6 m, scattered 2x2-texel stones),
    so that every image window of a few pixels has texture to track. Built in blocks of
    rows (the lattices are drawn first, in a fixed order, so the result is the seed's)."""
    rng = np.random.default_rng(seed + 7919)
    size_m = (max(shape) - 1) * texel_m
    coarse = _Octaves(shape, size_m, size_m / 4, 80 * texel_m, 0.6, rng)
    fine_oct = _Octaves(shape, size_m, 40 * texel_m, 2 * texel_m, 0.85, rng)
    # The fine detail is standardised over the whole grid: built first.
    fine = np.empty(shape, dtype=np.float32)
    for r0, r1 in _blocks(shape[0]):
        fine[r0:r1] = fine_oct.rows(r0, r1)
    fine /= max(float(fine.std()), 1e-6)
    grass = _ValueNoise(shape, 6, rng)
    tufts_oct = _Octaves(shape, size_m, 12 * texel_m, 2 * texel_m, 0.7, rng)
    seeds = rng.random(shape) < 0.003
    stones = seeds.copy()  # 2x2 texels each
    stones[1:, :] |= seeds[:-1, :]
    stones[:, 1:] |= seeds[:, :-1]
    stones[1:, 1:] |= seeds[:-1, :-1]
    stone_colours = (STONE * rng.uniform(0.75, 1.1, size=(int(stones.sum()), 1))
                     ).astype(np.float32)
    soil, grass_rgb = SOIL.astype(np.float32), GRASS.astype(np.float32)
    out = np.empty((*shape, 3), dtype=np.float32 if light is None else np.uint8)
    used = 0
    for r0, r1 in _blocks(shape[0]):
        grass_mask = np.clip((grass.rows(r0, r1) - 0.45) * 6, 0, 1).astype(np.float32)
        tufts = np.clip((tufts_oct.rows(r0, r1) - 0.12) * 8, 0, 1)
        brightness = ((0.6 + 0.8 * (0.5 + coarse.rows(r0, r1))) * (1 + 0.22 * fine[r0:r1])
                      * (1 - 0.35 * tufts))
        colour = (soil * (1 - grass_mask[..., None]) +
                  grass_rgb * grass_mask[..., None]) * brightness[..., None]
        here = stones[r0:r1]
        n = int(here.sum())
        colour[here] = stone_colours[used:used + n]
        used += n
        np.clip(colour, 0, 255, out=colour)
        if light is None:
            out[r0:r1] = colour
        else:
            colour *= light[r0:r1, :, None]
            out[r0:r1] = np.clip(colour, 0, 255).astype(np.uint8)
    return out


def albedo(hf: Heightfield, seed: int = 0) -> np.ndarray:
    """(ny, nx, 3) float albedo in [0, 255] per heightfield vertex."""
    return albedo_grid(hf.z_m.shape, float(hf.x_m[1] - hf.x_m[0]), seed)


def normals(hf: Heightfield) -> np.ndarray:
    """(ny, nx, 3) unit surface normals (ENU) from the height gradient."""
    dzdy, dzdx = np.gradient(hf.z_m, hf.y_m, hf.x_m)
    n = np.stack([-dzdx, -dzdy, np.ones_like(hf.z_m)], axis=-1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def shaded_colours(hf: Heightfield, lighting: Lighting, seed: int = 0) -> np.ndarray:
    """(ny, nx, 3) uint8 RGB: albedo times Lambertian shading."""
    s = lighting.sun_vector()
    intensity = lighting.ambient + (1 - lighting.ambient) * np.clip(normals(hf) @ s, 0, None)
    return np.clip(albedo(hf, seed) * intensity[..., None], 0, 255).astype(np.uint8)


def shaded_texture(hf: Heightfield, lighting: Lighting, texel_m: float, seed: int = 0
                   ) -> np.ndarray:
    """(th, tw, 3) uint8 RGB texture over the heightfield's extent with texels `texel_m`
    apart (texel (0, 0) at the grid's first vertex, rows northwards). The heightfield's
    spacing must be an integer multiple of `texel_m`; normals are interpolated bilinearly
    between vertices (smooth shading), the albedo has detail down to the texel."""
    spacing = hf.x_m[1] - hf.x_m[0]
    factor = spacing / texel_m if texel_m > 0 else math.nan  # NaN, 0 and below: refused
    if not (math.isfinite(factor) and abs(factor - round(factor)) <= 1e-6
            and round(factor) >= 1):
        raise InputError(f"texture: texel_m {texel_m} must divide the grid spacing {spacing}")
    f = int(round(factor))
    shape = ((len(hf.y_m) - 1) * f + 1, (len(hf.x_m) - 1) * f + 1)
    s = lighting.sun_vector()
    vertex_light = lighting.ambient + (1 - lighting.ambient) * np.clip(normals(hf) @ s, 0, None)
    light = _refine(vertex_light.astype(np.float32), f)
    return albedo_grid(shape, texel_m, seed, light=light)


def _refine(grid: np.ndarray, f: int) -> np.ndarray:
    """Bilinear refinement of a vertex grid by an integer factor (corners kept)."""
    if f == 1:
        return grid
    t = np.arange(f, dtype=np.float32) / f
    rows = grid[:-1, None, :] * (1 - t)[None, :, None] + grid[1:, None, :] * t[None, :, None]
    rows = np.concatenate([rows.reshape(-1, grid.shape[1]), grid[-1:]], axis=0)
    cols = rows[:, :-1, None] * (1 - t)[None, None, :] + rows[:, 1:, None] * t[None, None, :]
    return np.concatenate([cols.reshape(rows.shape[0], -1), rows[:, -1:]], axis=1)
