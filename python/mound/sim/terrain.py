"""Site terrain as a heightfield in metres (ENU, origin at the site centre, z up).

Ground: a gently undulating surface, a sum of a few long-wavelength sinusoids with random
phases and directions (seeded), amplitude `ground_relief_m`.
Tumulus (optional): a radially symmetric mound of `diameter_m` and `height_m` (or an
elongated one, `length_m` along `mound_azimuth_deg`, its profile stretched) with a
profile: "conical"; "spherical_cap"; "drum" (a vertical-sided drum of `drum_height_m`
carrying a spherical cap). Erosion/slump smooths the profile over `erosion_m` (a Gaussian
blur of the radial profile), and an optional looters' pit is a conical depression of
`pit_radius_m` and `pit_depth_m` at `pit_offset_m` from the centre. The flat control is
the same ground without the mound (same seed, so the same ground).

Field conditions (issue 26): the mound may stand off the site centre (`mound_x_m`,
`mound_y_m`) and be wider than the flight's scan; a "ploughed" profile (a cap whose top is
flattened at 60 % of its height, then scaled back to its height; the plough's spreading is
the erosion, which the grid makes at least a tenth of the diameter); a looters'
trench (`trench_width_m`, `trench_depth_m`, `trench_azimuth_deg`: a V-shaped cut through
the centre, across the whole mound); ground on a slope (`slope_deg` rising towards
`slope_azimuth_deg`, clockwise from north) or a patch of a real DEM (`dem_path`, centred
on `dem_x_m`, `dem_y_m` in the DEM's CRS; its heights less the patch's median, so the
site's datum stays near 0); ridge-and-valley ground (issue 68: `ridge_relief_m` from
valley floor to crest, crests `ridge_wavelength_m` apart along `ridge_azimuth_deg`,
meandering by a tenth of that) and hillside terraces (`terrace_step_m`: the ground's height
cut into flat treads of that rise, each riser `terrace_riser` of the step's run); and
confusers (`Confuser`), alone on a site without a mound:
an elongated natural hillock, a ridge or a ditch across the site, a terrace edge (a step),
a group of trees (steep crowns), a building (a box with vertical walls) or a haystack (a
small steep dome). `truth()` says what stands on the site.

Presets: "bin_tepe" (a Lydian tumulus: 60 m across, 12 m high, on a 160 m square site) and
"lab" (a scale model about 1 m across, as in the paper's experiment, on a 2.6 m square).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from mound.errors import InputError
from mound.jsonio import JsonObject, read_json

PROFILES = ("conical", "spherical_cap", "drum", "ploughed")
CONFUSERS = ("hillock", "ridge", "ditch", "terrace", "trees", "building", "haystack")
PLOUGH_CUT = 0.6  # a ploughed cap is cut at this share of its height, then scaled back


@dataclass(frozen=True)
class Confuser:
    """Something on a site that is not a tumulus: `kind` (CONFUSERS) centred at (x_m, y_m),
    `length_m` along `azimuth_deg` (clockwise from north), `width_m` across it, `height_m`
    (a ditch's depth; a terrace's step). Trees: `count` crowns of diameter `width_m` within
    a group `length_m` across."""
    kind: str
    x_m: float = 0.0
    y_m: float = 0.0
    length_m: float = 40.0
    width_m: float = 10.0
    height_m: float = 2.0
    azimuth_deg: float = 0.0
    count: int = 1
    seed: int = 0

    def check(self) -> None:
        if self.kind not in CONFUSERS:
            raise InputError(f"terrain: confuser kind must be one of {CONFUSERS}, got "
                             f"{self.kind!r}")
        if not (self.length_m > 0 and self.width_m > 0 and self.height_m > 0
                and self.count >= 1):
            raise InputError(f"terrain: confuser {self.kind}: length, width, height and "
                             "count must be > 0")


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
    mound_x_m: float = 0.0         # the mound's centre, m east / north of the site centre
    mound_y_m: float = 0.0
    # An elongated base (a population's measured tumuli): `length_m` along
    # `mound_azimuth_deg` (clockwise from north), `diameter_m` across it; 0: round
    length_m: float = 0.0
    mound_azimuth_deg: float = 0.0
    trench_width_m: float = 0.0    # 0: no looters' trench
    trench_depth_m: float = 0.0
    trench_azimuth_deg: float = 0.0
    slope_deg: float = 0.0         # the ground rises towards slope_azimuth_deg
    slope_azimuth_deg: float = 0.0
    dem_path: str | None = None    # a real terrain patch in place of the undulation
    dem_x_m: float = 0.0
    dem_y_m: float = 0.0
    # With a DEM: z = 0 at this height of the DEM (the mission's ground of the site, so that
    # the simulator flies the mission's heights); None: the patch's median. The heights
    # are then read as dem_vertical ones (None: as they are).
    dem_ground_m: float | None = None
    dem_vertical: str | None = None
    # Continue the patch beyond the DEM's edge (dem_patch's point reflection) rather than
    # refuse the site: the second look's wider site near the edge (sim/looks.py, `wider`).
    dem_extend: bool = False
    ridge_relief_m: float = 0.0      # 0: no ridges; valley floor to crest
    ridge_wavelength_m: float = 100.0
    ridge_azimuth_deg: float = 0.0   # the crests run across this direction
    terrace_step_m: float = 0.0      # 0: no terraces; the rise of one terrace
    terrace_riser: float = 0.3       # the share of a terrace's run its riser takes
    confusers: tuple[Confuser, ...] = ()
    seed: int = 0

    def check(self) -> None:
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
            need(self.trench_width_m >= 0 and self.trench_depth_m >= 0,
                 "trench sizes must be >= 0")
            need(self.length_m == 0 or self.length_m >= self.diameter_m,
                 "length_m must be 0 (round) or >= diameter_m")
            need(max(abs(self.mound_x_m), abs(self.mound_y_m)) + self.base_length_m / 2
                 <= self.size_m / 2, "the mound (offset included) must fit on the site")
        need(0 <= self.slope_deg < 45, f"slope_deg must be in [0, 45), got {self.slope_deg}")
        need(self.ridge_relief_m >= 0, "ridge_relief_m must be >= 0")
        need(self.ridge_wavelength_m > 0, "ridge_wavelength_m must be > 0")
        need(self.terrace_step_m >= 0, "terrace_step_m must be >= 0")
        need(0 < self.terrace_riser <= 1, "terrace_riser must be in (0, 1]")
        for c in self.confusers:
            c.check()

    @property
    def base_length_m(self) -> float:
        """The tumulus's base along its long axis (its diameter when round)."""
        return self.length_m if self.length_m > 0 else self.diameter_m

    def truth(self) -> JsonObject:
        """What stands on the site (truth.json): a tumulus with its size and centre, or the
        most prominent confuser, or bare ground. A tumulus's `diameter_m` is its base's
        mean extent, (length + width) / 2, as an inventory's "across" (an elongated
        one's `length_m`, `width_m` and `azimuth_deg` beside it)."""
        if self.mound:
            shape = ({"length_m": self.length_m, "width_m": self.diameter_m,
                      "azimuth_deg": self.mound_azimuth_deg} if self.length_m > 0 else {})
            return {"mound": True, "kind": "tumulus", "profile": self.profile,
                    "height_m": self.height_m,
                    "diameter_m": (self.base_length_m + self.diameter_m) / 2, **shape,
                    "centre_enu_m": [self.mound_x_m, self.mound_y_m],
                    "pit": self.pit_radius_m > 0 and self.pit_depth_m > 0,
                    "trench": self.trench_width_m > 0 and self.trench_depth_m > 0,
                    **self._ground_truth()}
        if self.confusers:
            c = self.confusers[0]
            return {"mound": False, "kind": c.kind, "height_m": c.height_m,
                    "diameter_m": c.width_m, "length_m": c.length_m,
                    "centre_enu_m": [c.x_m, c.y_m], **self._ground_truth()}
        return {"mound": False, "kind": "flat", "height_m": 0.0, "diameter_m": 0.0,
                "centre_enu_m": [0.0, 0.0], **self._ground_truth()}

    def _ground_truth(self) -> JsonObject:
        """The ground under the site: its slope, a DEM's patch or not, and its ridges and
        terraces when it has them."""
        out: JsonObject = {"slope_deg": self.slope_deg, "dem": self.dem_path is not None}
        if self.ridge_relief_m > 0:
            out.update(ridge_relief_m=self.ridge_relief_m,
                       ridge_wavelength_m=self.ridge_wavelength_m)
        if self.terrace_step_m > 0:
            out["terrace_step_m"] = self.terrace_step_m
        return out


