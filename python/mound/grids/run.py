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

The draws are mound.sim.draws's (`draw`); the second looks mound.sim.looks's.

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

import math
import time
from collections.abc import Callable
from dataclasses import asdict, replace
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np

from mound import native
from mound.errors import InputError, NoResultError, ToolNoResultError
from mound.formats.grid import SCHEMA, VERSION, GridLook, GridRow
from mound.formats.verdict import VerdictFile, record_grid_times
from mound.geometry.flight import DEFAULT_SITE_DIAMETER_M
from mound.jsonio import JsonObject, read_json, write_json
from mound.recon.defaults import CANDIDATES, SIM_RECONSTRUCT
from mound.sim import site as sim
from mound.sim.card import site_jpegs
from mound.sim.dem_places import DemPlaces
from mound.sim.draws import draw
from mound.sim.looks import (
    LOWER_FACTOR,
    SECOND_LOOK_FACTOR,
    SECOND_LOOK_P,
    SECOND_LOOKS,
    second_look_spec,
)
from mound.sim.population import read_population

DEFAULT_DEM = "TM1_564_146.tif"  # the 1 m airborne-laser DEM (../shared/data/dem)


def _site(out: Path, spec: sim.SimSpec, threads: int, remeasure: bool,
          dense: bool = False, card: bool = False,
          candidates: str = "site_ground") -> GridLook:
    """A look at a site: flown, reconstructed and judged in `out` unless its verdict (of
    this candidate set) is there already."""
    simdir, recon, verdict = out / "sim", out / "recon", out / "verdict.json"
    times: dict[str, float] = {}
    if verdict.exists() and not remeasure:
        done = VerdictFile.read(verdict)
        # a verdict of another candidate set is measured again (the grid holds one set; a
        # failed verdict measured nothing)
        if done.measurements is None or done.measurements.candidates == candidates:
            return GridLook(done.status, dict(done.grid_times_s), done.p_mound)
    if verdict.exists():  # remeasuring: keep the times of the flight and reconstruction
        try:
            times.update({k: v for k, v in VerdictFile.read(verdict).grid_times_s.items()
                          if k != "verdict"})
        except InputError:  # remeasured anyway: only its times are lost
            pass
    try:
        if not (recon / "recon.json").exists():
            t = time.perf_counter()
            sim.simulate(spec, simdir, threads=threads)
            # as from the aircraft's card: JPEGs whose EXIF carries the GPS and the focal
            # length, the lens (f, k1, k2) refined about EXIF's values (--lens prior)
            camera = ["--gps", "exif"]
            if card:
                site_jpegs(simdir, datetime(2026, 6, 1, 9, 0, 0))
            else:
                camera = ["--camera", str(simdir / "camera.json"), "--gps",
                          str(simdir / "poses.json"), *SIM_RECONSTRUCT.argv()]
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
                        str(threads)], 1800, log=out / "log.txt")
                except ToolNoResultError:
                    pass  # no dense cloud: the verdict then says status failed
                times["densify"] = time.perf_counter() - t
            verdict_args = ["--cloud", str(cloud)]
        if candidates != "site_ground":
            verdict_args += ["--candidates", candidates]
        t = time.perf_counter()
        try:
            native.run_tool("mound_recon", ["verdict", str(recon), "--out", str(verdict),
                                            *verdict_args], 600, log=out / "log.txt")
        except ToolNoResultError:
            pass  # verdict.json says status failed and why
        times["verdict"] = time.perf_counter() - t
        record_grid_times(verdict, times)
        judged = VerdictFile.read(verdict)
        return GridLook(judged.status, times, judged.p_mound,
                        None if judged.ok else judged.reason)
    except (InputError, NoResultError) as e:
        return GridLook("failed", times, None, str(e))


