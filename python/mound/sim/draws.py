"""The field's sites as a grid draws them (mound.grids.run flies, reconstructs and judges
them; `mound sim grid`).

The draws (half of the sites carry a tumulus):
- tumulus: profile conical / spherical cap / drum / ploughed; height log-uniform in
  0.5-25 m, diameter log-uniform in 10-150 m, the height at most what the profile allows
  with flanks no steeper than earth stands (`max_height`: 35 degrees, the angle of repose
  of loose earth; a drum's retaining wall is vertical, its cap obeys the rule); centre off
  the scan centre by up to half the scan's radius; erosion 0.5-5 m; a looters' pit (20 %)
  or trench (15 %);
- or, with `population` (`--population kazanlak|FILE`, population.py), a row of a measured
  inventory drawn at random: its base length and width (an elongated base, length along a
  random azimuth), its height (at most what a cone of its width stands at the angle of
  repose; the profile a cap, cone or ploughed cap, a cone where a cap would be too steep),
  and its looters' trench as the field records it (half of them a trench across the top,
  a fifth to a third of the width wide, half a pit; an unrecorded one drawn at the
  inventory's share); erosion 5-20 % of the width (the measured base is the eroded one);
- no mound: bare ground (25 %) or one confuser (75 %): an elongated hillock, a ridge, a
  ditch, a terrace edge, a group of trees, a building or a haystack, within 15 m of the
  centre;
- ground (either class), `ground="mixed"` (the training grids'): undulating (45 %), on a
  slope of 2-15 degrees (30 %) or a patch of a real DEM (25 %; skipped when no DEM is
  given); `ground="steep"` (a terrain family no training grid has held, for held-out
  grids): every site on a slope of 15-35 degrees, over a DEM's patch (half, when DEMs are
  given) or undulating ground; `ground="ridged"` (another family no training grid holds):
  ridge-and-valley ground, crests 60-160 m apart and 3 m to a fifth of that high (flanks
  up to 32 degrees), on a regional slope of 0-10 degrees, terraced (steps of 1-3 m) on half
  the sites, no DEM. A DEM patch is one of the DEMs given (`--dem`, repeated)
  drawn among those on which the site's square fits wholly on valid cells, the centre
  uniform over where it fits within the DEM's `dem_part` (dem_places.py: train, the first
  60 % across its longer axis; heldout, the rest; training and held-out grids then share
  no terrain, save that a second look's wider site may reach across);
- flight: the survey's (a raster scan of `site_diameter_m`, 60 m, at 60 m; `pattern="both"`:
  the full 40-image flight, the raster and an orbit of oblique images), sun azimuth 0-360
  degrees at 25-70 degrees elevation, lens of 60-84 degrees horizontal field of view;
- cloud: the sparse cloud of `mound_recon reconstruct`, or with `dense=True` the dense
  cloud of `mound_recon densify` (dense/dense.ply), which the verdict then judges;
- camera: the simulator's calibration (camera.json, poses.json), or with `card=True` the
  photo card's (JPEGs with EXIF GPS and focal length; `reconstruct --gps exif` levels the
  model by the images and refines f, k1, k2 about EXIF's values, as the survey's
  `--photos` does).
"""

from __future__ import annotations

import logging
import math
from dataclasses import replace

import numpy as np

from mound.errors import InputError
from mound.geometry.flight import DEFAULT_SITE_DIAMETER_M
from mound.sim import site as sim
from mound.sim import terrain
from mound.sim.appearance import Lighting
from mound.sim.dem_places import DemPlaces
from mound.sim.population import Population

# a measured population's tumuli (population.py): earthen profiles, no Lydian drum
POPULATION_PROFILES = ("spherical_cap", "conical", "ploughed")
LOG = logging.getLogger(__name__)
REPOSE_DEG = 35.0  # the steepest flank loose earth stands at (angle of repose, 30-35 deg)


def max_height(profile: str, diameter_m: float, drum_share: float = 0.0) -> float:
    """The highest tumulus of `profile` and `diameter_m` whose flanks are nowhere steeper
    than REPOSE_DEG (before erosion, which only flattens them): a cone h <= r tan(a); a
    spherical cap meets its base at 2 atan(h / r), so h <= r tan(a / 2); a ploughed cap
    (cut at terrain.PLOUGH_CUT, 60 %, and scaled back, its flank 1 / 0.6 as steep)
    h <= r tan(atan(0.6 tan a) / 2);
    a drum's cap of the height above its wall (`drum_share` of h) as a spherical cap's.
    An earthen mound steeper than that slumps: the previous grid's limit of h <= 0.45 d
    drew near-hemispheres with 84-degree flanks, no tumulus's form."""
    a = math.radians(REPOSE_DEG)
    r = diameter_m / 2
    if profile == "conical":
        return r * math.tan(a)
    if profile == "ploughed":
        return r * math.tan(math.atan(terrain.PLOUGH_CUT * math.tan(a)) / 2)
    cap = r * math.tan(a / 2)
    if profile == "drum":
        return cap / (1 - drum_share)
    return cap