PRESETS = {
    "bin_tepe": TerrainSpec(),
    "lab": TerrainSpec(size_m=2.6, resolution_m=0.004, ground_relief_m=0.002, diameter_m=1.0,
                       height_m=0.15, drum_height_m=0.02, erosion_m=0.02),
}


def preset(name: str, **overrides: object) -> TerrainSpec:
    if name not in PRESETS:
        raise InputError(f"terrain: unknown preset {name!r} ({', '.join(PRESETS)})")
    spec = replace(PRESETS[name], **overrides)  # type: ignore[arg-type]
    spec.check()
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


# The ring of ground around a tumulus that mound_relief fits (R < r <= RELIEF_RING R, R the
# base radius) and the fewest surface cells it must hold.
RELIEF_RING = 1.3
RELIEF_MIN_CELLS = 20


def mound_relief(hf: Heightfield, centre_m: tuple[float, float] | list[float],
                 diameter_m: float) -> dict[str, float] | None:
    """How far a tumulus stands out of the ground around it, on the true surface (a truth of
    the simulated site, not a measurement of its cloud): the ground is a plane fitted by least
    squares to the surface in the ring R < r <= 1.3 R around the base (R the base radius);
    `prominence_m` is the 95th percentile of the surface over that plane within R / 2 of the
    centre, and `ground_clutter_m` the RMS of the ring about the plane: the ground's own
    relief at the tumulus's scale, what a verdict has to tell the tumulus from. On flat
    ground the prominence is the tumulus's height and the clutter near 0; a tumulus that
    fills a hollow of its own size on a hillside stands no higher than the ground's
    undulations around it. None when the ring holds fewer than 20 cells of the surface
    (a tumulus wider than the simulated patch)."""
    if not diameter_m > 0:
        return None
    xx, yy = np.meshgrid(hf.x_m - centre_m[0], hf.y_m - centre_m[1])
    r = np.hypot(xx, yy)
    radius = diameter_m / 2
    ring = (r > radius) & (r <= RELIEF_RING * radius) & np.isfinite(hf.z_m)
    inner = (r <= radius / 2) & np.isfinite(hf.z_m)
    if ring.sum() < RELIEF_MIN_CELLS or not inner.any():
        return None
    a = np.column_stack([np.ones(int(ring.sum())), xx[ring], yy[ring]])
    plane, *_ = np.linalg.lstsq(a, hf.z_m[ring], rcond=None)
    above = hf.z_m[inner] - (plane[0] + plane[1] * xx[inner] + plane[2] * yy[inner])
    return {"prominence_m": float(np.percentile(above, 95)),
            "ground_clutter_m": float(np.sqrt(np.mean((hf.z_m[ring] - a @ plane) ** 2)))}


