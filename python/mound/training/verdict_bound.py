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
the same size at every place it looks), and a floor on what the ground's shape hides.

The plain filter treats the ground's departure from a quadratic as white. The whitened one
(`whiten=True`, `--whiten`) knows the ground's second-order statistics at the tumulus's own
window: the window's surface is read at a polar pattern (NR radii over r <= WINDOW R, NA
azimuths, those within the scanned disc), its quadratic drift projected out, and the
covariance of what is left estimated from the same window, at the same place in the scan,
on the sites without a tumulus on the same kind of ground (rotated about the site centre
NA times: the scanned disc is round; Ledoit-Wolf shrinkage). Its output is the
generalised likelihood ratio's t for A x the told relief against Gaussian ground of that
covariance up to an unknown scale (the whitened amplitude over the whitened residual's
RMS, scale-free like the plain filter's). The sites without a tumulus are split at random
into two halves: one estimates the covariance, the other gives the null (the same window
on each of its sites, NULL_ROTATIONS random rotations); a held-out grid takes its
covariance from the training grids' sites (`ground_from`) and its null from its own. The
whitened filter is the optimal linear detector for Gaussian ground of that covariance; the
laser DEM's hills are not Gaussian, so it too is a ceiling for its class only.

Told the place only to within a distance (`place_within_m`, `--place-within`), the
whitened filter takes its highest output over centres on a lattice of PLACE_STEP_M within
that distance of the true one (the window's covariance the true centre's; only the samples
within the scanned site for every centre), and its null the same highest output over the
same centres about each null window: how closely the place has to be known.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from mound.errors import InputError
from mound.recon.grid_site import SiteTruth
from mound.sim import terrain
from mound.training import verdict_data as vd

SCHEMA = "mound.verdict_bound"
VERSION = 1
WINDOW = 1.5          # the filter's window: r <= WINDOW x the tumulus's base radius
FALSE_ALARMS = 0.01   # the null's share above the threshold
PLACEMENTS = 6        # null placements per site without a tumulus
MIN_CELLS = 50        # fewer cells of the window within the site: no output
GROUNDS = ("dem", "synthetic")  # the kinds of ground, each with its own null
NR, NA = 12, 24       # the whitened filter's polar pattern: radii over r <= WINDOW R, azimuths
NULL_ROTATIONS = 4    # the whitened null: random rotations of the window per site
MIN_SAMPLES = 40      # fewer samples of the pattern within the site: no whitened output
PLACE_STEP_M = 2.0    # the lattice of centres searched when told the place within a distance


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


def read_thresholds(path: str | Path, filter_kind: str = "plain",
                    place_within_m: float = 0.0) -> dict[str, float]:
    """The thresholds of a `mound.verdict_bound` report (`--thresholds-from`): finite
    numbers by kind of ground ("dem", "synthetic"), of the same filter (`filter`, "plain"
    when absent) told the place as closely (`place_within_m`, 0 when absent); InputError
    naming the file and field."""
    from mound.jsonio import read_json

    doc = read_json(path, SCHEMA, VERSION)
    kind = doc.get("filter", "plain")
    if kind != filter_kind:
        raise InputError(f"{path}: filter: {kind!r}: thresholds of another filter than the "
                         f"{filter_kind} one asked for")
    within = doc.get("place_within_m", 0.0)
    if within != place_within_m:
        raise InputError(f"{path}: place_within_m: {within!r}: thresholds of a filter told "
                         f"the place otherwise than within {place_within_m:g} m")
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


def _sample(hf: terrain.Heightfield, pts: np.ndarray) -> np.ndarray:
    """The surface at points (n, 2) (m, the site's frame), bilinear; NaN off the grid."""
    x, y = pts[:, 0], pts[:, 1]
    return np.where(hf.covers(x, y), hf.height_at(x, y), np.nan)


def _rotated(v: np.ndarray, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.column_stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]])


Ground = list[tuple[terrain.Heightfield, tuple[float, float]]]  # surfaces, site centres


