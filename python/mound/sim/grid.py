"""A grid of simulated sites that look like the field, each flown, reconstructed and measured:
the data the 3-D verdict is learned from (`mound recon train-verdict`) and judged on.

`make_grid(out, sites, seed, ...)` draws `sites` sites from the field's distributions
(seeded: another seed is another grid), and for each one, in GRID/NNNN/:
    sim/       mound sim site's output (images, poses, truth.json, ...)
    recon/     mound_recon reconstruct (sparse cloud, georeferenced by the noisy GPS)
    verdict.json  mound_recon verdict (the detector's measurements and its p_mound)
and GRID/grid.json (`mound.verdict_grid` v1): the draws, the truth and the status of every
site, the flight and the time it took, and the sha256 of the mound_recon that ran (`tools`:
the grid runs a copy of build/mound_recon taken when it starts, native.pinned, so a rebuild
meanwhile changes nothing in it). Resumable: a site whose verdict exists is not redone;
`remeasure=True` reruns only the verdicts (after a change of the detector). A grid resumed
with another build and without `remeasure` keeps its earlier verdicts: grid.json then names
the earlier build too (`earlier_tools`), and `mound sim grid` says so.

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
- ground (either class): undulating (45 %), on a slope of 2-15 degrees (30 %) or a patch of
  a real DEM (25 %; skipped when no DEM is given): one of the DEMs given (`--dem`, repeated)
  drawn among those on which the site's square fits wholly on valid cells, the centre
  uniform over where it fits within the DEM's `dem_part` (dem_places.py: train, the first
  60 % across its longer axis; heldout, the rest; training and held-out grids then share
  no terrain, save that a second look's wider site may reach across);
- flight: the survey's (a raster scan of `scan_m`, 60 m, at 60 m; `pattern="both"`: the
  full 40-image flight, the raster and an orbit of oblique images), sun azimuth 0-360
  degrees at 25-70 degrees elevation, lens of 60-84 degrees horizontal field of view;
- cloud: the sparse cloud of `mound_recon reconstruct`, or with `dense=True` the dense
  cloud of `mound_recon densify` (dense/dense.ply), which the verdict then judges;
- camera: the simulator's calibration (camera.json, poses.json), or with `card=True` the
  photo card's (JPEGs with EXIF GPS and focal length; `reconstruct --gps exif` levels the
  model by the images and refines f, k1, k2 about EXIF's values, as the survey's
  `--photos` does).

`second_look_kind="lower"` flies the other second look instead, in GRID/NNNN/second_lower/:
the same scan area with the raster half as high (`lower`; issue 56 asks which helps more).
`second_look=True` flies a second look (issue 26) at every site whose first verdict leaves it
undecided, p_mound in SECOND_LOOK_P (wider than any model's band, so that a retrained
model finds its band's sites flown): the same site flown again with a scan SECOND_LOOK_FACTOR
x as wide (`wider`), reconstructed and judged in GRID/NNNN/second/ as above. On a DEM patch
near the laser DEM's edge the wider site's part off the DEM is the DEM continued across its
edge (`terrain.dem_patch`, `extend`); until 2026-11-26 such a site was not flown again
(second/ held no verdict, and the evaluation kept its first verdict).

`flights_from=GRID` takes each site's flight and reconstruction from another grid of the
same seed, flight and camera (links to its NNNN/sim and NNNN/recon; nothing is flown or
reconstructed anew): the dense clouds of a sparse grid's sites, in minutes.
"""

from __future__ import annotations

import json
import logging
import math
import time
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any

import numpy as np

from mound import native
from mound.errors import InputError, NoResultError, ToolNoResultError
from mound.jsonio import write_json
from mound.sim import site as sim
from mound.sim import terrain
from mound.sim.appearance import Lighting
from mound.sim.dem_places import DemPlaces
from mound.sim.population import Population, read_population

SCHEMA = "mound.verdict_grid"
VERSION = 1
SCAN_M = 60.0
# the survey's densify (mound.survey: options.dense_size, site_work.DENSE_RESOLUTION_M):
# depth maps 320 px on their longer side, points merged on 0.25 m voxels
DENSIFY_ARGS = ("--max-image-size", "320", "--resolution-m", "0.25")
DEFAULT_DEM = "TM1_564_146.tif"  # the 1 m airborne-laser DEM (../shared/data/dem)
# The second look: sites whose first p_mound lies in SECOND_LOOK_P are flown again with a
# scan SECOND_LOOK_FACTOR x as wide (the model's own band, second_look.p_low .. threshold, lies
# within it); the site drawn SITE_PER_SCAN x the scan across (as the first look's 160 m for
# its 60 m).
SECOND_LOOK_FACTOR = 2.0
SECOND_LOOK_P = (0.05, 0.995)
SITE_PER_SCAN = 2.7
# The other second look: the same scan area, the raster this many times as high (lower)
LOWER_FACTOR = 0.5
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


