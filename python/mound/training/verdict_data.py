"""The verdict's data: a grid's measured sites (`load_grid`), the training labels of their
rises (`rise_labels`), whether a tumulus stands clear of its ground, and what a grid says
of itself (its cloud, its label). See verdict_model.py for the model."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from mound.errors import InputError
from mound.formats import grid as grid_doc
from mound.formats.verdict import Rise, VerdictFile
from mound.jsonio import read_json
from mound.recon.grid_site import GridSite, SiteTruth, grid_site
from mound.sim import terrain
from mound.sim.looks import SECOND_LOOKS

MAX_FA = 0.01


Rule = tuple[float, float, tuple[float, float, float]]  # p_low, threshold, combine


HEIGHT_BINS = (0.5, 1.0, 2.0, 4.0, 8.0, 30.0)


DIAMETER_BINS = (10.0, 15.0, 30.0, 60.0, 150.0)


def site_folds(n: int, k: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).permutation(n) % k


def found_by_ground(found: np.ndarray, ground: dict[str, np.ndarray]) -> dict[str, object]:
    """Of the sites in each of `ground`'s masks, how many `found` (CV splits x sites) holds,
    the mean over the splits."""
    return {"clear_of_ground": CLEAR_OF_GROUND,
            **{name: {"sites": int(sel.sum()), "found": float(found[:, sel].sum() / len(found))}
               for name, sel in ground.items()}}


# A tumulus stands clear of its ground when its prominence over the ground around it is at
# least this many times that ground's clutter (terrain.mound_relief, on the true surface);
# below it the ground undulates at the tumulus's own scale nearly as high as the tumulus
# stands, and the verdict, which reads the cloud's shape alone, cannot tell it from the
# ground's own rises. The goal's rates are reported for both (evaluate: goal_by_ground).
# Set from the training grid's out-of-fold misses (dense: every one of the 12 goal
# tumuli under 5 lies on the laser DEM, found 4.5 of 12 times; at 5 or more, 176.2 of 178)
# and checked on the held-out grid.
CLEAR_OF_GROUND = 5.0


# A rise over a tumulus wider than this many times its diameter is the ground that holds it
# (rise_labels)
RISE_MAX_SCALE = 2.5


# The goal's tumuli by ground, as stands_clear() says: (name, its value)
GROUND_CLASSES = (("clear", True), ("masked", False))


def load_grid(folder: str | Path, second_look: str = "wider") -> list[GridSite]:
    """The sites of a grid: truth, and where measured the judged rises, the second look of
    kind `second_look` (mound.sim.looks.SECOND_LOOKS) where flown, the tumulus's relief."""
    if second_look not in SECOND_LOOKS:
        raise InputError(f"--second-look-kind: one of {', '.join(SECOND_LOOKS)}")
    root = Path(folder)
    gpath = root / "grid.json"
    if gpath.is_file():
        listed = read_json(gpath, grid_doc.SCHEMA, grid_doc.VERSION).get("rows")
        if not isinstance(listed, list):
            raise InputError(f"{gpath}: rows: expected a list")
        rows = [grid_doc.GridRow.from_doc(r, f"{gpath}: rows[{k}]")
                for k, r in enumerate(listed)]
    elif root.is_dir():  # a grid still running or interrupted: its finished sites
        rows = []
        for t in sorted(root.glob("*/sim/truth.json")):
            site = t.parent.parent
            truth = {k: v for k, v in read_json(t, "mound.sim_truth", 1).items()
                     if k not in ("schema", "version", "frame", "origin")}
            done = (site / "verdict.json").is_file()
            rows.append(grid_doc.GridRow(site.name, truth,
                                         grid_doc.GridLook("ok" if done else "running")))
    else:
        raise InputError(f"{root}: no grid (make one with `mound sim grid`)")
    out = []
    for k, row in enumerate(rows):
        where = f"{gpath}: rows[{k}]"
        vpath = root / row.dir / "verdict.json"
        if row.look.status != "ok" or not vpath.is_file():
            out.append(grid_site(row, None, None, str(root), where))
            continue
        judged = grid_site(row, VerdictFile.read(vpath),
                           _second_look(root / row.dir / SECOND_LOOKS[second_look]),
                           str(root), where)
        out.append(replace(judged, relief=_relief(root / row.dir, judged.truth)))
    return out


def _relief(site: Path, truth: SiteTruth) -> dict[str, float] | None:
    """How far the site's tumulus stands out of its ground (terrain.mound_relief), from the
    true surface the site was rendered from (NNNN/sim/heightfield.npy); None without a
    tumulus or without that surface."""
    if not truth.mound or not (site / "sim" / "site.json").is_file():
        return None
    hf = terrain.load_site_heightfield(site / "sim")
    return terrain.mound_relief(hf, truth.centre_enu_m, truth.diameter_m)


def site_terrain(site: GridSite, where: str) -> terrain.TerrainSpec:
    """A grid site's terrain (its row's spec.terrain), without its confusers: the ground and
    the tumulus the site was drawn with; InputError naming `where` when the row holds none."""
    if site.terrain is None:
        raise InputError(f"{where}: spec.terrain: missing (not a simulated site's row)")
    try:
        t: Any = {**site.terrain, "confusers": ()}
        return terrain.TerrainSpec(**t)
    except (KeyError, TypeError) as e:
        raise InputError(f"{where}: spec.terrain: not a simulated site's terrain ({e})") \
            from None