def whitened_output(hf: terrain.Heightfield, spec: terrain.TerrainSpec,
                    site_centre_m: tuple[float, float], site_radius_m: float,
                    ground: Ground, null: Ground, rng: np.random.Generator,
                    place_within_m: float = 0.0) -> tuple[float, list[float]] | None:
    """The whitened filter's output for the tumulus of `spec` at its own centre on `hf`,
    and its null: the same window on each `null` site (NULL_ROTATIONS random rotations
    about the site centre); the covariance from the same window on each `ground` site (NA
    rotations). See the module text. None when fewer than MIN_SAMPLES samples of the
    pattern lie within the site (or on its surface), when the ground sites give no more
    windows than the pattern has dimensions, or when the told relief is none there beyond
    the window's quadratic drift. `place_within_m`: the highest output over the centres
    within that distance (see the module text), for the tumulus and each null window."""
    radius = spec.diameter_m / 2
    rho = (np.arange(NR) + 0.5) / NR * WINDOW * radius
    theta = np.arange(NA) * 2 * np.pi / NA
    rr, tt = np.meshgrid(rho, theta, indexing="ij")
    local = np.column_stack([(rr * np.cos(tt)).ravel(), (rr * np.sin(tt)).ravel()])
    centre = np.array([spec.mound_x_m, spec.mound_y_m])
    rel = centre + local - np.asarray(site_centre_m)  # the window about the site centre
    k = PLACE_STEP_M * np.arange(-math.floor(place_within_m / PLACE_STEP_M),
                                 math.floor(place_within_m / PLACE_STEP_M) + 1)
    shifts = np.array([(a, b) for a in k for b in k if math.hypot(a, b) <= place_within_m])
    keep = np.all([np.hypot(rel[:, 0] + dx, rel[:, 1] + dy) <= site_radius_m
                   for dx, dy in shifts], axis=0)
    if int(keep.sum()) < MIN_SAMPLES:
        return None
    local, rel = local[keep], rel[keep]
    pts = np.asarray(site_centre_m) + rel
    told = terrain.mound_added(spec, pts[:, 0], pts[:, 1],
                               reach_m=WINDOW * radius + 4 * spec.erosion_m)
    if not told.max() > 0:
        return None
    x, y = local[:, 0] / radius, local[:, 1] / radius
    drift = np.column_stack([np.ones_like(x), x, y, x * x, x * y, y * y])
    q = np.linalg.svd(drift, full_matrices=True)[0][:, drift.shape[1]:]  # drift's complement

    def windows(sites: Ground, angles: list[np.ndarray], at: np.ndarray) -> np.ndarray:
        """(windows, centres `at`, drift's complement): each site's window at each angle."""
        out = [_sample(g, np.concatenate([np.asarray(c) + _rotated(rel + d, a)
                                          for a in ang for d in at])
                       ).reshape(len(ang), len(at), len(rel))
               for (g, c), ang in zip(sites, angles, strict=True)]
        w = np.concatenate(out)
        return w[np.isfinite(w).all(axis=(1, 2))] @ q

    u = windows(ground, [theta] * len(ground), np.zeros((1, 2)))[:, 0]
    if len(u) <= q.shape[1]:
        return None
    mean = u.mean(axis=0)
    cov = np.cov(u, rowvar=False)
    d, n = cov.shape[0], len(u)
    # Ledoit-Wolf shrinkage towards the scaled identity
    target = np.trace(cov) / d
    dev = u - mean
    spread = float(((dev ** 2).T @ (dev ** 2) / n - cov ** 2).sum() / n)
    lam = min(max(spread / max(float(((cov - target * np.eye(d)) ** 2).sum()), 1e-12), 0.0),
              1.0)
    chol = np.linalg.cholesky((1 - lam) * cov + lam * target * np.eye(d))
    from scipy.linalg import solve_triangular

    g = solve_triangular(chol, q.T @ (told / told.max()), lower=True)
    gg = float(g @ g)
    if not gg > 1e-12:  # the told relief is the window's drift: nothing to tell it by
        return None

    def t(vs: np.ndarray) -> np.ndarray:
        """The highest output over the centres of each window (windows, centres, d)."""
        flat = vs.reshape(-1, d)
        yw = solve_triangular(chol, (flat - mean).T, lower=True).T
        a = yw @ g / gg
        res = yw - a[:, None] * g[None, :]
        out = a * math.sqrt(gg) / np.sqrt((res ** 2).sum(axis=1) / (d - 1))
        return out.reshape(vs.shape[:2]).max(axis=1)

    own = windows([(hf, site_centre_m)], [np.zeros(1)], shifts)
    if not len(own):
        return None
    angles = [rng.uniform(0, 2 * np.pi, NULL_ROTATIONS) for _ in null]
    return float(t(own)[0]), [float(v) for v in t(windows(null, angles, shifts))]