def _radial_profile(spec: TerrainSpec, r: np.ndarray) -> np.ndarray:
    radius = spec.diameter_m / 2
    h = spec.height_m
    if spec.profile == "conical":
        z = h * np.clip(1 - r / radius, 0, None)
    elif spec.profile == "spherical_cap":
        big_r = (radius ** 2 + h ** 2) / (2 * h)  # sphere radius of a cap of height h
        z = np.where(r < radius, np.sqrt(np.clip(big_r ** 2 - r ** 2, 0, None)) - (big_r - h), 0)
    elif spec.profile == "ploughed":  # a cap flattened at PLOUGH_CUT of its height
        big_r = (radius ** 2 + h ** 2) / (2 * h)
        cap = np.where(r < radius, np.sqrt(np.clip(big_r ** 2 - r ** 2, 0, None))
                       - (big_r - h), 0)
        z = np.minimum(cap, PLOUGH_CUT * h) / PLOUGH_CUT
    else:  # drum: vertical-sided drum, then a cap of the remaining height
        cap_h = h - spec.drum_height_m
        big_r = (radius ** 2 + cap_h ** 2) / (2 * cap_h)
        z = np.where(r < radius, spec.drum_height_m +
                     np.sqrt(np.clip(big_r ** 2 - r ** 2, 0, None)) - (big_r - cap_h), 0)
    return np.clip(z, 0, None)