def _measured_tumulus(rng: np.random.Generator, pop: Population,
                      scan_m: float) -> dict[str, Any]:
    """A tumulus of the population's measured rows (see the module text)."""
    row = pop.rows[int(rng.integers(len(pop.rows)))]
    profile = str(rng.choice(POPULATION_PROFILES))
    w, length, h = row.width_m, row.length_m, row.height_m
    if h > max_height(profile, w):  # steeper than a cap stands: a cone's flanks
        profile = "conical"
    h = min(h, max_height(profile, w))
    x, y = _in_disc(rng, scan_m / 4)
    az = float(rng.uniform(0, 180))
    over: dict[str, Any] = {
        "profile": profile, "diameter_m": w, "height_m": h, "mound_x_m": x, "mound_y_m": y,
        "erosion_m": float(rng.uniform(0.05, 0.2)) * w,
        **({"length_m": length, "mound_azimuth_deg": az} if length > w * (1 + 1e-9) else {})}
    trench = row.trench if row.trench is not None else bool(rng.random() < pop.trench_share)
    if trench:  # as the field records it: a trench across the top, or a pit in it
        if rng.random() < 0.5 and w > 4:
            pr = float(rng.uniform(0.1, 0.25)) * w
            over.update(pit_radius_m=pr, pit_depth_m=float(rng.uniform(0.2, 0.6)) * h,
                        pit_offset_m=float(rng.uniform(0, w / 2 - pr)))
        else:
            over.update(trench_width_m=float(rng.uniform(0.15, 0.35)) * w,
                        trench_depth_m=float(rng.uniform(0.2, 0.6)) * h,
                        trench_azimuth_deg=float(rng.uniform(0, 180)))
    return over


def _place_on_dem(rng: np.random.Generator, dems: list[DemPlaces],
                  size_m: float) -> dict[str, Any] | None:
    """A terrain patch of one of `dems` (drawn among those where a site `size_m` across
    fits), or None where it fits on none."""
    fits = [d for d in dems if d.fits(size_m)]
    if not fits:
        return None
    d = fits[int(rng.integers(len(fits)))]
    x, y = d.draw(rng, size_m)
    return {"dem_path": d.path, "dem_x_m": x, "dem_y_m": y}


def draw(rng: np.random.Generator, seed: int, dems: list[DemPlaces] | None,
         size: tuple[int, int], scan_m: float = SCAN_M, texel_m: float = 0.1,
         pattern: str = "raster", population: Population | None = None) -> sim.SimSpec:
    """One site of the grid (see the module text); `dems` opened once for the grid (each
    open reads the whole DEM)."""
    over: dict[str, Any] = {"seed": seed, "resolution_m": 0.5}
    mound = bool(rng.random() < 0.5)
    over["mound"] = mound
    extent = 0.0
    if mound and population is not None:
        over.update(_measured_tumulus(rng, population, scan_m))
        extent = (over.get("length_m", over["diameter_m"])
                  + 2 * max(abs(over["mound_x_m"]), abs(over["mound_y_m"])))
    elif mound:
        profile = str(rng.choice(terrain.PROFILES))
        d = _log_uniform(rng, 10, 150)
        drum_share = float(rng.uniform(0.2, 0.5)) if profile == "drum" else 0.0
        h = min(_log_uniform(rng, 0.5, 25), max_height(profile, d, drum_share))
        x, y = _in_disc(rng, scan_m / 4)
        over.update(profile=profile, diameter_m=d, height_m=h,
                    mound_x_m=x, mound_y_m=y, erosion_m=float(rng.uniform(0.5, 5)))
        if profile == "ploughed":  # spread by the plough: at least a tenth of D
            over["erosion_m"] = max(over["erosion_m"], d / 10)
        if profile == "drum":
            over["drum_height_m"] = drum_share * h
        k = rng.random()
        if k < 0.2 and d > 12:
            pr = float(rng.uniform(0.1, 0.25)) * d
            over.update(pit_radius_m=pr, pit_depth_m=float(rng.uniform(0.2, 0.6)) * h,
                        pit_offset_m=float(rng.uniform(0, d / 2 - pr)))
        elif k < 0.35:
            over.update(trench_width_m=float(rng.uniform(2, 6)),
                        trench_depth_m=float(rng.uniform(0.2, 0.6)) * h,
                        trench_azimuth_deg=float(rng.uniform(0, 180)))
        extent = d + 2 * max(abs(x), abs(y))
    elif rng.random() < 0.75:
        kind = str(rng.choice(terrain.CONFUSERS))
        over["confusers"] = (_confuser(rng, kind, seed),)
    g = rng.random()
    size_m = max(160.0, extent + 40.0)
    size_m = math.ceil(size_m / 4) * 4
    over["size_m"] = size_m
    if g < 0.30:
        over.update(slope_deg=float(rng.uniform(2, 15)),
                    slope_azimuth_deg=float(rng.uniform(0, 360)))
    elif g < 0.55 and dems:
        place = _place_on_dem(rng, dems, size_m)
        if place is None:  # wider than any DEM holds: undulating ground (truth: dem false)
            LOG.warning("site %d: %g m across fits on no DEM's part; its ground undulates",
                        seed, size_m)
        else:
            over.update(place)
    spec = terrain.preset("bin_tepe", **over)
    return sim.SimSpec(
        terrain=spec,
        lighting=Lighting(math.radians(float(rng.uniform(0, 360))),
                          math.radians(float(rng.uniform(25, 70)))),
        width_px=size[0], height_px=size[1],
        hfov_rad=math.radians(float(rng.uniform(60, 84))), pattern=pattern,
        scan_diameter_m=scan_m, seed=seed, texel_m=texel_m)


