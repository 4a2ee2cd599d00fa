"""The verdict model judged on held-out grids (`evaluate`): accuracy, false alarms and
misses by class, kind and profile; reliability, Brier score and ECE; the goal's subsets;
the old hand-set rule on the same sites; the detection limit; the two looks; the three
answers (verdict_band.py); and the paper's test beside it (`paper_agreement`)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Literal, NotRequired, TypedDict

import numpy as np

from mound.classify.metrics import (
    clopper_pearson,
    ece_consistency,
    expected_calibration_error,
    reliability,
    roc_auc,
)
from mound.errors import InputError
from mound.formats.verdict import VerdictFile
from mound.jsonio import JsonObject
from mound.recon.grid_site import GridSite
from mound.recon.model_file import VerdictModel, outside_terrain
from mound.recon.verdict_band import ThreeAnswers, three_answers
from mound.sim import terrain
from mound.training.verdict_data import (
    CLEAR_OF_GROUND,
    DIAMETER_BINS,
    GROUND_CLASSES,
    HEIGHT_BINS,
    goal_tumulus,
    load_grid,
    site_terrain,
    stands_clear,
)
from mound.training.verdict_fit import check_candidates, probability
from mound.training.verdict_second import second_look_p

OPERATING_THRESHOLDS = (0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95)


class GroundRate(TypedDict):
    """The goal's tumuli standing clear of their ground or masked by it (masked ones listed
    with their relief)."""
    sites: int
    right: int
    rate: float | None
    rate_95ci: list[float] | None
    tumuli: NotRequired[list[dict[str, str | float | bool]]]


class ByGround(TypedDict):
    clear_of_ground: float
    clear: GroundRate
    masked: GroundRate
    relief_unknown: int


class GoalMounds(TypedDict):
    sites: int
    right: int
    rate: float | None
    rate_95ci: list[float] | None
    by_ground: ByGround
    old_rule_rate: NotRequired[float | None]


class GoalNoMound(TypedDict):
    sites: int
    false_alarms: int
    rate: float | None
    rate_95ci: list[float] | None


class GoalRates(TypedDict):
    goal_mounds_2m_15m: GoalMounds
    goal_no_mound: GoalNoMound


class WiderThanScan(TypedDict):
    sites: int
    right: int
    coverage_warned: int
    beyond_the_cloud: int
    beyond_the_cloud_warned: int


class GroupCounts(TypedDict):
    sites: int
    right: int
    old_rule_right: int


class OperatingPoint(TypedDict):
    threshold: float
    mounds_2m_15m_found: int
    false_alarms: int
    mounds_found: int


class DetectionBin(TypedDict):
    height_m: list[float]
    diameter_m: list[float]
    mounds: int
    detected: int


class DetectionCorner(TypedDict):
    height_m_at_least: float
    diameter_m_at_least: float
    mounds: int
    detected: int


class DetectionLimit(TypedDict):
    table: list[DetectionBin]
    limit: list[DetectionCorner] | None


class SiteError(TypedDict):
    dir: str
    truth: JsonObject
    p_mound: float


class TwoLookError(SiteError):
    second_look: bool


class SecondLookRow(TypedDict):
    dir: str
    mound: bool
    p_first: float
    p_second: float
    label: bool


class TwoLooks(GoalRates):
    """The verdict with the second look (two_looks)."""
    p_low: float
    threshold: float
    band: int
    flown: int
    not_flown: list[str]
    accuracy: float
    ece: float
    calibration: dict[str, float]
    second_looks: list[SecondLookRow]
    errors: list[TwoLookError]


class PaperRow(TypedDict):
    dir: str
    truth: bool
    kind: str
    paper: str
    learned: str


PaperCount = Literal["sites", "judged", "agree", "paper_right", "learned_right",
                     "paper_false_alarms", "paper_missed", "paper_failed"]


class PaperAgreement(TypedDict):
    """The paper's test beside the learned verdict (paper_agreement)."""
    sites: int
    paper_failed: int
    agree: int
    paper_right: int
    learned_right: int
    judged: int
    paper_false_alarms: int
    paper_missed: int
    rows: list[PaperRow]