def make_grid(out: str | Path, sites: int, seed: int, size: tuple[int, int] = (640, 480),
              dem: str | list[str] | None = None, threads: int = 1, workers: int = 1,
              remeasure: bool = False,
              progress: Callable[[int, GridRow], None] | None = None, pattern: str = "raster",
              dense: bool = False, card: bool = False,
              flights_from: str | Path | None = None,
              second_look: bool = False, dem_part: str = "all",
              second_look_kind: str = "wider",
              population: str | None = None, ground: str = "mixed",
              candidates: str = "site_ground") -> dict[str, Any]:
    """Draws and runs the grid (see the module text); returns grid.json's document."""
    if not 1 <= sites <= 100_000:
        raise InputError("--sites: must be 1 .. 100,000")
    if second_look_kind not in SECOND_LOOKS:
        raise InputError(f"--second-look-kind: one of {', '.join(SECOND_LOOKS)}")
    if candidates not in CANDIDATES:
        raise InputError(f"--candidates: one of {', '.join(CANDIDATES)}")
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
             "population": pop.summary() if pop else "uniform",
             **({"ground": ground} if ground != "mixed" else {})}  # mixed: as grids before
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
    specs = [draw(rng, 100_000 * seed + k, dems, size, pattern=pattern, population=pop,
                  ground=ground) for k in range(sites)]
    start = time.perf_counter()
    rows = [GridRow(f"{k:04d}", specs[k].terrain.truth(), spec=_spec_doc(specs[k]))
            for k in range(sites)]

    def one(k: int) -> None:
        first = _site(root / f"{k:04d}", specs[k], threads, remeasure, dense, card, candidates)
        p = first.p_mound  # the first look's (grid.json's rows carry it)
        second = {}
        if second_look and p is not None and SECOND_LOOK_P[0] <= p < SECOND_LOOK_P[1]:
            folder = SECOND_LOOKS[second_look_kind]
            second[folder] = _site(root / f"{k:04d}" / folder,
                                   second_look_spec(specs[k], second_look_kind), threads,
                                   remeasure, dense, card, candidates)
        rows[k] = replace(rows[k], look=first, second=second)
        if progress:
            progress(k, rows[k])

    # One build judges the whole grid: the sites run a copy of mound_recon taken now, so
    # that a rebuild while the grid runs (make relinks build/mound_recon in place) fails no
    # site half-way and mixes no two detectors (until 2026-11-27 a rebuild failed the sites
    # running then with PermissionError).
    earlier, before_kinds = _before(root)
    with native.pinned("mound_recon") as digests:
        if workers > 1:
            from concurrent.futures import ThreadPoolExecutor

            with ThreadPoolExecutor(max_workers=workers) as pool:
                list(pool.map(one, range(sites)))
        else:
            for k in range(sites):
                one(k)
    tools = {name: {"sha256": d} for name, d in digests.items()}
    measured = sum(1 for r in rows if r.look.status == "ok")
    # a grid none of whose sites was measured is no result (the CLI's exit 3), whatever why
    status = "ok" if measured == sites else "partial" if measured else "failed"
    doc = {"schema": SCHEMA, "version": VERSION, "seed": seed, "sites": sites,
           "status": status, "measured": measured, "tools": tools,
           **({"earlier_tools": earlier} if earlier and earlier != tools and not remeasure
              else {}),
           "flight": _flight_doc(pattern, size),
           **({"second_look": {"scan_factor": SECOND_LOOK_FACTOR,
                               "lower_factor": LOWER_FACTOR,
                               "kinds": sorted({second_look_kind, *before_kinds}),
                               "first_p": list(SECOND_LOOK_P)}}
              if second_look or before_kinds else {}),
           "cloud": "dense" if dense else "sparse",
           **({"candidates": candidates} if candidates != "site_ground" else {}),
           "camera": "exif" if card else "calibrated",
           **draws, **({"flights_from": str(flights_from)} if flights_from else {}),
           "wall_s": time.perf_counter() - start,
           "rows": [r.to_doc() for r in rows]}
    write_json(root / "grid.json", doc)
    return doc


def _flight_doc(pattern: str, size: tuple[int, int]) -> JsonObject:
    """grid.json's `flight`: the survey's scan every site is flown with (sim.draws)."""
    return {"pattern": pattern, "site_diameter_m": DEFAULT_SITE_DIAMETER_M,
            "image_size": list(size)}


def _before(root: Path) -> tuple[Any, list[str]]:
    """What grid.json says of the grid's earlier runs: the build of the verdicts already
    there (the oldest one named; None when there is no grid.json yet) and the second looks
    flown before."""
    if not (root / "grid.json").is_file():
        return None, []
    before = read_json(root / "grid.json", SCHEMA, VERSION)
    sl = before.get("second_look") or {}
    if not isinstance(sl, dict):
        raise InputError(f"{root / 'grid.json'}: second_look: expected an object")
    return (before.get("earlier_tools") or before.get("tools"),
            list(sl.get("kinds", ["wider"] if sl else [])))


def _check_flights_from(src: Path, out: Path, sites: int, seed: int, size: tuple[int, int],
                        pattern: str, card: bool, draws: dict[str, Any]) -> None:
    """InputError (naming --flights-from and the field) unless src is a finished grid of the
    same draws (seed, DEM), flight and camera with at least `sites` sites, and not the grid
    itself."""
    if not (src / "grid.json").is_file():
        raise InputError(f"--flights-from: {src}/grid.json: no finished grid there")
    doc = read_json(src / "grid.json", SCHEMA, VERSION)
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


def _spec_doc(spec: sim.SimSpec) -> JsonObject:
    d: JsonObject = asdict(spec)
    return {"terrain": d["terrain"], "sun_deg": [math.degrees(spec.lighting.sun_azimuth_rad),
                                                  math.degrees(spec.lighting.sun_elevation_rad)],
            "hfov_deg": math.degrees(spec.hfov_rad), "seed": spec.seed}
