"""The verdict model file's blocks beside the model's weights: the second look's rule and
one not kept (typed here, learned in verdict_second), the reasons' thresholds and the
terrain domain (learned here from the training sites); mound.recon.model_file reads them
back."""

from __future__ import annotations

from typing import TypedDict

import numpy as np

from mound.recon.grid_site import GridSite
from mound.training.verdict_data import goal_tumulus


class GoalByGround(TypedDict, total=False):
    goal_found_by_ground: dict[str, object]


class SecondLookFigures(GoalByGround):
    """The second look's figures out of fold (nested), the first look's beside them."""
    flights: float
    goal_found: float
    goal_found_first_look: float
    goal_sites: int
    found: float
    found_first_look: float
    goal_found_first_look_same_fa: float
    found_first_look_same_fa: float
    false_alarms: float
    false_alarms_first_look: float
    negatives: int
    folds: int
    folds_without_a_rule: int


class SecondLookInSample(TypedDict):
    flights: float
    goal_found: float
    found: float
    false_alarms: float


class SecondLookTrained(TypedDict):
    fitted_sites: int
    fitted_mounds: int
    out_of_fold: SecondLookFigures
    selected_in_sample: SecondLookInSample
    method: str


class Combine(TypedDict):
    first: float
    second: float
    bias: float


class SecondLookRule(TypedDict):
    """The model file's `second_look` (second_look_rule)."""
    p_low: float
    threshold: float
    scan_factor: float
    combine: Combine
    trained: SecondLookTrained


class SecondLookNotKept(TypedDict):
    """A second look's rule that gained too little out of fold, and why (_kept)."""
    p_low: float
    threshold: float
    out_of_fold: SecondLookFigures
    selected_in_sample: SecondLookInSample
    why: str


class ReasonsTrained(TypedDict):
    cut_youden_j: float
    irregular_youden_j: float
    goal_tumuli_cut: int
    goal_tumuli_uncut: int
    sites_without_tumulus: int
    method: str


class Reasons(TypedDict):
    """The model file's `reasons` (reason_thresholds)."""
    cut_roughness: float
    irregular_roughness: float
    trained: ReasonsTrained


class Neighbours(TypedDict):
    """The model file's terrain_domain.neighbours (terrain_neighbours)."""
    k: int
    centre: list[float]
    scale: list[float]
    points: list[list[float]]
    max_distance: float
    quantile: float
    method: str


class NeighboursPart(TypedDict, total=False):
    neighbours: Neighbours


class TerrainDomain(NeighboursPart):
    """The model file's `terrain_domain` (terrain_domain)."""
    ranges: dict[str, list[float]]
    sites: int
    grids: list[str]
    margin: float
    outside_left_out: float | None
    method: str


# The terrain domain's margin, in units of each descriptor's range over the training sites,
# on either side: left out one at a time, the Kazanlak training grid's 160 sites fall
# outside the others' plain range 9 times (5.6 %, each descriptor twice), outside the
# range widened by 0.05 or 0.1 of it twice (1.2 %), by 0.2 still twice (2026-11-29).
DOMAIN_MARGIN = 0.1
# A site whose ground is far from every training site's, though each descriptor lies in
# its range (ridges and terraces: relief, slope and noise each like some training site's,
# never together): its mean distance to its NEIGHBOURS_K nearest training sites beyond
# the NEIGHBOURS_QUANTILE of the training sites' own (left out one at a time). The
# quantile chosen on the training grids alone, one terrain family left out: the domain of
# the gentle grids' 320 sites, judged on the steep training grid's 158 by the model
# trained on the gentle ones (box and neighbours together): at 0.95 and below no confident
# error among the sites left inside, at 0.975 and above one confident miss of 44
# (2026-11-29); the largest quantile without it.
NEIGHBOURS_K = 5
# The reasons' thresholds need this many goal tumuli with and without a cut, and sites
# with and without a tumulus, among the training sites.
REASON_MIN = 20
NEIGHBOURS_QUANTILE = 0.95


def _youden(x: np.ndarray, pos: np.ndarray) -> tuple[float, float]:
    """The threshold t (x >= t calls positive) that best separates `pos` from the rest
    (Youden's J = true positive rate - false positive rate), and its J."""
    best = (float(np.inf), 0.0)
    for t in np.unique(x):
        j = float(np.mean(x[pos] >= t) - np.mean(x[~pos] >= t))
        if j > best[1]:
            best = (float(t), j)
    return best