class GridReport(TypedDict):
    """One grid's figures in eval-verdict's per_grid."""
    grid: str
    label: str
    model: str | None
    detection_limit: DetectionLimit
    goal_no_mound: GoalNoMound
    goal_mounds_2m_15m: GoalMounds
    auc: float
    ece: float


class VerdictReport(GoalRates):
    """The held-out report of a verdict model (evaluate); eval-verdict adds the paper's
    test and the grids one by one."""
    sites: int
    measured: int
    failed: list[str]
    threshold: float
    accuracy: float
    old_rule_accuracy: float
    false_alarm_rate: float | None
    missed_rate: float | None
    old_rule_false_alarm_rate: float | None
    old_rule_missed_rate: float | None
    wider_than_scan: WiderThanScan
    auc: float
    brier: float
    ece: float
    calibration: dict[str, float]
    reliability: list[dict[str, float | None]]
    per_group: dict[str, GroupCounts]
    operating_points: list[OperatingPoint]
    detection_limit: DetectionLimit
    errors: list[SiteError]
    two_looks: NotRequired[TwoLooks]
    three_answers: NotRequired[ThreeAnswers]
    paper_agreement: NotRequired[PaperAgreement]
    per_grid: NotRequired[list[GridReport]]



def _old_rule(r: GridSite) -> bool:
    """The paper's fixed rule on the verdict's chosen rise."""
    q = r.rise
    return bool(q and q.height_m is not None and q.height_m >= 1.0
                and q.base_diameter_m is not None and q.base_diameter_m >= 8.0
                and q.roundness is not None and q.roundness >= 0.6
                and q.dome_r2 is not None and q.dome_r2 >= 0.6)


def _radius(site: GridSite) -> float:
    """The scanned site's radius (its verdict's; inf when it names none)."""
    return math.inf if site.site_radius_m is None else site.site_radius_m


def _rate(flags: list[bool]) -> float | None:
    return float(np.mean(flags)) if flags else None


def _interval(k: int, n: int) -> list[float] | None:
    """The rate's exact 95 % interval (Clopper-Pearson); None over no site."""
    return list(clopper_pearson(k, n)) if n else None


def _goal_rates(lab: np.ndarray, big: list[int], neg: list[int],
                rows: list[GridSite]) -> GoalRates:
    """The issue's goals under labels `lab`: the goal's tumuli (`big`) found and the sites
    without a mound (`neg`) called one, each with its exact 95 % interval; and the goal's
    tumuli apart for those that stand clear of their ground and those it masks
    (`stands_clear`), the masked ones listed with their relief."""
    right, fa = int(sum(lab[k] for k in big)), int(sum(lab[k] for k in neg))

    def ground(want: bool) -> GroundRate:
        idx = [k for k in big if stands_clear(rows[k].relief) is want]
        found = int(sum(lab[k] for k in idx))
        out: GroundRate = {"sites": len(idx), "right": found,
                           "rate": _rate([bool(lab[k]) for k in idx]),
                           "rate_95ci": _interval(found, len(idx))}
        if not want:
            out["tumuli"] = [{"dir": rows[k].dir, **(rows[k].relief or {}),
                              "found": bool(lab[k])} for k in idx]
        return out

    classes = dict(GROUND_CLASSES)
    by_ground: ByGround = {
        "clear_of_ground": CLEAR_OF_GROUND, "clear": ground(classes["clear"]),
        "masked": ground(classes["masked"]),
        "relief_unknown": sum(1 for k in big if stands_clear(rows[k].relief) is None)}
    return {"goal_mounds_2m_15m": {"sites": len(big), "right": right,
                                   "rate": _rate([bool(lab[k]) for k in big]),
                                   "rate_95ci": _interval(right, len(big)),
                                   "by_ground": by_ground},
            "goal_no_mound": {"sites": len(neg), "false_alarms": fa,
                              "rate": _rate([bool(lab[k]) for k in neg]),
                              "rate_95ci": _interval(fa, len(neg))}}