def _log_uniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def _in_disc(rng: np.random.Generator, radius: float) -> tuple[float, float]:
    r, a = radius * math.sqrt(rng.random()), 2 * math.pi * rng.random()
    return r * math.sin(a), r * math.cos(a)


def _confuser(rng: np.random.Generator, kind: str, seed: int) -> terrain.Confuser:
    x, y = _in_disc(rng, 15.0)
    az = float(rng.uniform(0, 180))
    u = rng.uniform
    if kind == "hillock":
        length = float(u(30, 120))
        return terrain.Confuser(kind, x, y, length, length / float(u(2.5, 5)), float(u(1, 8)),
                                az, seed=seed)
    if kind == "ridge":
        return terrain.Confuser(kind, x, y, 200.0, float(u(15, 40)), float(u(2, 10)), az,
                                seed=seed)
    if kind == "ditch":
        return terrain.Confuser(kind, x, y, 200.0, float(u(3, 8)), float(u(1, 3)), az,
                                seed=seed)
    if kind == "terrace":
        return terrain.Confuser(kind, x, y, 200.0, float(u(2, 8)), float(u(1, 4)), az,
                                seed=seed)
    if kind == "trees":
        return terrain.Confuser(kind, x, y, float(u(15, 40)), float(u(4, 9)), float(u(6, 18)),
                                az, count=int(rng.integers(3, 13)), seed=seed)
    if kind == "building":
        return terrain.Confuser(kind, x, y, float(u(8, 25)), float(u(6, 12)), float(u(3, 10)),
                                az, seed=seed)
    return terrain.Confuser("haystack", x, y, 6.0, float(u(4, 8)), float(u(2.5, 5)), az,
                            seed=seed)


def _measured_tumulus(rng: np.random.Generator, spec: terrain.TerrainSpec, pop: Population,
                      site_diameter_m: float) -> terrain.TerrainSpec:
    """`spec` with a tumulus of the population's measured rows (see the module text)."""
    row = pop.rows[int(rng.integers(len(pop.rows)))]
    profile = str(rng.choice(POPULATION_PROFILES))
    w, length, h = row.width_m, row.length_m, row.height_m
    if h > max_height(profile, w):  # steeper than a cap stands: a cone's flanks
        profile = "conical"
    h = min(h, max_height(profile, w))
    x, y = _in_disc(rng, site_diameter_m / 4)
    az = float(rng.uniform(0, 180))
    spec = replace(spec, profile=profile, diameter_m=w, height_m=h, mound_x_m=x, mound_y_m=y,
                   erosion_m=float(rng.uniform(0.05, 0.2)) * w)
    if length > w * (1 + 1e-9):
        spec = replace(spec, length_m=length, mound_azimuth_deg=az)
    trench = row.trench if row.trench is not None else bool(rng.random() < pop.trench_share)
    if trench:  # as the field records it: a trench across the top, or a pit in it
        if rng.random() < 0.5 and w > 4:
            pr = float(rng.uniform(0.1, 0.25)) * w
            spec = replace(spec, pit_radius_m=pr, pit_depth_m=float(rng.uniform(0.2, 0.6)) * h,
                           pit_offset_m=float(rng.uniform(0, w / 2 - pr)))
        else:
            spec = replace(spec, trench_width_m=float(rng.uniform(0.15, 0.35)) * w,
                           trench_depth_m=float(rng.uniform(0.2, 0.6)) * h,
                           trench_azimuth_deg=float(rng.uniform(0, 180)))
    return spec


def _place_on_dem(rng: np.random.Generator, spec: terrain.TerrainSpec,
                  dems: list[DemPlaces]) -> terrain.TerrainSpec | None:
    """`spec` on a terrain patch of one of `dems` (drawn among those where the site fits),
    or None where it fits on none."""
    fits = [d for d in dems if d.fits(spec.size_m)]
    if not fits:
        return None
    d = fits[int(rng.integers(len(fits)))]
    x, y = d.draw(rng, spec.size_m)
    return replace(spec, dem_path=d.path, dem_x_m=x, dem_y_m=y)


GROUNDS = ("mixed", "steep", "ridged")
STEEP_DEG = (15.0, 35.0)  # ground="steep": the slopes no training grid held


