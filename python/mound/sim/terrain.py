"""Site terrain as a heightfield in metres (ENU, origin at the site centre, z up).

Ground: a gently undulating surface, a sum of a few long-wavelength sinusoids with random
phases and directions (seeded), amplitude `ground_relief_m`.
Tumulus (optional): a radially symmetric mound of `diameter_m` and `height_m` with a
profile: "conical"; "spherical_cap"; "drum" (a vertical-sided drum of `drum_height_m`
carrying a spherical cap). Erosion/slump smooths the profile over `erosion_m` (a Gaussian
blur of the radial profile), and an optional looters' pit is a conical depression of
`pit_radius_m` and `pit_depth_m` at `pit_offset_m` from the centre. The flat control is
the same ground without the mound (same seed, so the same ground).

Presets: "bin_tepe" (a Lydian tumulus: 60 m across, 12 m high, on a 160 m square site) and
"lab" (a scale model about 1 m across, as in the paper's experiment, on a 2.6 m square).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from mound.errors import InputError

PROFILES = ("conical", "spherical_cap", "drum")


@dataclass(frozen=True)
class TerrainSpec:
    size_m: float = 160.0          # side of the square site
    resolution_m: float = 0.25     # grid spacing
    ground_relief_m: float = 0.8   # amplitude of the undulation
    mound: bool = True
    diameter_m: float = 60.0
    height_m: float = 12.0
    profile: str = "spherical_cap"
    drum_height_m: float = 2.0
    erosion_m: float = 3.0
    pit_radius_m: float = 0.0      # 0: no looters' pit
    pit_depth_m: float = 0.0
    pit_offset_m: float = 0.0
    seed: int = 0

    def validate(self) -> None:
        def need(ok: bool, msg: str) -> None:
            if not ok:
                raise InputError(f"terrain: {msg}")

        need(self.size_m > 0, f"size_m must be > 0, got {self.size_m}")
        need(0 < self.resolution_m <= self.size_m / 4,
             f"resolution_m must be in (0, size_m/4], got {self.resolution_m}")
        need(self.ground_relief_m >= 0, "ground_relief_m must be >= 0")
        if self.mound:
            need(self.diameter_m > 0, f"diameter_m must be > 0, got {self.diameter_m}")
            need(self.height_m > 0, f"height_m must be > 0, got {self.height_m}")
            need(self.diameter_m <= self.size_m, "the mound must fit on the site")
            need(self.profile in PROFILES, f"profile must be one of {PROFILES}")
            if self.profile == "drum":
                need(0 <= self.drum_height_m < self.height_m,
                     "drum_height_m must be in [0, height)")
            need(self.erosion_m >= 0, "erosion_m must be >= 0")
            need(self.pit_radius_m >= 0 and self.pit_depth_m >= 0, "pit sizes must be >= 0")
            need(self.pit_offset_m + self.pit_radius_m <= self.diameter_m / 2 or
                 self.pit_radius_m == 0, "the looters' pit must lie on the mound")


PRESETS = {
    "bin_tepe": TerrainSpec(),
    "lab": TerrainSpec(size_m=2.6, resolution_m=0.004, ground_relief_m=0.002, diameter_m=1.0,
                       height_m=0.15, drum_height_m=0.02, erosion_m=0.02),
}


def preset(name: str, **overrides: object) -> TerrainSpec:
    if name not in PRESETS:
        raise InputError(f"terrain: unknown preset {name!r} ({', '.join(PRESETS)})")
    spec = replace(PRESETS[name], **overrides)  # type: ignore[arg-type]
    spec.validate()
    return spec


@dataclass
class Heightfield:
    x_m: np.ndarray  # (nx,) east coordinates of the columns
    y_m: np.ndarray  # (ny,) north coordinates of the rows
    z_m: np.ndarray  # (ny, nx) heights

    def height_at(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Bilinear height at (x, y); points outside the site get the nearest edge value."""
        fx = np.clip((np.asarray(x) - self.x_m[0]) / (self.x_m[1] - self.x_m[0]),
                     0, len(self.x_m) - 1.000001)
        fy = np.clip((np.asarray(y) - self.y_m[0]) / (self.y_m[1] - self.y_m[0]),
                     0, len(self.y_m) - 1.000001)
        i, j = np.floor(fy).astype(int), np.floor(fx).astype(int)
        a, b = fy - i, fx - j
        z = self.z_m
        return ((1 - a) * (1 - b) * z[i, j] + (1 - a) * b * z[i, j + 1] +
                a * (1 - b) * z[i + 1, j] + a * b * z[i + 1, j + 1])

    def covers(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Whether (x, y) lies over the grid."""
        return ((x >= self.x_m[0]) & (x <= self.x_m[-1]) & (y >= self.y_m[0])
                & (y <= self.y_m[-1]))

    def points(self) -> np.ndarray:
        """All grid vertices as (n, 3) ENU points."""
        xx, yy = np.meshgrid(self.x_m, self.y_m)
        return np.stack([xx.ravel(), yy.ravel(), self.z_m.ravel()], axis=1)


def _radial_profile(spec: TerrainSpec, r: np.ndarray) -> np.ndarray:
    radius = spec.diameter_m / 2
    h = spec.height_m
    if spec.profile == "conical":
        z = h * np.clip(1 - r / radius, 0, None)
    elif spec.profile == "spherical_cap":
        big_r = (radius ** 2 + h ** 2) / (2 * h)  # sphere radius of a cap of height h
        z = np.where(r < radius, np.sqrt(np.clip(big_r ** 2 - r ** 2, 0, None)) - (big_r - h), 0)
    else:  # drum: vertical-sided drum, then a cap of the remaining height
        cap = h - spec.drum_height_m
        big_r = (radius ** 2 + cap ** 2) / (2 * cap)
        z = np.where(r < radius, spec.drum_height_m +
                     np.sqrt(np.clip(big_r ** 2 - r ** 2, 0, None)) - (big_r - cap), 0)
    return np.clip(z, 0, None)


def build(spec: TerrainSpec) -> Heightfield:
    spec.validate()
    n = int(round(spec.size_m / spec.resolution_m)) + 1
    axis = np.linspace(-spec.size_m / 2, spec.size_m / 2, n)
    xx, yy = np.meshgrid(axis, axis)
    rng = np.random.default_rng(spec.seed)
    ground = np.zeros_like(xx)
    for _ in range(4):
        wavelength = spec.size_m * rng.uniform(0.6, 2.0)
        theta, phase = rng.uniform(0, 2 * np.pi, size=2)
        ground += np.sin(2 * np.pi * (xx * np.cos(theta) + yy * np.sin(theta)) / wavelength
                         + phase)
    z = spec.ground_relief_m / 4 * ground
    if spec.mound:
        r = np.hypot(xx, yy)
        # Erosion: the radial profile blurred with a Gaussian of sigma erosion_m.
        rs = np.linspace(0, spec.size_m, 4096)
        prof = _radial_profile(spec, rs)
        if spec.erosion_m > 0:
            step = rs[1] - rs[0]
            k = np.arange(-int(4 * spec.erosion_m / step), int(4 * spec.erosion_m / step) + 1)
            w = np.exp(-0.5 * (k * step / spec.erosion_m) ** 2)
            padded = np.concatenate([prof[len(k) // 2:0:-1], prof, np.zeros(len(k))])
            prof = np.convolve(padded, w / w.sum(), mode="same")[len(k) // 2:len(k) // 2 + len(rs)]
        mound = np.interp(r, rs, prof)
        if spec.pit_radius_m > 0 and spec.pit_depth_m > 0:
            rp = np.hypot(xx - spec.pit_offset_m, yy)
            mound -= spec.pit_depth_m * np.clip(1 - rp / spec.pit_radius_m, 0, None)
        z = z + mound
    return Heightfield(axis, axis.copy(), z)


def load_site_heightfield(site_dir: str | Path) -> Heightfield:
    """The true surface a simulated site was rendered from (site.json's grid and
    heightfield.npy)."""
    import json

    site_dir = Path(site_dir)
    grid = json.loads((site_dir / "site.json").read_text())["heightfield"]
    z = np.load(site_dir / grid["npy"])
    ny, nx = z.shape
    return Heightfield(x_m=grid["x0_m"] + grid["spacing_m"] * np.arange(nx),
                       y_m=grid["y0_m"] + grid["spacing_m"] * np.arange(ny), z_m=z)
