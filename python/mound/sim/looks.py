"""A site's second looks, as the simulator flies them: the same site (terrain, light, lens,
seed) flown again `wider` (a scan SECOND_LOOK_FACTOR x as wide, on a site drawn
SITE_PER_SCAN x that scan across) or `lower` (the same scan area, the raster LOWER_FACTOR x
as high). The grids (mound.grids.run) fly them at the sites a first verdict leaves
undecided; the survey's simulated second look and the photo card's wider flights are the
same `wider`."""

from __future__ import annotations

import math
from dataclasses import replace

from mound.sim import site as sim

# The second look: sites whose first p_mound lies in SECOND_LOOK_P are flown again with a
# scan SECOND_LOOK_FACTOR x as wide (the model's own band, second_look.p_low .. threshold, lies
# within it); the site drawn SITE_PER_SCAN x the scan across (as the first look's 160 m for
# its 60 m).
SECOND_LOOK_FACTOR = 2.0
SECOND_LOOK_P = (0.05, 0.995)
SITE_PER_SCAN = 2.7
# The other second look: the same scan area, the raster this many times as high (lower)
LOWER_FACTOR = 0.5


def lower(spec: sim.SimSpec, factor: float = LOWER_FACTOR) -> sim.SimSpec:
    """The same site (terrain, light, lens, seed) and scan area flown with its raster
    `factor` x as high (LOWER_FACTOR: half): the ground sampled 1 / factor x as finely,
    with more images for the same overlaps (78 against 28 for the 60 m scan at half)."""
    return replace(spec, raster_altitude_m=spec.site_diameter_m * factor)


# The second looks a grid flies, and the folder of each (NNNN/<folder>/)
SECOND_LOOKS = {"wider": "second", "lower": "second_lower"}


def second_look_spec(spec: sim.SimSpec, kind: str) -> sim.SimSpec:
    """The second look of `kind` (SECOND_LOOKS) at the site `spec`."""
    return wider(spec) if kind == "wider" else lower(spec)


def wider(spec: sim.SimSpec, factor: float = SECOND_LOOK_FACTOR) -> sim.SimSpec:
    """The same site (terrain, light, lens, seed) flown with a scan `factor` x as wide, on a
    site drawn SITE_PER_SCAN x that scan across (at least the first look's). On a DEM patch
    the part of the wider site that lies off the laser DEM is its continuation across the
    edge (terrain.dem_patch's point reflection): the field's second look would fly there."""
    scan = spec.site_diameter_m * factor
    size = max(spec.terrain.size_m, math.ceil(scan * SITE_PER_SCAN / 4) * 4)
    return replace(spec, scan_diameter_m=scan, terrain=replace(
        spec.terrain, size_m=size, dem_extend=spec.terrain.dem_path is not None))