def _ridged(rng: np.random.Generator, spec: terrain.TerrainSpec) -> terrain.TerrainSpec:
    """`spec` on ground="ridged": ridge and valley (a fifth of the wavelength at most: flanks
    of at most atan(pi / 5), 32 degrees), a regional slope, terraces on half the sites."""
    lam = float(rng.uniform(60, 160))
    spec = replace(spec, ridge_wavelength_m=lam, ridge_relief_m=float(rng.uniform(3, lam / 5)),
                   ridge_azimuth_deg=float(rng.uniform(0, 180)),
                   slope_deg=float(rng.uniform(0, 10)),
                   slope_azimuth_deg=float(rng.uniform(0, 360)))
    if rng.random() < 0.5:
        spec = replace(spec, terrace_step_m=float(rng.uniform(1, 3)),
                       terrace_riser=float(rng.uniform(0.2, 0.4)))
    return spec


def draw(rng: np.random.Generator, seed: int, dems: list[DemPlaces] | None,
         size: tuple[int, int], site_diameter_m: float = DEFAULT_SITE_DIAMETER_M,
         texel_m: float = 0.1,
         pattern: str = "raster", population: Population | None = None,
         ground: str = "mixed") -> sim.SimSpec:
    """One site of the grid (see the module text); `dems` opened once for the grid (each
    open reads the whole DEM)."""
    mound = bool(rng.random() < 0.5)
    spec = replace(terrain.PRESETS["bin_tepe"], seed=seed, resolution_m=0.5, mound=mound)
    extent = 0.0
    if mound and population is not None:
        spec = _measured_tumulus(rng, spec, population, site_diameter_m)
        extent = (max(spec.length_m, spec.diameter_m)
                  + 2 * max(abs(spec.mound_x_m), abs(spec.mound_y_m)))
    elif mound:
        profile = str(rng.choice(terrain.PROFILES))
        d = _log_uniform(rng, 10, 150)
        drum_share = float(rng.uniform(0.2, 0.5)) if profile == "drum" else 0.0
        h = min(_log_uniform(rng, 0.5, 25), max_height(profile, d, drum_share))
        x, y = _in_disc(rng, site_diameter_m / 4)
        erosion = float(rng.uniform(0.5, 5))
        if profile == "ploughed":  # spread by the plough: at least a tenth of D
            erosion = max(erosion, d / 10)
        spec = replace(spec, profile=profile, diameter_m=d, height_m=h,
                       mound_x_m=x, mound_y_m=y, erosion_m=erosion)
        if profile == "drum":
            spec = replace(spec, drum_height_m=drum_share * h)
        k = rng.random()
        if k < 0.2 and d > 12:
            pr = float(rng.uniform(0.1, 0.25)) * d
            spec = replace(spec, pit_radius_m=pr, pit_depth_m=float(rng.uniform(0.2, 0.6)) * h,
                           pit_offset_m=float(rng.uniform(0, d / 2 - pr)))
        elif k < 0.35:
            spec = replace(spec, trench_width_m=float(rng.uniform(2, 6)),
                           trench_depth_m=float(rng.uniform(0.2, 0.6)) * h,
                           trench_azimuth_deg=float(rng.uniform(0, 180)))
        extent = d + 2 * max(abs(x), abs(y))
    elif rng.random() < 0.75:
        kind = str(rng.choice(terrain.CONFUSERS))
        spec = replace(spec, confusers=(_confuser(rng, kind, seed),))
    g = rng.random()
    size_m = max(160.0, extent + 40.0)
    spec = replace(spec, size_m=math.ceil(size_m / 4) * 4)
    if ground not in GROUNDS:
        raise InputError(f"--ground: one of {', '.join(GROUNDS)}, got {ground!r}")
    steep = ground == "steep"
    if ground == "ridged":
        spec = _ridged(rng, spec)
    elif steep or g < 0.30:
        spec = replace(spec, slope_deg=float(rng.uniform(*(STEEP_DEG if steep else (2, 15)))),
                       slope_azimuth_deg=float(rng.uniform(0, 360)))
    # steep: half over a DEM's patch; mixed: a quarter, the sites not on a slope
    if ground != "ridged" and (g < 0.5 if steep else 0.30 <= g < 0.55) and dems:
        placed = _place_on_dem(rng, spec, dems)
        if placed is None:  # wider than any DEM holds: undulating ground (truth: dem false)
            LOG.warning("site %d: %g m across fits on no DEM's part; its ground undulates",
                        seed, spec.size_m)
        else:
            spec = placed
    spec.check()
    return sim.SimSpec(
        terrain=spec,
        lighting=Lighting(math.radians(float(rng.uniform(0, 360))),
                          math.radians(float(rng.uniform(25, 70)))),
        width_px=size[0], height_px=size[1],
        hfov_rad=math.radians(float(rng.uniform(60, 84))), pattern=pattern,
        scan_diameter_m=site_diameter_m, seed=seed, texel_m=texel_m)