def _outside(model: VerdictModel, measured: list[GridSite]) -> np.ndarray | None:
    """The sites whose ground lies outside the model's terrain domain (None: the model has
    none); a site whose verdict did not measure its ground is an error (remeasure it)."""
    if not model.terrain_ranges:
        return None
    missing = [r.where for r in measured if r.ground is None]
    if missing:
        raise InputError(f"{missing[0]}: the verdict does not measure the site's terrain, "
                         "and the model has a terrain_domain (mound sim grid --remeasure)")
    out = []
    for r in measured:
        try:
            out.append(bool(outside_terrain(model, r.ground or {})))
        except InputError as e:
            raise InputError(f"{r.where}/verdict.json: {e}") from None
    return np.array(out)


def _site_bands(model: VerdictModel, measured: list[GridSite]
                ) -> tuple[np.ndarray, np.ndarray] | None:
    """Each site's undecided band by its measured slope (None: the model has one band)."""
    if not model.slope_bands:
        return None
    bands = np.array([model.band_for((r.ground or {}).get("site_slope_rad"))
                      for r in measured], dtype=float).reshape(-1, 2)
    return bands[:, 0], bands[:, 1]


def evaluate(model: VerdictModel, rows: list[GridSite]) -> VerdictReport:
    measured = [r for r in rows if r.measured]
    check_candidates(model, measured)
    p = probability(model, [r.rises for r in measured])
    thr = model.threshold
    y = np.array([r.truth.mound for r in measured])
    lab = p >= thr
    old = np.array([_old_rule(r) for r in measured])
    groups: dict[str, list[int]] = {}
    for k, r in enumerate(measured):
        t = r.truth
        key = f"tumulus/{t.profile}" if t.mound else f"no mound/{t.kind}"
        groups.setdefault(key, []).append(k)
    per: dict[str, GroupCounts] = {}
    for key, idx in sorted(groups.items()):
        per[key] = {"sites": len(idx), "right": int(sum(lab[i] == y[i] for i in idx)),
                    "old_rule_right": int(sum(old[i] == y[i] for i in idx))}
    big = [k for k, r in enumerate(measured) if goal_tumulus(r.truth)]
    neg = [k for k in range(len(measured)) if not y[k]]
    clipped = [k for k in big if measured[k].coverage == "clipped"]
    wider = [k for k in big if measured[k].truth.diameter_m > 60]
    beyond = [k for k in wider if measured[k].truth.reach_m > _radius(measured[k])]
    goal = _goal_rates(lab, big, neg, measured)
    goal["goal_mounds_2m_15m"]["old_rule_rate"] = _rate([bool(old[k]) for k in big])
    report: VerdictReport = {
        "sites": len(rows), "measured": len(measured),
        "failed": [r.dir for r in rows if not r.measured],
        "threshold": thr,
        "accuracy": float(np.mean(lab == y)), "old_rule_accuracy": float(np.mean(old == y)),
        "false_alarm_rate": _rate([bool(lab[k]) for k in neg]),
        "missed_rate": _rate([not lab[k] for k in range(len(y)) if y[k]]),
        "old_rule_false_alarm_rate": _rate([bool(old[k]) for k in neg]),
        "old_rule_missed_rate": _rate([not old[k] for k in range(len(y)) if y[k]]),
        **goal,
        "wider_than_scan": {"sites": len(wider), "right": int(sum(lab[k] for k in wider)),
                            "coverage_warned": int(sum(1 for k in wider if k in clipped)),
                            "beyond_the_cloud": len(beyond),
                            "beyond_the_cloud_warned": int(sum(1 for k in beyond
                                                               if k in clipped))},
        "auc": roc_auc(p, y.astype(float)),
        "brier": float(np.mean((p - y) ** 2)),
        "ece": expected_calibration_error(p, y.astype(float)),
        # the ECE beside what a calibrated forecast would show on these sites by chance
        "calibration": ece_consistency(p, y.astype(float)),
        "reliability": [{k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                         for k, v in r.items()} for r in reliability(p, y.astype(float))],
        "per_group": per,
        # what another threshold would give: the goal's mounds found, the false alarms
        "operating_points": [
            {"threshold": t, "mounds_2m_15m_found": int(sum(p[k] >= t for k in big)),
             "false_alarms": int(sum(p[k] >= t for k in neg)),
             "mounds_found": int(sum(p[k] >= t for k in range(len(y)) if y[k]))}
            for t in OPERATING_THRESHOLDS],
        "detection_limit": detection_limit(measured, lab),
        "errors": [{"dir": measured[k].dir, "truth": measured[k].truth.to_doc(),
                    "p_mound": float(p[k])} for k in range(len(y)) if lab[k] != y[k]],
    }
    if model.second_look:
        report["two_looks"] = two_looks(model, measured, p, big, neg)
    if model.undecided:
        report["three_answers"] = three_answers(
            p, measured, model.undecided, thr, _outside(model, measured),
            _site_bands(model, measured))
    return report