def lower(spec: sim.SimSpec, factor: float = LOWER_FACTOR) -> sim.SimSpec:
    """The same site (terrain, light, lens, seed) and scan area flown with its raster
    `factor` x as high (LOWER_FACTOR: half): the ground sampled 1 / factor x as finely,
    with more images for the same overlaps (78 against 28 for the 60 m scan at half)."""
    return replace(spec, raster_altitude_m=spec.scale_m * factor)


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
    scan = spec.scale_m * factor
    size = max(spec.terrain.size_m, math.ceil(scan * SITE_PER_SCAN / 4) * 4)
    return replace(spec, scan_diameter_m=scan, terrain=replace(
        spec.terrain, size_m=size, dem_extend=spec.terrain.dem_path is not None))


def _p_of(verdict: dict[str, Any]) -> float | None:
    """A site's verdict's p_mound (None: not judged)."""
    p = verdict.get("p_mound")
    return float(p) if isinstance(p, int | float) else None


def _site(out: Path, spec: sim.SimSpec, threads: int, remeasure: bool,
          dense: bool = False, card: bool = False) -> dict[str, Any]:
    simdir, recon, verdict = out / "sim", out / "recon", out / "verdict.json"
    row: dict[str, Any] = {"dir": out.name, "truth": spec.terrain.truth()}
    times: dict[str, float] = {}
    if verdict.exists() and not remeasure:
        doc = json.loads(verdict.read_text())
        row.update(status=doc.get("status"), times=doc.get("grid_times_s", {}),
                   p_mound=_p_of(doc))
        return row
    if verdict.exists():  # remeasuring: keep the times of the flight and reconstruction
        try:
            times.update({k: v for k, v in json.loads(verdict.read_text()).get(
                "grid_times_s", {}).items() if k != "verdict"})
        except (OSError, json.JSONDecodeError):
            pass
    try:
        if not (recon / "recon.json").exists():
            t = time.perf_counter()
            sim.simulate(spec, simdir, threads=threads)
            # as from the aircraft's card: JPEGs whose EXIF carries the GPS and the focal
            # length, the lens (f, k1, k2) refined about EXIF's values (--lens prior)
            camera = ["--gps", "exif"]
            if card:
                from datetime import datetime

                from mound.sim.card import site_jpegs

                site_jpegs(simdir, datetime(2026, 6, 1, 9, 0, 0))
            else:
                camera = ["--camera", str(simdir / "camera.json"), "--gps",
                          str(simdir / "poses.json")]
            times["simulate"] = time.perf_counter() - t
            t = time.perf_counter()
            try:
                native.run_tool("mound_recon", [
                    "reconstruct", str(simdir / "images"), "--out", str(recon), *camera,
                    "--threads", str(threads)], 1800, log=out / "log.txt")
            except ToolNoResultError:
                pass  # recon.json says why; the verdict then says status failed
            times["reconstruct"] = time.perf_counter() - t
        verdict_args: list[str] = []
        if dense:
            cloud = out / "dense" / "dense.ply"
            if not cloud.exists() and (recon / "points.ply").exists():
                t = time.perf_counter()
                try:
                    native.run_tool("mound_recon", [
                        "densify", str(recon), "--out", str(out / "dense"), "--threads",
                        str(threads), *DENSIFY_ARGS], 1800, log=out / "log.txt")
                except ToolNoResultError:
                    pass  # no dense cloud: the verdict then says status failed
                times["densify"] = time.perf_counter() - t
            verdict_args = ["--cloud", str(cloud)]
        t = time.perf_counter()
        try:
            native.run_tool("mound_recon", ["verdict", str(recon), "--out", str(verdict),
                                            *verdict_args], 600, log=out / "log.txt")
        except ToolNoResultError:
            pass  # verdict.json says status failed and why
        times["verdict"] = time.perf_counter() - t
        doc = json.loads(verdict.read_text())
        doc["grid_times_s"] = times
        write_json(verdict, doc)
        row.update(status=doc.get("status"), times=times, p_mound=_p_of(doc),
                   **({"reason": str(doc.get("reason", ""))} if doc.get("status") != "ok"
                      else {}))
    except (InputError, NoResultError) as e:
        row.update(status="failed", reason=str(e))
    return row


