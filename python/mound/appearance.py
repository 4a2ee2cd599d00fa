"""Appearance of a site: albedo texture and Lambertian shading on the heightfield grid.

Albedo: a soil colour modulated by fractal value noise (octaves from metres down to the
grid spacing), grass patches from a low-frequency mask, and sparse small stones, so that
features can be tracked at every scale. Shading: Lambertian, I = ambient + (1 - ambient) *
max(0, n . s) with n the surface normal from the height gradient and s the unit vector
towards the sun (azimuth clockwise from north, elevation above the horizon, radians).
Deterministic for a seed; colours are 8-bit RGB per grid vertex.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mound.jsonio import InputError
from mound.terrain import Heightfield

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


def _value_noise(shape: tuple[int, int], cells: int, rng: np.random.Generator) -> np.ndarray:
    """Smooth noise in [0, 1]: random values on a (cells+1)^2 lattice, bicubic-smoothstep
    interpolated to `shape`."""
    lattice = rng.random((cells + 1, cells + 1))
    fy = np.linspace(0, cells, shape[0], endpoint=False)
    fx = np.linspace(0, cells, shape[1], endpoint=False)
    i, j = fy.astype(int), fx.astype(int)
    ty, tx = fy - i, fx - j
    ty, tx = ty * ty * (3 - 2 * ty), tx * tx * (3 - 2 * tx)
    a = lattice[np.ix_(i, j)]
    b = lattice[np.ix_(i, j + 1)]
    c = lattice[np.ix_(i + 1, j)]
    d = lattice[np.ix_(i + 1, j + 1)]
    top = a + (b - a) * tx[None, :]
    bottom = c + (d - c) * tx[None, :]
    return top + (bottom - top) * ty[:, None]


def albedo(hf: Heightfield, seed: int = 0) -> np.ndarray:
    """(ny, nx, 3) float albedo in [0, 255]."""
    rng = np.random.default_rng(seed + 7919)
    shape = hf.z_m.shape
    n = max(shape)
    fractal = np.zeros(shape)
    weight_sum = 0.0
    cells, weight = 4, 1.0
    while cells <= n // 2:
        fractal += weight * _value_noise(shape, cells, rng)
        weight_sum += weight
        cells *= 2
        weight *= 0.6
    fractal /= weight_sum
    grass_mask = np.clip((_value_noise(shape, 6, rng) - 0.45) * 6, 0, 1)
    colour = SOIL * (0.6 + 0.8 * fractal)[..., None]
    colour = colour * (1 - grass_mask[..., None]) + \
        (GRASS * (0.7 + 0.6 * fractal)[..., None]) * grass_mask[..., None]
    stones = rng.random(shape) < 0.004
    colour[stones] = STONE * rng.uniform(0.8, 1.1, size=(int(stones.sum()), 1))
    return np.clip(colour, 0, 255)


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