Empty = list[tuple[Path, terrain.TerrainSpec, tuple[tuple[float, float], float]]]


@dataclass
class Tumulus:
    """A measured goal tumulus of a grid: where, its terrain, the scanned disc, its kind of
    ground, whether it stands clear of it, and the filter's output (None: no window)."""

    grid: str
    dir: str
    site: Path
    spec: terrain.TerrainSpec
    disc: tuple[tuple[float, float], float]
    ground: str
    clear: bool | None
    truth: SiteTruth
    output: float | None = None


@dataclass
class Measured:
    """The filter's outputs on the tumuli and its null per kind of ground (`measure`)."""

    tumuli: list[Tumulus]
    null: dict[str, list[float]]
    filter: str
    place_within_m: float = 0.0


def _read(folders: list[str]) -> tuple[list[Tumulus], Empty]:
    """The grids' measured goal tumuli and their sites without a tumulus."""
    tumuli: list[Tumulus] = []
    empty: Empty = []
    for folder in folders:
        root = Path(folder)
        gpath = root / "grid.json"
        if not gpath.is_file():
            raise InputError(f"{root}: no grid.json (make one with `mound sim grid`)")
        for row in vd.load_grid(root):
            disc = row.disc() if row.measured else None
            if disc is None:
                continue
            name, site = row.dir, root / row.dir
            spec = vd.site_terrain(row, f"{gpath}: {name}")
            truth = row.truth
            if vd.goal_tumulus(truth):
                tumuli.append(Tumulus(str(root), name, site, spec, disc, _ground(spec),
                                      vd.stands_clear(row.relief), truth))
            elif not truth.mound:
                empty.append((site, spec, disc))
    return tumuli, empty


def _surfaces(empty: Empty) -> dict[str, Ground]:
    """The true surfaces of sites without a tumulus, by kind of ground."""
    out: dict[str, Ground] = {k: [] for k in GROUNDS}
    for site, spec, (centre, _) in empty:
        out[_ground(spec)].append((terrain.load_site_heightfield(site / "sim"), centre))
    return out


