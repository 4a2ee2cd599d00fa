"""Three answers: "mound", "no_mound" or "undecided" (issue 56).

A confident wrong answer is the costly one: a tumulus called "no mound" is never visited
again, a false alarm sends a dig team to a terrace. The model's calibrated p decides where
it is far from doubt; in between, the band [p_low, p_high) of the model file's
`undecided`, the site is undecided and goes to a second look or a person.

The band is chosen on the training sites' out-of-fold p (`choose_band`): p_low the highest
p below which at most BAND_MISS of the band's tumuli (at least GOAL_HEIGHT_M high and
GOAL_ACROSS_M across) lie, p_high the lowest p from which at most BAND_FA of the sites
without a tumulus lie (every ground, every confuser). The goals on new ground are
MAX_MISS and MAX_FA; the band is chosen for BAND_SHARE of them, a margin for ground the
training sites do not hold. Where the two bounds cross (p_low > p_high) there is nothing
to leave undecided and the band shrinks to the point between them nearest the model's
threshold. Its figures are nested (`nested_band`): each fold of the sites labelled by the
band chosen on the others.

Bands by the site's slope (issue 68): a p from steep ground is less sure than one from
gentle ground, and one band over both is as wide as the steep sites need everywhere (on
the training grids with a steep grid, 60 % of the sites undecided out of fold, against
33 % with two bands). `slope_bands` splits the sites at the measured site slope (candidates
every SLOPE_STEP_DEG degrees, each side holding at least MIN_STRATUM goal tumuli and as
many sites without one) whose two bands, each chosen on its own sites as above, leave the
fewest sites undecided out of fold (nested) without more confident misses or false alarms
out of fold than the one band, to within one site; kept only when that beats the one band.

On held-out sites `three_answers` reports the confident wrong answers, the undecided share
and whether the band is calibrated (the share of tumuli among the undecided sites beside
their mean p), each rate with its exact 95 % interval; and, per height class of the
tumuli, the share confirmed "mound" beside the two-answer verdict's (`field_recall`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from typing import Literal, NotRequired, TypedDict, get_args

import numpy as np

from mound.classify.metrics import clopper_pearson
from mound.recon.grid_site import GridSite, SiteTruth
from mound.recon.model_file import band_at

GOAL_HEIGHT_M = 1.0
GOAL_ACROSS_M = 10.0
MAX_MISS = 0.01        # of the goal's tumuli called no_mound
MAX_FA = 0.005         # of the sites without a tumulus called mound
MAX_UNDECIDED = 0.10   # of all sites
BAND_SHARE = 0.5       # the band is chosen for this share of MAX_MISS and MAX_FA
BAND_FOLDS = 5
BAND_FOLD_SEED = 11
SLOPE_STEP_DEG = 2.0   # the candidate splits between two slope bands: 4, 6, ... 30 degrees
SLOPE_SPLITS_DEG = tuple(4.0 + SLOPE_STEP_DEG * k for k in range(14))
MIN_STRATUM = 20       # goal tumuli and sites without a tumulus on each side, at least
HEIGHT_CLASSES = (0.0, 0.5, 1.0, 2.0, 5.0, math.inf)  # m: < 0.5, 0.5-1, 1-2, 2-5, >= 5

NO, UNDECIDED, MOUND = 0, 1, 2
NAMES = ("no_mound", "undecided", "mound")
# the order of a confusion's rates (confusion_doc, mound.recon.visit_value)
ANSWERS = (NAMES[MOUND], NAMES[UNDECIDED], NAMES[NO])


class Rate(TypedDict):
    """k of n with its exact 95 % interval (None over no site)."""
    count: int
    of: int
    rate: float | None
    rate_95ci: list[float] | None


class GoalRate(Rate):
    goal: float
    of_what: str


class MissRate(GoalRate):
    sites: list[str]


class UndecidedRate(Rate):
    goal: float
    tumuli: int
    tumulus_share: float | None
    tumulus_share_95ci: list[float] | None
    mean_p: float | None


class BandErrors(TypedDict):
    """Confident misses, confident false alarms and undecided sites (a split's mean)."""
    confident_misses: float
    confident_false_alarms: float
    undecided: float


class NestedFigures(TypedDict):
    """A band's figures out of fold (nested_band)."""
    folds: int
    confident_misses: float
    goal_tumuli: int
    confident_false_alarms: float
    negatives: int
    undecided: float
    sites: int


class SlopeBand(TypedDict):
    site_slope_rad: list[float]
    p_low: float
    p_high: float
    sites: int
    out_of_fold: NestedFigures


class SlopeSplitFigures(BandErrors):
    sites: int
    one_band: BandErrors


class SlopeBands(TypedDict):
    """Two bands split at a site slope (slope_bands)."""
    bands: list[SlopeBand]
    out_of_fold: SlopeSplitFigures
    method: str


class BandAtSlope(TypedDict):
    """One of the model file's `undecided.by_slope`."""
    site_slope_rad: list[float]
    p_low: float
    p_high: float


class BandGoals(TypedDict):
    max_miss: float
    max_false_alarm: float
    max_undecided: float
    chosen_for_share: float
    goal_tumuli: str


class BandTrained(TypedDict):
    goals: BandGoals
    out_of_fold: NestedFigures
    selected_in_sample: BandErrors
    method: str
    by_slope: NotRequired[SlopeBands]


class BandDoc(TypedDict):
    """The model file's `undecided` (band_doc)."""
    p_low: float
    p_high: float
    by_slope: NotRequired[list[BandAtSlope]]
    trained: BandTrained


class ConfusionDoc(TypedDict):
    """The three answers' rates per height class of tumulus and for a site without one."""
    tumulus: dict[str, list[float]]
    tumuli: dict[str, int]
    none: list[float] | None
    sites_without: int
    answers: list[str]
    method: str


class RecallRow(TypedDict):
    tumuli: int
    confirmed: Rate
    undecided: Rate
    no_mound: Rate
    two_answer_mound: Rate


class RecallPart(TypedDict):
    all: RecallRow
    by_height: dict[str, RecallRow]


RecallShare = Literal["confirmed", "undecided", "no_mound", "two_answer_mound"]
RECALL_SHARES: tuple[RecallShare, ...] = get_args(RecallShare)


class FrontierBest(TypedDict):
    band: list[float]
    confident_misses: float
    confident_false_alarms: float
    times_the_goals: float


class Frontier(TypedDict):
    """What any band could do on the judged sites (frontier)."""
    band_at_goals: list[float]
    undecided_at_goals: float
    at_most_undecided: float
    best_within_undecided: FrontierBest | None
    goals_reachable: bool
    note: str


class TerrainRates(TypedDict):
    sites: int
    confident_misses: Rate
    confident_false_alarms: Rate
    undecided: Rate
    confirmed_2m: Rate


class OutsideDomain(TypedDict):
    outside: int
    tumuli_outside: int
    sites_outside: list[str]
    would_be: dict[str, int]


class TerrainPart(TypedDict, total=False):
    terrain: OutsideDomain
    frontier_inside_domain: Frontier


class Decided(TypedDict):
    sites: int
    wrong: int


class ThreeAnswers(TerrainPart):
    """The three answers' figures on held-out sites (three_answers)."""
    band: list[float]
    band_by_slope: bool
    sites: int
    confident_misses: MissRate
    confident_false_alarms: GoalRate
    undecided: UndecidedRate
    decided: Decided
    field_recall: dict[str, RecallPart]
    by_terrain: dict[str, TerrainRates]
    frontier: Frontier



def band_goal(truth: SiteTruth) -> bool:
    """A tumulus the band must not call "no_mound": >= 1 m high and >= 10 m across."""
    return truth.mound and truth.height_m >= GOAL_HEIGHT_M and truth.diameter_m >= GOAL_ACROSS_M


def choose_band(p: np.ndarray, y: np.ndarray, goal: np.ndarray, threshold: float,
                miss: float = MAX_MISS * BAND_SHARE,
                fa: float = MAX_FA * BAND_SHARE) -> tuple[float, float]:
    """(p_low, p_high) from p (splits x sites, or sites) of sites whose truth is `y` and
    which `goal` marks (see the module text)."""
    p = np.atleast_2d(p)
    pos = np.sort(p[:, goal].ravel())
    neg = np.sort(p[:, ~y].ravel())[::-1]
    k = int(math.floor(miss * len(pos) + 1e-9))  # confident misses allowed, pooled
    p_low = float(pos[k]) if k < len(pos) else 1.0
    j = int(math.floor(fa * len(neg) + 1e-9))
    p_high = float(np.nextafter(neg[j], 1.0)) if j < len(neg) else 0.0
    p_low = min(max(p_low, 1e-6), 1 - 1e-6)
    p_high = min(max(p_high, 1e-6), 1 - 1e-6)
    if p_low > p_high:  # nothing to leave undecided
        t = min(max(threshold, p_high), p_low)
        return t, t
    return p_low, p_high


def answers(p: np.ndarray, band: tuple[float, float] | tuple[np.ndarray, np.ndarray]
            ) -> np.ndarray:
    """NO, UNDECIDED or MOUND for each p (the band one for all, or one per site)."""
    lo, hi = band
    return np.where(p >= hi, MOUND, np.where(p < lo, NO, UNDECIDED))


def _rate(k: int, n: int) -> Rate:
    return {"count": k, "of": n, "rate": k / n if n else None,
            "rate_95ci": list(clopper_pearson(k, n)) if n else None}


def _errors(nested: list[NestedFigures]) -> BandErrors:
    """The confident misses, false alarms and undecided sites summed over `nested`."""
    return {"confident_misses": float(sum(n["confident_misses"] for n in nested)),
            "confident_false_alarms": float(sum(n["confident_false_alarms"] for n in nested)),
            "undecided": float(sum(n["undecided"] for n in nested))}


def nested_band(p: np.ndarray, y: np.ndarray, goal: np.ndarray,
                threshold: float) -> NestedFigures:
    """The band's figures out of fold: the sites in BAND_FOLDS folds, each labelled by the
    band chosen on the others (p: splits x sites, the counts a split's mean)."""
    p = np.atleast_2d(p)
    fold = np.random.default_rng(BAND_FOLD_SEED).permutation(p.shape[1]) % BAND_FOLDS
    lab = np.zeros(p.shape, dtype=int)
    for k in range(BAND_FOLDS):
        out = fold == k
        band = choose_band(p[:, ~out], y[~out], goal[~out], threshold)
        lab[:, out] = answers(p[:, out], band)
    reps = len(p)
    return {"folds": BAND_FOLDS,
            "confident_misses": float((lab[:, goal] == NO).sum() / reps),
            "goal_tumuli": int(goal.sum()),
            "confident_false_alarms": float((lab[:, ~y] == MOUND).sum() / reps),
            "negatives": int((~y).sum()),
            "undecided": float((lab == UNDECIDED).sum() / reps), "sites": int(p.shape[1])}


def slope_bands(p: np.ndarray, y: np.ndarray, goal: np.ndarray, threshold: float,
                slope: np.ndarray) -> SlopeBands | None:
    """Two bands split at a site slope (see the module text): the model file's
    `undecided.by_slope` and their nested figures, or None when no split leaves fewer sites
    undecided out of fold than one band (or a site's slope is unknown)."""
    p = np.atleast_2d(p)
    if not np.isfinite(slope).all():
        return None
    one = nested_band(p, y, goal, threshold)
    best: tuple[float, float, np.ndarray, list[NestedFigures]] | None = None
    for deg in SLOPE_SPLITS_DEG:
        s = math.radians(deg)
        low = slope < s
        if min(int(goal[low].sum()), int(goal[~low].sum()), int((~y[low]).sum()),
               int((~y[~low]).sum())) < MIN_STRATUM:
            continue
        nested = [nested_band(p[:, m], y[m], goal[m], threshold) for m in (low, ~low)]
        und = sum(n["undecided"] for n in nested)
        # no more confident errors than one band, to within one site (their resolution)
        if (sum(n["confident_misses"] for n in nested) > one["confident_misses"] + 1
                or sum(n["confident_false_alarms"] for n in nested)
                > one["confident_false_alarms"] + 1):
            continue
        if best is None or und < best[0]:
            best = (und, s, low, nested)
    if best is None or best[0] >= one["undecided"]:
        return None
    und, s, low, nested = best
    bands: list[SlopeBand] = []
    for m, (a, b), n in zip((low, ~low), ((-math.pi / 2, s), (s, math.pi / 2)), nested,
                            strict=True):
        lo, hi = choose_band(p[:, m], y[m], goal[m], threshold)
        bands.append({"site_slope_rad": [a, b], "p_low": lo, "p_high": hi,
                      "sites": int(m.sum()), "out_of_fold": n})
    return {"bands": bands,
            "out_of_fold": {**_errors(nested), "sites": int(p.shape[1]),
                            "one_band": _errors([one])},
            "method": f"the split among {SLOPE_SPLITS_DEG[0]:g}-{SLOPE_SPLITS_DEG[-1]:g} "
                      f"degrees (every {SLOPE_STEP_DEG:g}) whose two bands leave the fewest "
                      "sites undecided out of fold with no more confident misses or false "
                      "alarms than one band (to within one site), each band chosen on its "
                      "side's sites; "
                      "the split chosen on every site (its nested figures a little "
                      "optimistic)"}


def band_doc(p: np.ndarray, y: np.ndarray, goal: np.ndarray,
             threshold: float, slope: np.ndarray | None = None) -> BandDoc:
    """The model file's `undecided`: the band chosen on every site, with its nested and
    in-sample figures; with the sites' measured slope, two bands by slope when they
    leave fewer sites undecided (`by_slope`, slope_bands)."""
    lo, hi = choose_band(p, y, goal, threshold)
    lab = answers(np.atleast_2d(p), (lo, hi))
    reps = len(lab)
    split = slope_bands(p, y, goal, threshold, slope) if slope is not None else None
    trained: BandTrained = {
                "goals": {"max_miss": MAX_MISS, "max_false_alarm": MAX_FA,
                          "max_undecided": MAX_UNDECIDED, "chosen_for_share": BAND_SHARE,
                          "goal_tumuli": f">= {GOAL_HEIGHT_M:g} m high, >= "
                                         f"{GOAL_ACROSS_M:g} m across"},
                "out_of_fold": nested_band(p, y, goal, threshold),
                "selected_in_sample": {
                    "confident_misses": float((lab[:, goal] == NO).sum() / reps),
                    "confident_false_alarms": float((lab[:, ~y] == MOUND).sum() / reps),
                    "undecided": float((lab == UNDECIDED).sum() / reps)},
                "method": "p_low, p_high from the out-of-fold p of the training sites (every "
                          "CV split; sites without a rise at p_no_rise); out_of_fold: each "
                          f"of {BAND_FOLDS} folds labelled by the band chosen on the others"}
    if not split:
        return {"p_low": lo, "p_high": hi, "trained": trained}
    trained["by_slope"] = split
    by_slope: list[BandAtSlope] = [
        {"site_slope_rad": b["site_slope_rad"], "p_low": b["p_low"], "p_high": b["p_high"]}
        for b in split["bands"]]
    return {"p_low": lo, "p_high": hi, "by_slope": by_slope, "trained": trained}


def confusion_doc(p: np.ndarray, truths: Sequence[SiteTruth], band: BandDoc,
                  slope: np.ndarray) -> ConfusionDoc:
    """The three answers' rates the model's band (`band`: band_doc's, by the site's
    `slope` when it has bands by slope) gives the training sites' out-of-fold p (splits x
    sites): per height class of tumulus (mound, undecided, no_mound) and for a site without
    one; what a visit is worth (mound.recon.visit_value) is read from it."""
    one = (float(band["p_low"]), float(band["p_high"]))
    by = tuple((b["site_slope_rad"][0], b["site_slope_rad"][1], b["p_low"], b["p_high"])
               for b in band.get("by_slope", []))
    site = np.array([band_at(one, by, float(s)) for s in slope], dtype=float).reshape(-1, 2)
    lab = answers(np.atleast_2d(p), (site[:, 0], site[:, 1]))

    def rates(idx: list[int]) -> list[float]:
        a = lab[:, idx].ravel()
        return [float(np.mean(a == MOUND)), float(np.mean(a == UNDECIDED)),
                float(np.mean(a == NO))]

    classes: dict[str, list[int]] = {}
    for k, t in enumerate(truths):
        if t.mound:
            classes.setdefault(height_class(t.height_m), []).append(k)
    none = [k for k, t in enumerate(truths) if not t.mound]
    return {"tumulus": {c: rates(idx) for c, idx in sorted(classes.items())},
            "tumuli": {c: len(idx) for c, idx in sorted(classes.items())},
            "none": rates(none) if none else None, "sites_without": len(none),
            "answers": list(ANSWERS),
            "method": "the chosen band (by the site's slope where the model has bands by "
                      "slope) over the training sites' out-of-fold p of every CV split"}


def height_class(h: float) -> str:
    """The name of the height class (HEIGHT_CLASSES) of a tumulus `h` m high, as the
    reports' field_recall.by_height names it ("?" below the first)."""
    for lo, hi in itertools.pairwise(HEIGHT_CLASSES):
        if lo <= h < hi:
            return f"{lo:g}-{hi:g} m" if math.isfinite(hi) else f">= {lo:g} m"
    return "?"


HEIGHT_CLASS_NAMES = tuple(height_class(lo) for lo in HEIGHT_CLASSES[:-1])


def field_recall(truths: Sequence[SiteTruth], lab3: np.ndarray,
                 lab2: np.ndarray) -> dict[str, RecallPart]:
    """Of the tumuli, the share confirmed "mound" by the three answers (and left undecided,
    and called no_mound) beside the two answers' "mound", per height class, all, and with
    and without a looters' trench or pit."""
    def row(idx: list[int]) -> RecallRow:
        n = len(idx)
        return {"tumuli": n,
                "confirmed": _rate(int(sum(lab3[k] == MOUND for k in idx)), n),
                "undecided": _rate(int(sum(lab3[k] == UNDECIDED for k in idx)), n),
                "no_mound": _rate(int(sum(lab3[k] == NO for k in idx)), n),
                "two_answer_mound": _rate(int(sum(bool(lab2[k]) for k in idx)), n)}

    tum = [k for k, t in enumerate(truths) if t.mound]
    out: dict[str, RecallPart] = {}
    for cut, name in ((None, "all"), (True, "with_trench"), (False, "without_trench")):
        sel = [k for k in tum if cut is None or truths[k].cut is cut]
        classes = {}
        for lo, hi in itertools.pairwise(HEIGHT_CLASSES):
            idx = [k for k in sel if lo <= truths[k].height_m < hi]
            classes[height_class(lo)] = row(idx)
        out[name] = {"all": row(sel), "by_height": classes}
    return out


def frontier(p: np.ndarray, y: np.ndarray, goal: np.ndarray) -> Frontier:
    """What any band could do on these very sites (chosen on them: a bound no band chosen
    elsewhere beats, not a figure for new ground): the least undecided share at which the
    confident errors meet the goals (MAX_MISS, MAX_FA), and the least confident errors
    (in multiples of the goals, the worse of the two) with at most MAX_UNDECIDED
    undecided. When the first exceeds MAX_UNDECIDED, no band meets the three goals
    together with these p: the evidence, not the band, is short."""
    lo, hi = choose_band(p, y, goal, 0.5, miss=MAX_MISS, fa=MAX_FA)
    at_goals = float((answers(p, (lo, hi)) == UNDECIDED).mean())
    ps = np.sort(p)
    cuts = np.unique(np.concatenate([ps, [np.nextafter(ps[-1], np.inf)]]))
    pos, neg = np.sort(p[goal]), np.sort(p[~y])
    allowed = int(math.floor(MAX_UNDECIDED * len(p) + 1e-9))
    best: FrontierBest | None = None
    for t_low in cuts:  # a band [t_low, t_high): the widest t_high within the allowance
        below = int(np.searchsorted(ps, t_low, side="left"))
        k = min(below + allowed, len(ps))  # sites with p < t_high are at most k
        t_high = float(ps[k]) if k < len(ps) else float(cuts[-1])
        if t_high < t_low:
            continue
        miss = int(np.searchsorted(pos, t_low, side="left"))
        fa = len(neg) - int(np.searchsorted(neg, t_high, side="left"))
        m = miss / max(len(pos), 1)
        f = fa / max(len(neg), 1)
        worse = max(m / MAX_MISS, f / MAX_FA)
        if best is None or worse < best["times_the_goals"]:
            best = {"band": [float(t_low), t_high], "confident_misses": m,
                    "confident_false_alarms": f, "times_the_goals": worse}
    return {"band_at_goals": [lo, hi], "undecided_at_goals": at_goals,
            "at_most_undecided": MAX_UNDECIDED, "best_within_undecided": best,
            "goals_reachable": at_goals <= MAX_UNDECIDED,
            "note": "chosen on the judged sites themselves: a bound, not a held-out figure"}


def three_answers(p: np.ndarray, sites: Sequence[GridSite], band: tuple[float, float],
                  threshold: float, outside: np.ndarray | None = None,
                  site_bands: tuple[np.ndarray, np.ndarray] | None = None) -> ThreeAnswers:
    """The three answers' figures on held-out sites (see the module text): p of every
    measured site, the sites (their truth), the model's band and two-answer threshold;
    `outside` (a model with a terrain domain) the sites whose ground lies outside it,
    undecided whatever their p, with `frontier_inside_domain` what any band could do on
    the others (the outside sites counted undecided); `site_bands` (a model with bands by
    slope) each site's (p_low, p_high)."""
    truths = [s.truth for s in sites]
    y = np.array([t.mound for t in truths])
    goal = np.array([band_goal(t) for t in truths])
    lab = answers(p, site_bands if site_bands is not None else band)
    terrain: TerrainPart = {}
    if outside is not None:
        inside = ~outside
        terrain = {"terrain": {
            "outside": int(outside.sum()), "tumuli_outside": int(y[outside].sum()),
            "sites_outside": [sites[k].dir for k in np.flatnonzero(outside)],
            "would_be": {name: int((lab[outside] == code).sum())
                         for name, code in (("mound", MOUND), ("no_mound", NO),
                                            ("undecided", UNDECIDED))}}}
        if inside.any():
            f = frontier(p[inside], y[inside], goal[inside])
            f["undecided_at_goals"] = float(
                (f["undecided_at_goals"] * inside.sum() + outside.sum()) / len(p))
            terrain["frontier_inside_domain"] = f
        lab = np.where(outside, UNDECIDED, lab)
    und = lab == UNDECIDED
    n_und = int(und.sum())
    return {**terrain,
        "band": list(band), "band_by_slope": site_bands is not None, "sites": len(p),
        "confident_misses": {**_rate(int((lab[goal] == NO).sum()), int(goal.sum())),
                             "goal": MAX_MISS,
                             "of_what": f"tumuli >= {GOAL_HEIGHT_M:g} m high and >= "
                                        f"{GOAL_ACROSS_M:g} m across called no_mound",
                             "sites": [sites[k].dir for k in np.flatnonzero(
                                 goal & (lab == NO))]},
        "confident_false_alarms": {**_rate(int((lab[~y] == MOUND).sum()), int((~y).sum())),
                                   "goal": MAX_FA,
                                   "of_what": "sites without a tumulus called mound"},
        "undecided": {**_rate(n_und, len(p)), "goal": MAX_UNDECIDED,
                      "tumuli": int(y[und].sum()),
                      "tumulus_share": float(y[und].mean()) if n_und else None,
                      "tumulus_share_95ci": list(clopper_pearson(int(y[und].sum()), n_und))
                      if n_und else None,
                      "mean_p": float(p[und].mean()) if n_und else None},
        "decided": {"sites": int((~und).sum()),
                    "wrong": int(((lab == MOUND) & ~y).sum() + ((lab == NO) & y).sum())},
        "field_recall": field_recall(truths, lab, p >= threshold),
        "by_terrain": by_terrain(truths, lab),
        "frontier": frontier(p, y, goal),
    }


def by_terrain(truths: Sequence[SiteTruth], lab: np.ndarray) -> dict[str, TerrainRates]:
    """The three answers per kind of ground (SiteTruth.terrain_kind): the confident
    misses and false alarms, the undecided, and the tumuli >= 2 m high confirmed mound,
    each with its exact 95 % interval."""
    kind_of = np.array([t.terrain_kind for t in truths])
    mound = np.array([t.mound for t in truths], dtype=bool)
    goal_all = np.array([band_goal(t) for t in truths], dtype=bool)
    high_all = mound & np.array([t.height_m >= 2.0 for t in truths], dtype=bool)
    out: dict[str, TerrainRates] = {}
    for kind in sorted(set(kind_of.tolist())):
        idx = kind_of == kind
        goal, high, neg = goal_all & idx, high_all & idx, idx & ~mound
        out[kind] = {
            "sites": int(idx.sum()),
            "confident_misses": _rate(int((lab[goal] == NO).sum()), int(goal.sum())),
            "confident_false_alarms": _rate(int((lab[neg] == MOUND).sum()), int(neg.sum())),
            "undecided": _rate(int((lab[idx] == UNDECIDED).sum()), int(idx.sum())),
            "confirmed_2m": _rate(int((lab[high] == MOUND).sum()), int(high.sum()))}
    return out


def recall_figure(three: ThreeAnswers, out: str, title: str = "") -> None:
    """The field recall (three_answers' field_recall) as bars per height class: the tumuli
    confirmed mound, left undecided and called no_mound, beside the two answers' mound
    share (a dot), with and without a looters' trench or pit."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fr = three["field_recall"]
    panels = [("all", "all tumuli"), ("with_trench", "with a looters' trench or pit"),
              ("without_trench", "without one")]
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2), sharey=True)
    for ax, (key, name) in zip(axes, panels, strict=True):
        classes = {**fr[key]["by_height"], "all": fr[key]["all"]}
        x = np.arange(len(classes))
        share = {k: np.array([(c[k]["rate"] or 0.0) for c in classes.values()])
                 for k in RECALL_SHARES}
        ax.bar(x, share["confirmed"], color="#ff7f00", label="mound")
        ax.bar(x, share["undecided"], bottom=share["confirmed"], color="#1f78b4",
               label="undecided")
        ax.bar(x, share["no_mound"], bottom=share["confirmed"] + share["undecided"],
               color="0.3", label="no mound")
        ax.plot(x, share["two_answer_mound"], "wo", mec="k", label="two answers: mound")
        for i, c in enumerate(classes.values()):
            ax.annotate(str(c["tumuli"]), (i, 1.01), ha="center", fontsize=7)
        ax.set_xticks(x, list(classes), rotation=30, fontsize=8)
        ax.set_title(name, fontsize=9)
        ax.set_ylim(0, 1.08)
    axes[0].set_ylabel("share of the tumuli (count above)")
    axes[0].legend(fontsize=7, loc="center left")
    fig.suptitle(title or "tumuli confirmed by height class", fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