def reason_thresholds(sites: list[GridSite]) -> Reasons | None:
    """The model's `reasons` from the training sites' judged rises (their roughness, the
    dome fit's residual over the height) and truth: cut_roughness separates the tumuli
    >= 2 m high and 15 m across (goal_tumulus: a cut shows on them) with a looters' trench
    or pit from those without, irregular_roughness the sites
    without a tumulus from those with one (at least cut_roughness); each the threshold of
    best Youden's J. None without REASON_MIN of each kind."""
    judged = [(r.truth, r.rise) for r in sites
              if r.rise is not None and "roughness" in r.rise.features]
    rough = np.array([float(rise.features["roughness"]) for _, rise in judged])
    goal = np.array([goal_tumulus(t) for t, _ in judged], dtype=bool)
    cut = np.array([t.cut for t, _ in judged], dtype=bool)
    mound = np.array([t.mound for t, _ in judged], dtype=bool)
    if min(int((goal & cut).sum()), int((goal & ~cut).sum()), int(mound.sum()),
           int((~mound).sum())) < REASON_MIN:
        return None
    t_cut, j_cut = _youden(rough[goal], cut[goal])
    t_nat, j_nat = _youden(rough, ~mound)
    t_nat = max(t_nat, t_cut)
    return {"cut_roughness": t_cut, "irregular_roughness": t_nat,
            "trained": {"cut_youden_j": j_cut, "irregular_youden_j": j_nat,
                        "goal_tumuli_cut": int((goal & cut).sum()),
                        "goal_tumuli_uncut": int((goal & ~cut).sum()),
                        "sites_without_tumulus": int((~mound).sum()),
                        "method": "the judged rise's roughness: cut_roughness the threshold "
                                  "of best Youden's J between the tumuli >= 2 m x 15 m with "
                                  "a trench or pit and without; irregular_roughness between "
                                  "the sites without a tumulus and with one"}}


def terrain_neighbours(x: np.ndarray) -> Neighbours:
    """terrain_domain.neighbours from the training sites' descriptors `x` (sites x
    TERRAIN_DESCRIPTORS): each standardised by the median and interquartile range, and
    max_distance the NEIGHBOURS_QUANTILE of each site's mean distance to its NEIGHBOURS_K
    nearest others (left out one at a time)."""
    centre = np.median(x, axis=0)
    scale = np.subtract(*np.percentile(x, [75, 25], axis=0))
    scale = np.where(scale > 1e-6, scale, np.maximum(x.std(axis=0), 1e-6))
    z = (x - centre) / scale
    d = np.sqrt(((z[:, None, :] - z[None, :, :]) ** 2).sum(axis=-1))
    np.fill_diagonal(d, np.inf)
    loo = np.sort(d, axis=1)[:, :NEIGHBOURS_K].mean(axis=1)
    return {"k": NEIGHBOURS_K, "centre": centre.tolist(), "scale": scale.tolist(),
            "points": np.round(z, 4).tolist(),
            "max_distance": float(np.quantile(loo, NEIGHBOURS_QUANTILE)),
            "quantile": NEIGHBOURS_QUANTILE,
            "method": "each descriptor less the sites' median over their interquartile "
                      "range; max_distance: the quantile of each site's mean distance to "
                      "its k nearest others"}


def terrain_domain(measured: list[GridSite], sources: list[str]) -> TerrainDomain | None:
    """The ground the sites stand on (the model's `terrain_domain`): each terrain
    descriptor from the lowest to the highest of the sites' (their verdicts'
    measurements.terrain), widened by DOMAIN_MARGIN of that range on either side, with the
    share of the sites that fall outside the others' domain left out one at a time; None
    when a site's verdict does not measure it (older grids: `mound recon terrain-domain`
    adds it to a model from grids remeasured or drawn as its training grids were)."""
    from mound.recon.model_file import TERRAIN_DESCRIPTORS

    if not measured or any(r.ground is None for r in measured):
        return None
    if any(name not in (r.ground or {}) for r in measured for name in TERRAIN_DESCRIPTORS):
        return None
    x = np.array([[float((r.ground or {})[n]) for n in TERRAIN_DESCRIPTORS] for r in measured])

    def bounds(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = v.min(axis=0), v.max(axis=0)
        return lo - DOMAIN_MARGIN * (hi - lo), hi + DOMAIN_MARGIN * (hi - lo)

    lo, hi = bounds(x)
    left_out = 0
    for k in range(len(x) if len(x) > 1 else 0):
        a, b = bounds(np.delete(x, k, axis=0))
        left_out += bool(((x[k] < a) | (x[k] > b)).any())
    neighbours: NeighboursPart = ({"neighbours": terrain_neighbours(x)}
                                  if len(x) > 2 * NEIGHBOURS_K else {})
    return {"ranges": {n: [float(lo[i]), float(hi[i])]
                       for i, n in enumerate(TERRAIN_DESCRIPTORS)},
            **neighbours,
            "sites": len(measured), "grids": sources, "margin": DOMAIN_MARGIN,
            "outside_left_out": left_out / len(x) if len(x) > 1 else None,
            "method": "each descriptor's lowest to highest over the sites, widened by "
                      "margin x that range on either side; outside_left_out: the share of "
                      "the sites outside the domain of the others"}