def measure(folders: list[str], placements: int = PLACEMENTS, seed: int = 0,
            whiten: bool = False, ground_from: list[str] | None = None,
            place_within_m: float = 0.0) -> Measured:
    """The oracle's outputs on the grids' goal tumuli (>= 2 m x 15 m) and its null (see the
    module text), the null by kind of ground ("dem", "synthetic").
    `whiten`: the whitened filter, its covariance from `ground_from`'s sites without a
    tumulus (default: half of the grids' own, the other half the null), told the place
    within `place_within_m`."""
    rng = np.random.default_rng(seed)
    tumuli, empty = _read(folders)
    if not tumuli or not empty:
        raise InputError(f"verdict-bound: {', '.join(folders)}: needs measured sites with a "
                         f"goal tumulus and without one (got {len(tumuli)} and {len(empty)})")
    null: dict[str, list[float]] = {k: [] for k in GROUNDS}
    if whiten:
        own = _surfaces(empty)
        if ground_from:
            ground, nulls = _surfaces(_read(ground_from)[1]), own
        else:
            ground, nulls = {}, {}
            for k, sites in own.items():
                order = rng.permutation(len(sites))
                ground[k] = [sites[i] for i in order[:len(sites) // 2]]
                nulls[k] = [sites[i] for i in order[len(sites) // 2:]]
        for t in tumuli:
            kind = t.ground
            if not ground[kind] or not nulls[kind]:
                raise InputError(f"verdict-bound --whiten: no sites without a tumulus on "
                                 f"{kind} ground to learn its covariance and null from")
            (centre, radius) = t.disc
            hf = terrain.load_site_heightfield(t.site / "sim")
            got = whitened_output(hf, t.spec, centre, radius, ground[kind], nulls[kind], rng,
                                  place_within_m)
            t.output = None if got is None else got[0]
            if got is not None:
                null[kind].extend(got[1])
        return Measured(tumuli, null, "whitened", place_within_m)
    profiles = [t.spec for t in tumuli]
    for t in tumuli:
        hf = terrain.load_site_heightfield(t.site / "sim")
        sp = t.spec
        t.output = filter_output(hf, sp, (sp.mound_x_m, sp.mound_y_m), *t.disc)
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
    return Measured(tumuli, null, "plain")


METHODS = {
    "plain": "matched filter told each tumulus's centre and the relief it adds (profile, "
             "size, erosion, pit, trench), on the true surface: quadratic ground + A x that "
             f"relief over r <= {WINDOW:g} R within the scanned site, output A / "
             "RMS(residual); its null random profiles at random places on the sites without "
             "a tumulus",
    "whitened": "whitened matched filter told each tumulus's centre and the relief it adds, "
                f"on the true surface: a polar pattern ({NR} radii over r <= {WINDOW:g} R, "
                f"{NA} azimuths) within the scanned site, its quadratic drift projected out, "
                "whitened by the covariance of the same window on half the sites without a "
                "tumulus (or on the --ground-from grids'), output the generalised likelihood "
                "ratio's t for A x that relief; its null the same window on the other sites "
                "without a tumulus",
}


def judge(measured: Measured, thresholds: dict[str, float] | None = None
          ) -> dict[str, Any]:
    """The report: the null's thresholds (its 99th percentile per kind of ground, or the
    `thresholds` given, e.g. a training grid's) and the goal tumuli found, by kind of
    ground and by whether they stand clear of it (verdict_model.stands_clear)."""
    null = {k: np.asarray(v, dtype=float) for k, v in measured.null.items()}
    thr = dict(thresholds) if thresholds else {
        k: float(np.quantile(v, 1 - FALSE_ALARMS)) for k, v in null.items() if len(v)}
    missing = sorted({t.ground for t in measured.tumuli} - set(thr))
    if missing:
        raise InputError(f"verdict-bound: no threshold for the {missing[0]} ground (no site "
                         "without a tumulus on it)")
    rows = []
    for t in measured.tumuli:
        out = t.output
        rows.append({"grid": t.grid, "dir": t.dir, "ground": t.ground,
                     "clear": t.clear, "output": out,
                     "found": bool(out is not None and out > thr[t.ground]),
                     "profile": t.truth.profile,
                     "height_m": t.truth.height_m,
                     "diameter_m": t.truth.diameter_m})

    def count(sel: list[dict[str, Any]]) -> dict[str, int]:
        return {"sites": len(sel), "found": sum(r["found"] for r in sel)}
    return {
        "schema": SCHEMA, "version": VERSION,
        "filter": measured.filter,
        "place_within_m": measured.place_within_m,
        "method": (METHODS[measured.filter]
                   + f"; threshold the {100 * (1 - FALSE_ALARMS):g}th percentile of its null "
                   "per kind of ground"),
        "grids": sorted({t.grid for t in measured.tumuli}),
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