def two_looks(model: VerdictModel, measured: list[GridSite], p: np.ndarray,
              big: list[int], neg: list[int]) -> TwoLooks:
    """The verdict with the second look: each site whose first p lies in [p_low, threshold)
    decided by its second flight (NNNN/second/), at the second look's calibration and
    threshold; a site in the band without one keeps its first verdict (`not_flown`)."""
    sl = model.second_look
    if sl is None:
        raise ValueError("two_looks: the model has no second look")
    thr = model.threshold
    y = np.array([r.truth.mound for r in measured])
    final_p, lab = p.copy(), p >= thr
    band = [k for k in range(len(p)) if sl.p_low <= p[k] < thr]
    flown = [k for k in band if measured[k].second is not None]
    if flown:
        p2 = second_look_p(model, p[flown],
                           probability(model, [measured[k].second or () for k in flown]))
        for k, q in zip(flown, p2, strict=True):
            final_p[k], lab[k] = q, q >= sl.threshold
    return {"p_low": sl.p_low, "threshold": sl.threshold,
            "band": len(band), "flown": len(flown),
            "not_flown": [measured[k].dir for k in band if k not in flown],
            **_goal_rates(lab, big, neg, measured),
            "accuracy": float(np.mean(lab == y)),
            "ece": expected_calibration_error(final_p, y.astype(float)),
            "calibration": ece_consistency(final_p, y.astype(float)),
            "second_looks": [{"dir": measured[k].dir, "mound": bool(y[k]),
                              "p_first": float(p[k]), "p_second": float(final_p[k]),
                              "label": bool(lab[k])} for k in flown],
            "errors": [{"dir": measured[k].dir, "truth": measured[k].truth.to_doc(),
                        "p_mound": float(final_p[k]), "second_look": k in flown}
                       for k in range(len(y)) if lab[k] != y[k]]}