def _along_across(xx: np.ndarray, yy: np.ndarray, x0: float, y0: float, azimuth_deg: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Coordinates along the azimuth (clockwise from north) and across it (to the right)."""
    a = np.deg2rad(azimuth_deg)
    dx, dy = xx - x0, yy - y0
    return dx * np.sin(a) + dy * np.cos(a), dx * np.cos(a) - dy * np.sin(a)


def _confuser(c: Confuser, xx: np.ndarray, yy: np.ndarray, ground: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray | None]:
    """(added relief, or None; a raised top that replaces the ground where it is higher)."""
    u, v = _along_across(xx, yy, c.x_m, c.y_m, c.azimuth_deg)
    if c.kind == "hillock":  # elongated, smooth: a Gaussian of sigma L/4 x W/4
        return c.height_m * np.exp(-0.5 * ((4 * u / c.length_m) ** 2 + (4 * v / c.width_m) ** 2)
                                   ), None
    if c.kind == "ridge":   # across the whole site
        return c.height_m * np.exp(-0.5 * (4 * v / c.width_m) ** 2), None
    if c.kind == "ditch":
        return -c.height_m * np.exp(-0.5 * (4 * v / c.width_m) ** 2), None
    if c.kind == "terrace":  # the ground steps up by height_m across a bank width_m wide
        return c.height_m * 0.5 * (1 + np.tanh(4 * v / c.width_m)), None
    if c.kind == "building":  # a box on the ground under its centre, vertical walls
        i = int(np.argmin(np.abs(yy[:, 0] - c.y_m)))
        j = int(np.argmin(np.abs(xx[0, :] - c.x_m)))
        base = float(ground[i, j])
        inside = (np.abs(u) <= c.length_m / 2) & (np.abs(v) <= c.width_m / 2)
        top = np.where(inside, base + c.height_m, -np.inf)
        return np.zeros_like(xx), top
    rng = np.random.default_rng([c.seed, 17])
    if c.kind == "haystack":
        centres = [(c.x_m, c.y_m, c.width_m / 2, c.height_m)]
    else:  # trees: crowns within a group length_m across, heights 70-100 % of height_m
        centres = []
        for _ in range(c.count):
            rad, ang = c.length_m / 2 * np.sqrt(rng.random()), 2 * np.pi * rng.random()
            centres.append((c.x_m + rad * np.sin(ang), c.y_m + rad * np.cos(ang),
                            c.width_m / 2 * rng.uniform(0.8, 1.2),
                            c.height_m * rng.uniform(0.7, 1.0)))
    top = np.full_like(xx, -np.inf)
    for cx, cy, a, h in centres:
        r = np.hypot(xx - cx, yy - cy)
        # a crown / stack: an ellipsoid of radius a and height h standing on the ground
        dome = ground + h * np.sqrt(np.clip(1 - (r / a) ** 2, 0, None))
        top = np.where(r < a, np.maximum(top, dome), top)
    return np.zeros_like(xx), top


def dem_patch(path: str, x0: float, y0: float, axis: np.ndarray,
              ground_m: float | None = None, vertical: str | None = None,
              extend: bool = False) -> np.ndarray:
    """Heights of a DEM (any CRS; geometry/dem.py, the project's one DEM reader) on the
    site's grid, the patch centred on (x0, y0) in the DEM's CRS, its axes along the DEM's
    (north up); less `ground_m` (AMSL, with the heights read as `vertical` ones), or less
    the patch's median height (then what the heights are above does not matter).

    A site that reaches off the DEM is refused (InputError), unless `extend`: then the rows
    and columns of the grid that the DEM holds are read and continued beyond its edge by
    their point reflection about the edge (z(e + d) = 2 z(e) - z(e - d), row by row and
    column by column): heights and slopes run on across the edge, with the DEM's own relief
    turned over, so that no fold (a ridge or a valley) stands at the edge; nodata cells
    within the DEM (an irregular outline) take their nearest valid cell's height. Only the
    simulator's second look draws such a site (a scan twice as wide about a site near the
    DEM's edge); the DEM must hold its centre. Never used for flying: geometry/dem.py
    refuses any point off the DEM."""
    from mound.geometry.dem import Dem

    dem = Dem.at(path, x0, y0, vertical or "egm96",
                 margin_m=float(np.abs(axis).max()) * 1.5 + 10)
    what = f"a site {axis[-1] - axis[0]:g} m across at ({x0:g}, {y0:g})"
    cols = rows = np.arange(len(axis))
    if extend:
        cols = np.flatnonzero(dem.inside_crs(x0 + axis, np.full(len(axis), y0)))
        rows = np.flatnonzero(dem.inside_crs(np.full(len(axis), x0), y0 + axis))
        if len(cols) < 2 or len(rows) < 2:
            raise InputError(f"{path}: {what}: its centre lies off the DEM")
    xx, yy = np.meshgrid(x0 + axis[cols], y0 + axis[rows])  # row i is y = y0 + axis[i]
    patch = dem.height_crs(xx, yy, what, nodata_ok=extend).reshape(len(rows), len(cols))
    if extend and not np.isfinite(patch).all():  # nodata within the DEM: its nearest cell
        from scipy import ndimage

        hole = ~np.isfinite(patch)
        if hole.all():
            raise InputError(f"{path}: {what}: all nodata")
        idx = ndimage.distance_transform_edt(hole, return_distances=False, return_indices=True)
        patch = patch[tuple(idx)]
    if len(rows) < len(axis) or len(cols) < len(axis):
        pad = ((int(rows[0]), len(axis) - 1 - int(rows[-1])),
               (int(cols[0]), len(axis) - 1 - int(cols[-1])))
        patch = np.pad(patch, pad, mode="reflect", reflect_type="odd")
    return patch - (np.median(patch) if ground_m is None else ground_m)


def mound_profile(spec: TerrainSpec, r: np.ndarray, reach_m: float | None = None
                  ) -> np.ndarray:
    """The tumulus's height at distances `r` (m) from its centre: its radial profile
    (`profile`, `height_m`, `diameter_m`, `drum_height_m`) blurred by erosion (a Gaussian of
    sigma `erosion_m` along the radius), without its pit or trench; tabulated out to
    `reach_m` (default the site's side), 0 beyond."""
    rs = np.linspace(0, spec.size_m if reach_m is None else reach_m, 4096)
    prof = _radial_profile(spec, rs)
    erosion = spec.erosion_m
    if erosion > 0:
        step = rs[1] - rs[0]
        k = np.arange(-int(4 * erosion / step), int(4 * erosion / step) + 1)
        w = np.exp(-0.5 * (k * step / erosion) ** 2)
        padded = np.concatenate([prof[len(k) // 2:0:-1], prof, np.zeros(len(k))])
        prof = np.convolve(padded, w / w.sum(), mode="same")[len(k) // 2:len(k) // 2 + len(rs)]
    return np.interp(r, rs, prof, right=0.0)


def mound_added(spec: TerrainSpec, xx: np.ndarray, yy: np.ndarray,
                reach_m: float | None = None) -> np.ndarray:
    """The relief the tumulus adds to the ground at (xx, yy) (m, the site's frame): its
    eroded profile about (mound_x_m, mound_y_m) (`mound_profile`), less its looters' pit
    and trench."""
    if spec.length_m > 0:  # elongated: the profile stretched along its axis
        u, v = _along_across(xx, yy, spec.mound_x_m, spec.mound_y_m, spec.mound_azimuth_deg)
        r = np.hypot(u * spec.diameter_m / spec.length_m, v)
    else:
        r = np.hypot(xx - spec.mound_x_m, yy - spec.mound_y_m)
    mound = mound_profile(spec, r, reach_m)
    if spec.pit_radius_m > 0 and spec.pit_depth_m > 0:
        rp = np.hypot(xx - spec.mound_x_m - spec.pit_offset_m, yy - spec.mound_y_m)
        mound = mound - spec.pit_depth_m * np.clip(1 - rp / spec.pit_radius_m, 0, None)
    if spec.trench_width_m > 0 and spec.trench_depth_m > 0:
        u, v = _along_across(xx, yy, spec.mound_x_m, spec.mound_y_m, spec.trench_azimuth_deg)
        cut = spec.trench_depth_m * np.clip(1 - 2 * np.abs(v) / spec.trench_width_m, 0, None)
        # across the mound, no deeper than the mound stands
        mound = np.where(np.abs(u) < spec.base_length_m / 2,
                         np.maximum(mound - cut, np.minimum(mound, 0)), mound)
    return mound


def _ridges(spec: TerrainSpec, xx: np.ndarray, yy: np.ndarray) -> np.ndarray:
    """Ridge-and-valley ground: crests `ridge_wavelength_m` apart across
    `ridge_azimuth_deg`, `ridge_relief_m` above the valley floors, meandering along the
    crest by a tenth of the wavelength (phase from the site's seed)."""
    u, v = _along_across(xx, yy, 0.0, 0.0, spec.ridge_azimuth_deg)
    lam = spec.ridge_wavelength_m
    phase = np.random.default_rng([spec.seed, 68]).uniform(0, 2 * np.pi, size=2)
    meander = lam / 10 * np.sin(2 * np.pi * v / (2.5 * lam) + phase[1])
    return spec.ridge_relief_m / 2 * np.cos(2 * np.pi * (u + meander) / lam + phase[0])


def _terraced(z: np.ndarray, step_m: float, riser: float) -> np.ndarray:
    """Hillside terraces: the height cut into flat treads `step_m` apart, each riser the
    last `riser` share of its step's run (a dry-stone wall's face, battered)."""
    f = z / step_m
    k = np.floor(f)
    return step_m * (k + np.clip((f - k - (1 - riser)) / riser, 0.0, 1.0))


def build(spec: TerrainSpec) -> Heightfield:
    spec.check()
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
    if spec.dem_path is not None:
        z = dem_patch(spec.dem_path, spec.dem_x_m, spec.dem_y_m, axis, spec.dem_ground_m,
                      spec.dem_vertical, extend=spec.dem_extend)
    if spec.ridge_relief_m > 0:
        z = z + _ridges(spec, xx, yy)
    if spec.slope_deg > 0:
        u, _ = _along_across(xx, yy, 0.0, 0.0, spec.slope_azimuth_deg)
        z = z + np.tan(np.deg2rad(spec.slope_deg)) * u
    if spec.terrace_step_m > 0:
        z = _terraced(z, spec.terrace_step_m, spec.terrace_riser)
    if spec.mound:
        mound = mound_added(spec, xx, yy)
        z = z + mound
    for c in spec.confusers:
        add, top = _confuser(c, xx, yy, z)
        z = z + add
        if top is not None:
            z = np.maximum(z, top)
    return Heightfield(axis, axis.copy(), z)


def load_site_heightfield(site_dir: str | Path) -> Heightfield:
    """The true surface a simulated site was rendered from (site.json's grid and
    heightfield.npy)."""
    site_dir = Path(site_dir)
    grid = read_json(site_dir / "site.json", "mound.sim_site", 1)["heightfield"]
    z = np.load(site_dir / grid["npy"])
    ny, nx = z.shape
    return Heightfield(x_m=grid["x0_m"] + grid["spacing_m"] * np.arange(nx),
                       y_m=grid["y0_m"] + grid["spacing_m"] * np.arange(ny), z_m=z)