def make_grid(out: str | Path, sites: int, seed: int, size: tuple[int, int] = (640, 480),
              dem: str | list[str] | None = None, threads: int = 1, workers: int = 1,
              remeasure: bool = False, progress: Any = None, pattern: str = "raster",
              dense: bool = False, card: bool = False,
              flights_from: str | Path | None = None,
              second_look: bool = False, dem_part: str = "all",
              second_look_kind: str = "wider",
              population: str | None = None) -> dict[str, Any]:
    """Draws and runs the grid (see the module text); returns grid.json's document."""
    if not 1 <= sites <= 100_000:
        raise InputError("--sites: must be 1 .. 100,000")
    if second_look_kind not in SECOND_LOOKS:
        raise InputError(f"--second-look-kind: one of {', '.join(SECOND_LOOKS)}")
    paths = [] if dem is None else [dem] if isinstance(dem, str) else list(dem)
    for p in paths:
        if not Path(p).is_file():
            raise InputError(f"--dem: no file {p}")
    dems = [DemPlaces.open(p, dem_part) for p in paths]
    for d in dems:
        if not d.fits(160.0):  # the smallest site
            raise InputError(f"--dem: {d.path}: no 160 m square of valid cells within its "
                             f"{dem_part} part")
    pop = read_population(population) if population is not None else None
    # grid.json's "dem": the one DEM's path as before, a list for several
    dem_doc: str | list[str] | None = (None if not paths else paths[0] if len(paths) == 1
                                       else paths)
    draws = {"dem": dem_doc, "dem_part": dem_part,
             "population": pop.summary() if pop else "uniform"}
    root = Path(out)
    if flights_from is not None:
        _check_flights_from(Path(flights_from), root, sites, seed, size, pattern, card, draws)
    root.mkdir(parents=True, exist_ok=True)
    if flights_from is not None:
        for k in range(sites):
            site, src = root / f"{k:04d}", Path(flights_from).resolve() / f"{k:04d}"
            site.mkdir(exist_ok=True)
            for part in ("sim", "recon"):
                if not (site / part).exists():
                    (site / part).symlink_to(src / part, target_is_directory=True)
    rng = np.random.default_rng([seed, 2026])
    specs = [draw(rng, 100_000 * seed + k, dems, size, pattern=pattern, population=pop)
             for k in range(sites)]
    start = time.perf_counter()
    rows: list[dict[str, Any]] = [{}] * sites

    def one(k: int) -> None:
        rows[k] = _site(root / f"{k:04d}", specs[k], threads, remeasure, dense, card)
        p = rows[k].get("p_mound")  # the first look's (grid.json's rows carry it)
        if second_look and p is not None and SECOND_LOOK_P[0] <= p < SECOND_LOOK_P[1]:
            folder = SECOND_LOOKS[second_look_kind]
            second = _site(root / f"{k:04d}" / folder,
                           second_look_spec(specs[k], second_look_kind), threads, remeasure,
                           dense, card)
            rows[k][folder] = {"status": second.get("status"), "times": second.get("times"),
                                 **({"reason": second["reason"]} if "reason" in second else {})}
        if progress:
            progress(k, rows[k])

    # One build judges the whole grid: the sites run a copy of mound_recon taken now, so
    # that a rebuild while the grid runs (make relinks build/mound_recon in place) fails no
    # site half-way and mixes no two detectors (until 2026-11-27 a rebuild failed the sites
    # running then with PermissionError).
    earlier = None  # the build of the verdicts already there (the oldest one named)
    before_kinds: list[str] = []  # the second looks flown before (grid.json)
    try:
        before = json.loads((root / "grid.json").read_text())
        earlier = before.get("earlier_tools") or before.get("tools")
        sl = before.get("second_look") or {}
        before_kinds = list(sl.get("kinds", ["wider"] if sl else []))
    except (OSError, json.JSONDecodeError, AttributeError):
        pass
    with native.pinned("mound_recon") as digests:
        if workers > 1:
            from concurrent.futures import ThreadPoolExecutor

            with ThreadPoolExecutor(max_workers=workers) as pool:
                list(pool.map(one, range(sites)))
        else:
            for k in range(sites):
                one(k)
    tools = {name: {"sha256": d} for name, d in digests.items()}
    measured = sum(1 for r in rows if r.get("status") == "ok")
    # a grid none of whose sites was measured is no result (the CLI's exit 3), whatever why
    status = "ok" if measured == sites else "partial" if measured else "failed"
    doc = {"schema": SCHEMA, "version": VERSION, "seed": seed, "sites": sites,
           "status": status, "measured": measured, "tools": tools,
           **({"earlier_tools": earlier} if earlier and earlier != tools and not remeasure
              else {}),
           "flight": {"pattern": pattern, "scan_m": SCAN_M, "image_size": list(size)},
           **({"second_look": {"scan_factor": SECOND_LOOK_FACTOR,
                               "lower_factor": LOWER_FACTOR,
                               "kinds": sorted({second_look_kind, *before_kinds}),
                               "first_p": list(SECOND_LOOK_P)}}
              if second_look or before_kinds else {}),
           "cloud": "dense" if dense else "sparse",
           "camera": "exif" if card else "calibrated",
           **draws, **({"flights_from": str(flights_from)} if flights_from else {}),
           "wall_s": time.perf_counter() - start,
           "rows": [{**r, "spec": _spec_doc(s)} for r, s in zip(rows, specs, strict=True)]}
    write_json(root / "grid.json", doc)
    return doc