def paper_agreement(folder: str | Path, model: VerdictModel, work: str | Path,
                    limit: int | None = None) -> PaperAgreement:
    """The paper's test (`mound_recon verdict --reference`) beside the learned verdict on the
    sites of a grid. The reference is what a tumulus there should look like: the site's own
    ground (same seed, slope or DEM patch; no confuser) with its own tumulus, or, on a site
    without one, a 40 m x 6 m spherical cap at the centre (the paper compared its flat
    control with the tumulus's reference). Returns both labels per site and their
    agreement."""
    from dataclasses import replace

    from mound import native
    from mound.errors import ToolNoResultError
    from mound.ply import write_ply

    root, out = Path(folder), Path(work)
    out.mkdir(parents=True, exist_ok=True)
    if not (root / "grid.json").is_file():
        raise InputError(f"{root}: no grid.json (--paper judges a finished grid)")
    rows = load_grid(root)
    check_candidates(model, [r for r in rows if r.measured])
    p = probability(model, [r.rises for r in rows])
    sites: list[PaperRow] = []
    for row, q in zip(rows, p, strict=True):
        if not row.measured or (limit is not None and len(sites) >= limit):
            continue
        spec = site_terrain(row, f"{root / 'grid.json'}: {row.dir}")
        if not spec.mound:
            spec = replace(spec, mound=True, profile="spherical_cap", diameter_m=40.0,
                           height_m=6.0, mound_x_m=0.0, mound_y_m=0.0, erosion_m=2.0)
        hf = terrain.build(replace(spec, resolution_m=1.0))
        ref = out / f"{row.dir}_reference.ply"
        write_ply(ref, hf.points(), None, comment="mound.reference v1 (grid paper test)")
        res = out / f"{row.dir}_paper.json"
        try:
            native.run_tool("mound_recon", ["verdict", str(root / row.dir / "recon"),
                                            "--reference", str(ref), "--out", str(res)], 600)
        except ToolNoResultError:
            pass
        paper = VerdictFile.read(res).label
        sites.append({"dir": row.dir, "truth": row.truth.mound,
                      "kind": row.truth.kind, "paper": paper,
                      "learned": "mound" if q >= model.threshold else "no_mound"})
        ref.unlink()
    judged = [s for s in sites if s["paper"] != "failed"]
    return {
        "sites": len(sites), "paper_failed": len(sites) - len(judged),
        "agree": sum(1 for s in judged if s["paper"] == s["learned"]),
        "paper_right": sum(1 for s in judged if (s["paper"] == "mound") == s["truth"]),
        "learned_right": sum(1 for s in judged if (s["learned"] == "mound") == s["truth"]),
        "judged": len(judged),
        "paper_false_alarms": sum(1 for s in judged if s["paper"] == "mound" and not s["truth"]),
        "paper_missed": sum(1 for s in judged if s["paper"] != "mound" and s["truth"]),
        "rows": sites}


def detection_limit(rows: list[GridSite], lab: np.ndarray) -> DetectionLimit:
    """Detection rate of the mounds per height x diameter bin, and the detection limit: the
    smallest (height, diameter) from which on the mounds are detected at >= 95 %."""
    table: list[DetectionBin] = []
    for i in range(len(HEIGHT_BINS) - 1):
        for j in range(len(DIAMETER_BINS) - 1):
            idx = [k for k, r in enumerate(rows) if r.truth.mound
                   and HEIGHT_BINS[i] <= r.truth.height_m < HEIGHT_BINS[i + 1]
                   and DIAMETER_BINS[j] <= r.truth.diameter_m < DIAMETER_BINS[j + 1]]
            table.append({"height_m": [HEIGHT_BINS[i], HEIGHT_BINS[i + 1]],
                          "diameter_m": [DIAMETER_BINS[j], DIAMETER_BINS[j + 1]],
                          "mounds": len(idx), "detected": int(sum(lab[k] for k in idx))})
    # corners (h, d): the mounds at least h high and d across; those detected at >= 95 %
    # (at least 5 mounds), and of them the ones no other such corner lies below and left of
    corners: list[DetectionCorner] = []
    for h in HEIGHT_BINS[:-1]:
        for d in DIAMETER_BINS[:-1]:
            idx = [k for k, r in enumerate(rows) if r.truth.mound
                   and r.truth.height_m >= h and r.truth.diameter_m >= d]
            if len(idx) >= 5 and sum(lab[k] for k in idx) / len(idx) >= 0.95:
                corners.append({"height_m_at_least": h, "diameter_m_at_least": d,
                                "mounds": len(idx), "detected": int(sum(lab[k] for k in idx))})
    limit = [c for c in corners if not any(
        o is not c and o["height_m_at_least"] <= c["height_m_at_least"]
        and o["diameter_m_at_least"] <= c["diameter_m_at_least"] for o in corners)] or None
    return {"table": table, "limit": limit}
