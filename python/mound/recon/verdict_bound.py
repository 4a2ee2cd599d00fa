"""The oracle's ceiling for a verdict that reads the ground's shape (`mound recon
verdict-bound`, `mound.verdict_bound` v1).

The learned verdict has to find a tumulus in a cloud of the site and tell it from the
ground's own relief. How many of a grid's tumuli could any verdict that reads only the
surface's shape find at 1 % false alarms? This module measures what an oracle finds: a
matched filter told each tumulus's centre and the relief it adds (its profile, height,
diameter, erosion, looters' pit and trench: the site's own spec), on the site's true
surface (the heightfield it was rendered from: no reconstruction error at all). Over the
window r <= WINDOW x R about that centre, within the scanned site (the site's disc in its
verdict.json), the surface is fitted by least squares as a quadratic ground plus A times
the tumulus's unit profile; the filter's output is A over the RMS of the residual (the
tumulus's height over the ground it must be told from). Its null is the same filter, with
the grid's own tumuli's profiles drawn at random, placed at random within half the scanned
radius of the sites without a tumulus; the threshold is the null's 99th percentile, per
kind of ground (the laser DEM's real relief, or the simulator's undulating ground), so
that a tumulus is judged against ground of its own kind. A tumulus is found when its
output exceeds its kind's threshold.

It is an oracle, not a detector: it knows where the tumulus is and what shape it has, so
its count is a ceiling for a detector that has to search for both (which meets hills of
the same size at every place it looks), and a floor on what the ground's shape hides. It is
a least-squares matched filter against a quadratic ground, not the whitened one a model
of the ground's relief would allow, so it is a ceiling for this class of filter only.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from mound.errors import InputError
from mound.sim import terrain

SCHEMA = "mound.verdict_bound"
VERSION = 1
WINDOW = 1.5          # the filter's window: r <= WINDOW x the tumulus's base radius
FALSE_ALARMS = 0.01   # the null's share above the threshold
PLACEMENTS = 6        # null placements per site without a tumulus
MIN_CELLS = 50        # fewer cells of the window within the site: no output
GROUNDS = ("dem", "synthetic")  # the kinds of ground, each with its own null


def filter_output(hf: terrain.Heightfield, spec: terrain.TerrainSpec,
                  centre_m: tuple[float, float], site_centre_m: tuple[float, float],
                  site_radius_m: float) -> float | None:
    """The matched filter's output for the tumulus of `spec` (the relief it adds,
    terrain.mound_added) moved to `centre_m` on the surface `hf`: A / RMS(residual) of the
    least-squares fit of a quadratic ground plus A x that relief over its maximum, over
    r <= WINDOW R within the site's disc; None when fewer than MIN_CELLS cells lie there."""
    xx, yy = np.meshgrid(hf.x_m - centre_m[0], hf.y_m - centre_m[1])
    r = np.hypot(xx, yy)
    radius = spec.diameter_m / 2
    inside = np.hypot(xx + centre_m[0] - site_centre_m[0],
                      yy + centre_m[1] - site_centre_m[1]) <= site_radius_m
    w = (r <= WINDOW * radius) & inside & np.isfinite(hf.z_m)
    if int(w.sum()) < MIN_CELLS:
        return None
    moved = replace(spec, mound_x_m=centre_m[0], mound_y_m=centre_m[1])
    prof = terrain.mound_added(moved, xx[w] + centre_m[0], yy[w] + centre_m[1],
                               reach_m=WINDOW * radius + 4 * spec.erosion_m)
    top = float(prof.max())
    if not top > 0:
        return None
    x, y = xx[w], yy[w]
    a = np.column_stack([np.ones_like(x), x, y, x * x, x * y, y * y, prof / top])
    coef, *_ = np.linalg.lstsq(a, hf.z_m[w], rcond=None)
    rms = float(np.sqrt(np.mean((hf.z_m[w] - a @ coef) ** 2)))
    return float(coef[-1] / max(rms, 1e-6))


def read_thresholds(path: str | Path) -> dict[str, float]:
    """The thresholds of a `mound.verdict_bound` report (`--thresholds-from`): finite
    numbers by kind of ground ("dem", "synthetic"); InputError naming the file and field."""
    from mound.jsonio import read_json

    doc = read_json(path, SCHEMA, VERSION)
    thr = doc.get("thresholds")
    if not isinstance(thr, dict) or not thr:
        raise InputError(f"{path}: thresholds: expected numbers by kind of ground")
    out = {}
    for kind, v in thr.items():
        if kind not in GROUNDS:
            raise InputError(f"{path}: thresholds.{kind}: expected one of {', '.join(GROUNDS)}")
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            raise InputError(f"{path}: thresholds.{kind}: expected a finite number")
        out[kind] = float(v)
    return out


def _ground(spec: terrain.TerrainSpec) -> str:
    """The kind of ground a site was drawn on (GROUNDS): the laser DEM's or the simulator's."""
    return "dem" if spec.dem_path is not None else "synthetic"


def _site_disc(row: dict[str, Any]) -> tuple[tuple[float, float], float] | None:
    """The scanned site's centre and radius (its verdict's), None without them."""
    m = (row.get("verdict") or {}).get("measurements") or {}
    if "site_centre_enu_m" not in m or "site_radius_m" not in m:
        return None
    c = m["site_centre_enu_m"]
    return (float(c[0]), float(c[1])), float(m["site_radius_m"])