def stands_clear(relief: Mapping[str, float] | None) -> bool | None:
    """Whether a tumulus stands clear of its ground (`relief`, terrain.mound_relief): its
    prominence at least CLEAR_OF_GROUND times the ground's clutter (None: relief unknown)."""
    if not relief:
        return None
    return bool(relief["prominence_m"] >= CLEAR_OF_GROUND * relief["ground_clutter_m"])


def _second_look(folder: Path) -> VerdictFile | None:
    """A site's second look's verdict (GRID/NNNN/second/verdict.json, `mound sim grid
    --second-look`; second_lower/ for the lower one): None when it was not flown or allowed
    no verdict."""
    path = folder / "verdict.json"
    if not path.is_file():
        return None
    v = VerdictFile.read(path)
    return v if v.ok else None


def rise_labels(site: GridSite) -> list[bool | None]:
    """What each judged rise of a site is, for training: on a site without a tumulus every
    rise is a negative. On a tumulus site a rise is the tumulus's (a positive) when its
    centre lies within max(8 m, the tumulus's radius) of the true centre and it is at least
    0.4 x the tumulus's diameter across; a rise that overlaps the tumulus otherwise (a pit's
    rim, a shoulder, the tumulus with the ground around it) is left out (None: no truth
    says whether it is the mound), and one clear of it is a negative. Left out too (since
    2026-11-28): a rise over the tumulus more than RISE_MAX_SCALE x its diameter across (a
    swell of the ground that holds it, not it), and every rise over a tumulus that stands
    less high than its ground's own clutter around it (`buried`: no cloud shows it). Labelled
    positives, such rises taught the model that low wide swells of bare ground are tumuli:
    a 0.35 m x 67 m swell of undulating ground scored p 0.93 (issue 56)."""
    t = site.truth
    out: list[bool | None] = []
    rel = site.relief
    buried = bool(t.mound and rel and rel["prominence_m"] < rel["ground_clutter_m"])
    for k, r in enumerate(site.rises):
        if not t.mound:
            out.append(False)
            continue
        if r.centre_enu_m is None:
            raise InputError(f"{site.where}: judged_rises[{k}]: no centre_enu_m")
        d = math.hypot(r.centre_enu_m[0] - t.centre_enu_m[0],
                       r.centre_enu_m[1] - t.centre_enu_m[1])
        size = t.diameter_m if r.base_diameter_m is None else r.base_diameter_m
        near = d <= max(8.0, t.diameter_m / 2)
        if near and (buried or size > RISE_MAX_SCALE * t.diameter_m):
            out.append(None)
        elif near and size >= 0.4 * t.diameter_m:
            out.append(True)
        elif d < (t.diameter_m + size) / 2:
            out.append(None)
        else:
            out.append(False)
    return out


def goal_tumulus(truth: SiteTruth) -> bool:
    """A tumulus of the issue's goal: >= 2 m high and >= 15 m across."""
    return truth.mound and truth.height_m >= 2 and truth.diameter_m >= 15


def rise_features(rise: Rise, names: list[str], where: str) -> list[float]:
    """A judged rise's features in the order of `names`; InputError naming the verdict file
    `where` when one is missing (measured by another detector)."""
    missing = [n for n in names if n not in rise.features]
    if missing:
        raise InputError(f"{where}: features: no {missing[0]!r} (remeasure the grid with this "
                         "detector: mound sim grid --remeasure)")
    return [rise.features[n] for n in names]


def grid_cloud(folder: str | Path) -> str:
    """The cloud a grid's verdicts judged (`sparse` or `dense`): its grid.json's `cloud`
    (grids made before the field existed were sparse); a grid still running (no grid.json)
    by the cloud its finished verdicts name (dense/dense.ply or recon/points.ply).
    InputError when neither says (until 2026-11-28 such a grid was taken for sparse)."""
    root = Path(folder)
    if (root / "grid.json").is_file():
        doc = read_json(root / "grid.json", grid_doc.SCHEMA, grid_doc.VERSION)
        return str(doc.get("cloud", "sparse"))
    for v in sorted(root.glob("*/verdict.json")):
        try:
            verdict = VerdictFile.read(v)
        except InputError:  # a verdict being written: the next one says
            continue
        if verdict.cloud:
            return verdict.cloud_kind
    raise InputError(f"{root}: no grid.json and no finished verdict: which cloud it judges "
                     "is unknown")


def grid_label(folder: str | Path) -> str:
    """How a grid was flown and which cloud was judged, from its grid.json."""
    try:
        doc = read_json(Path(folder) / "grid.json", grid_doc.SCHEMA, grid_doc.VERSION)
    except InputError:  # a grid still running: its folder's name
        return Path(folder).name
    flight = doc.get("flight") or {}
    w, h = (flight.get("image_size") or [0, 0])[:2]
    what = "full flight (raster + orbit)" if flight.get("pattern") == "both" else \
        "survey flight (raster)"
    camera = ", photo card (EXIF, lens held by a prior)" if doc.get("camera") == "exif" else ""
    pop = doc.get("population", "uniform")
    pop = "" if pop == "uniform" else ", Kazanlak-measured tumuli" if "kazanlak" in str(
        pop.get("file", "") if isinstance(pop, dict) else pop) else ", measured tumuli"
    part = doc.get("dem_part", "all")
    part = f", DEM part {part}" if part != "all" else ""
    return (f"{what}, {doc.get('cloud', 'sparse')} cloud{camera}{pop}{part}, {w} x {h}, "
            f"seed {doc.get('seed')}")


def feature_names_of(sites: list[GridSite]) -> list[str]:
    for r in sites:
        if r.measured and r.rises:
            return list(r.rises[0].features)
    raise InputError("train-verdict: no measured site with a rise in the grid")
