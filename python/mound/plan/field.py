"""Fields of candidate sites, as in the paper's experiment.

A 10 x 10 grid of sites at x, y = 1..10 m (east, north); every site holds a negative
test example of sat.tst (not cotton), then 3 to 5 positions are replaced by positive
examples (cotton, standing in for a mound). The classifier gives each site p_mound; its
binary entropy is the reward. A seed makes each realisation repeatable; seeds 0..9 are
the standard set. The truth travels in each site's "truth" field, which the planner
ignores.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mound.classify.model import Model
from mound.classify.reward import binary_entropy_bits
from mound.classify.statlog import COTTON, Split
from mound.errors import InputError
from mound.formats.sites import Node, Site, Sites, Truth
from mound.geometry.flight import ScanSpec
from mound.geometry.geodesy import Origin

GRID = 10
STANDARD_SEEDS = tuple(range(10))
ORIGIN = Origin(38.5705, 27.9862, 95.0)  # Bin Tepe, for flying


@dataclass
class Field:
    seed: int
    rows: np.ndarray      # (100,) sat.tst row of each site, grid order (x fastest)
    positive: np.ndarray  # (100,) bool: the site holds a positive example


def make_field(test: Split, seed: int, positives: tuple[int, int] = (3, 5)) -> Field:
    rng = np.random.default_rng(seed)
    neg = np.flatnonzero(test.cls != COTTON)
    pos = np.flatnonzero(test.cls == COTTON)
    n = GRID * GRID
    rows = rng.choice(neg, size=n, replace=False)
    k = int(rng.integers(positives[0], positives[1] + 1))
    where = rng.choice(n, size=k, replace=False)
    rows[where] = rng.choice(pos, size=k, replace=False)
    positive = np.zeros(n, dtype=bool)
    positive[where] = True
    return Field(seed=seed, rows=rows, positive=positive)


def sites_document(field: Field, test: Split, model: Model, scan_cost_m: float | None,
                   budget_m: float, home_xy: tuple[float, float] = (0.0, 0.0),
                   spacing_m: float = 1.0, scan: ScanSpec | None = None,
                   origin: Origin = ORIGIN) -> Sites:
    """The field as the sites of a mound.sites v1 document for mound_plan; sites at
    spacing_m * (1..10) (1 m: the paper's grid; a few hundred metres: real sites a UAV can
    fly).

    With `scan` (how each site is flown), the scan cost is derived from it
    (ScanSpec.site_cost_m) and the document records the spec and the take-off/landing
    climb, so that every plan within the budget is a flight within it; otherwise every
    site costs `scan_cost_m` (the paper's node cost)."""
    extra: dict[str, object] = {}
    takeoff_landing_m = 0.0
    if scan is not None:
        if scan_cost_m is not None:
            raise InputError("scan_cost_m: give a scan pattern or a scan cost, not both")
        scan_cost_m = scan.site_cost_m()
        extra = {"scan": scan.to_doc()}
        takeoff_landing_m = scan.takeoff_landing_m()
    elif scan_cost_m is None:
        raise InputError("scan_cost_m: missing (or give a scan pattern)")
    p = model.predict(test.x[field.rows])
    rewards = binary_entropy_bits(p)
    sites = []
    for k in range(GRID * GRID):
        i, j = k % GRID, k // GRID
        sites.append(Site(
            f"s{k + 1:03d}", spacing_m * (i + 1), spacing_m * (j + 1), float(rewards[k]),
            scan_cost_m, float(p[k]),
            Truth(bool(field.positive[k]), statlog_row=int(field.rows[k]),
                  extra={"class": int(test.cls[field.rows[k]])})))
    home = Node("home", home_xy[0], home_xy[1])
    return Sites(home, home, budget_m, tuple(sites), origin, takeoff_landing_m, {
        **extra,
        "provenance": {"tool": "mound field make", "seed": field.seed,
                       "classifier": {"band": model.band, "solver": model.solver, "l2": model.l2},
                       "total_reward": float(rewards.sum()),
                       "positives": int(field.positive.sum())}})