def measure(folders: list[str], placements: int = PLACEMENTS, seed: int = 0
            ) -> dict[str, Any]:
    """The oracle's outputs on the grids' goal tumuli (>= 2 m x 15 m) and its null (see the
    module text): {"tumuli": [...], "null": {"dem"|"synthetic": [...]}}."""
    from mound.recon import verdict_model as vm

    rng = np.random.default_rng(seed)
    tumuli: list[dict[str, Any]] = []
    empty: list[tuple[Path, terrain.TerrainSpec, tuple[tuple[float, float], float]]] = []
    profiles: list[terrain.TerrainSpec] = []
    for folder in folders:
        root = Path(folder)
        gpath = root / "grid.json"
        if not gpath.is_file():
            raise InputError(f"{root}: no grid.json (make one with `mound sim grid`)")
        for row in vm.load_grid(root):
            disc = _site_disc(row) if row["measured"] else None
            if disc is None:
                continue
            name, site = row["dir"], root / row["dir"]
            spec = vm.site_terrain(row, f"{gpath}: {name}")
            truth = row["truth"]
            if vm._goal(truth):
                profiles.append(spec)
                tumuli.append({"grid": str(root), "dir": name, "site": site, "spec": spec,
                               "disc": disc, "ground": _ground(spec),
                               "clear": vm.stands_clear(row), "truth": truth})
            elif not truth["mound"]:
                empty.append((site, spec, disc))
    if not tumuli or not empty:
        raise InputError(f"verdict-bound: {', '.join(folders)}: needs measured sites with a "
                         f"goal tumulus and without one (got {len(tumuli)} and {len(empty)})")
    for t in tumuli:
        hf = terrain.load_site_heightfield(t.pop("site") / "sim")
        sp = t.pop("spec")
        t["output"] = filter_output(hf, sp, (sp.mound_x_m, sp.mound_y_m), *t.pop("disc"))
    null: dict[str, list[float]] = {k: [] for k in GROUNDS}
    for site, spec, (centre, radius) in empty:
        hf = terrain.load_site_heightfield(site / "sim")
        kind = _ground(spec)
        for _ in range(placements):
            prof = profiles[int(rng.integers(len(profiles)))]
            ang, rad = rng.uniform(0, 2 * np.pi), 0.5 * radius * np.sqrt(rng.uniform())
            at = (centre[0] + rad * np.cos(ang), centre[1] + rad * np.sin(ang))
            out = filter_output(hf, prof, at, centre, radius)
            if out is not None:
                null[kind].append(out)
    return {"tumuli": tumuli, "null": null}


def judge(measured: dict[str, Any], thresholds: dict[str, float] | None = None
          ) -> dict[str, Any]:
    """The report: the null's thresholds (its 99th percentile per kind of ground, or the
    `thresholds` given, e.g. a training grid's) and the goal tumuli found, by kind of
    ground and by whether they stand clear of it (verdict_model.stands_clear)."""
    null = {k: np.asarray(v, dtype=float) for k, v in measured["null"].items()}
    thr = dict(thresholds) if thresholds else {
        k: float(np.quantile(v, 1 - FALSE_ALARMS)) for k, v in null.items() if len(v)}
    missing = sorted({t["ground"] for t in measured["tumuli"]} - set(thr))
    if missing:
        raise InputError(f"verdict-bound: no threshold for the {missing[0]} ground (no site "
                         "without a tumulus on it)")
    rows = []
    for t in measured["tumuli"]:
        out = t["output"]
        rows.append({"grid": t["grid"], "dir": t["dir"], "ground": t["ground"],
                     "clear": t["clear"], "output": out,
                     "found": bool(out is not None and out > thr[t["ground"]]),
                     "profile": t["truth"].get("profile"),
                     "height_m": t["truth"]["height_m"],
                     "diameter_m": t["truth"]["diameter_m"]})

    def count(sel: list[dict[str, Any]]) -> dict[str, int]:
        return {"sites": len(sel), "found": sum(r["found"] for r in sel)}
    return {
        "schema": SCHEMA, "version": VERSION,
        "method": "matched filter told each tumulus's centre and the relief it adds "
                  "(profile, size, erosion, pit, trench), on the true surface: quadratic "
                  "ground + A x that relief over r <= "
                  f"{WINDOW:g} R within the scanned site, output A / RMS(residual); "
                  f"threshold the {100 * (1 - FALSE_ALARMS):g}th percentile of its null "
                  "(random profiles at random places on the sites without a tumulus) per "
                  "kind of ground",
        "grids": sorted({t["grid"] for t in measured["tumuli"]}),
        "false_alarms": FALSE_ALARMS,
        "thresholds": thr, "thresholds_given": bool(thresholds),
        "null": {k: {"placements": int(len(v)),
                     "above_threshold": (float(np.mean(v > thr[k])) if len(v) and k in thr
                                         else None)}
                 for k, v in null.items()},
        "goal_tumuli": {
            "all": count(rows),
            "clear": count([r for r in rows if r["clear"] is True]),
            "masked": count([r for r in rows if r["clear"] is False]),
            **{f"on_{k}": count([r for r in rows if r["ground"] == k])
               for k in GROUNDS}},
        "rows": rows,
    }