def _check_flights_from(src: Path, out: Path, sites: int, seed: int, size: tuple[int, int],
                        pattern: str, card: bool, draws: dict[str, Any]) -> None:
    """InputError (naming --flights-from and the field) unless src is a finished grid of the
    same draws (seed, DEM), flight and camera with at least `sites` sites, and not the grid
    itself."""
    try:
        doc = json.loads((src / "grid.json").read_text())
    except (OSError, json.JSONDecodeError):
        raise InputError(f"--flights-from: {src}/grid.json: no finished grid there") from None
    if src.resolve() == out.resolve():
        raise InputError("--flights-from: the grid itself")
    flight = doc.get("flight") or {}
    want = {"seed": seed, "flight.pattern": pattern, "flight.image_size": list(size),
            "camera": "exif" if card else "calibrated", **draws}
    # grids drawn before 2026-11-28 have neither dem_part nor population: all, uniform
    have = {"seed": doc.get("seed"), "flight.pattern": flight.get("pattern"),
            "flight.image_size": flight.get("image_size"), "camera": doc.get("camera"),
            "dem": doc.get("dem"), "dem_part": doc.get("dem_part", "all"),
            "population": doc.get("population", "uniform")}
    for key, value in want.items():
        if have[key] != value:
            raise InputError(f"--flights-from: {src}/grid.json: {key} is {have[key]!r}, this "
                             f"grid's is {value!r}")
    if not isinstance(doc.get("sites"), int) or doc["sites"] < sites:
        raise InputError(f"--flights-from: {src}/grid.json: sites is {doc.get('sites')!r}, "
                         f"fewer than {sites}")


def _spec_doc(spec: sim.SimSpec) -> dict[str, Any]:
    d = asdict(spec)
    return {"terrain": d["terrain"], "sun_deg": [math.degrees(spec.lighting.sun_azimuth_rad),
                                                  math.degrees(spec.lighting.sun_elevation_rad)],
            "hfov_deg": math.degrees(spec.hfov_rad), "seed": spec.seed}
