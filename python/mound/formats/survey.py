"""The survey's summary (summary.json, mound.survey v1), typed once.

`SurveySummary` is the whole document: the run's status, the field, every candidate site,
the error rates, the sites left to the field team, the stages, and what the run made (the
plan, the missions, the photo card, the learning between flights, the second looks).
`SurveySite` joins the candidate (its position, the classifier's p(mound) and reward, the
truth where known) with, when the tour visited it, its 3-D work's row (`SiteRow`), and
says what the survey concluded: the classifier's label, the verdict (its two answers, or
failed), the verdict's own answer (mound, no_mound or undecided) and the final label with
its source. `to_doc()` is summary.json's `sites[k]`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from mound.classify.metrics import says_mound
from mound.errors import InputError
from mound.formats.learn import LearnRecord
from mound.formats.mission import FlightSummary, MissionSummary
from mound.formats.photos import CardSummary
from mound.formats.plan import Plan
from mound.formats.site_row import SiteRow
from mound.formats.sites import Site
from mound.formats.verdict import ANSWERS, Verdict
from mound.geometry.geodesy import Origin
from mound.jsonio import (
    JsonObject,
    as_object,
    check_doc,
    list_member,
    load_json,
    require_choice,
    require_id,
)

SCHEMA = "mound.survey"
VERSION = 1
STATUSES = ("ok", "partial", "waiting", "failed")
# What a site's entry says was concluded: the verdict's own answer, else `failed` (visited,
# no verdict); a site not visited says nothing.
SITE_ANSWERS = (*ANSWERS, "failed")
# What the summary's `plan` copies of the plan the survey flew.
PLAN_KEYS = ("algo", "tour", "reward", "cost_m", "budget_m", "n_visited", "n_sites", "flights")

# What a site's entry copies of its row (SiteRow.to_doc()) when the site was judged, and
# in any case (the 3-D work's figures and files).
JUDGED_KEYS = ("answer", "undecided", "confidence", "verdict_p_mound", "verdict_cloud",
               "coverage", "method", "reason", "rise", "distance_m", "second_look",
               "first_look", "rasters_error", "dense_error")
WORK_KEYS = ("recon", "timings_s", "files", "source", "simulated", "worker")


@dataclass(frozen=True)
class SurveySite:
    """A candidate site, and (visited) its 3-D work's row (None: not processed)."""

    site: Site
    visited: bool
    row: SiteRow | None = None

    def __post_init__(self) -> None:
        if self.site.p_mound is None:
            raise InputError(f"sites: {self.site.id}: no p_mound (the survey's sites carry "
                             "the classifier's)")

    @property
    def id(self) -> str:
        return self.site.id

    @property
    def p_mound(self) -> float:
        assert self.site.p_mound is not None  # __post_init__
        return self.site.p_mound

    @property
    def truth(self) -> bool | None:
        return None if self.site.truth is None else self.site.truth.mound

    @property
    def classifier_label(self) -> str:
        return "mound" if says_mound(self.p_mound) else "no_mound"

    @property
    def judged_verdict(self) -> Verdict | None:
        """Its 3-D verdict, where it was visited and the verdict stands (None otherwise)."""
        row = self.row
        return row.verdict if self.visited and row is not None and row.ok else None

    @property
    def judged(self) -> bool:
        """Visited, and its 3-D verdict stands."""
        return self.judged_verdict is not None

    @property
    def verdict(self) -> str | None:
        """The 3-D verdict's two answers, `failed` (visited, no verdict), None (not
        visited)."""
        v = self.judged_verdict
        return v.two_answer if v is not None else "failed" if self.visited else None

    @property
    def answer(self) -> str | None:
        """The verdict's own answer (mound, no_mound or undecided); None without one."""
        v = self.judged_verdict
        return v.label if v is not None else None

    @property
    def final_label(self) -> str:
        return self.verdict if self.judged and self.verdict else self.classifier_label

    @property
    def label_source(self) -> str:
        if self.judged:
            return "3-D verdict"
        return "classifier (3-D stage failed)" if self.visited else "classifier"

    def undecided_reasons(self) -> list[Mapping[str, object]]:
        """The verdict's reasons for leaving the site undecided (code, text)."""
        v = self.judged_verdict
        reasons = (v.undecided or {}).get("reasons", []) if v is not None else []
        return [r for r in reasons if isinstance(r, dict)] if isinstance(reasons, list) else []

    def to_doc(self) -> JsonObject:
        s = self.site
        doc: JsonObject = {"id": s.id, "x_m": s.x_m, "y_m": s.y_m,
                           "p_mound": self.p_mound, "reward": s.reward,
                           "visited": self.visited}
        if self.truth is not None:
            doc["truth"] = self.truth
        doc["classifier_label"] = self.classifier_label
        if not self.visited:
            return {**doc, "final_label": self.final_label, "label_source": self.label_source}
        row = self.row or SiteRow(s.id, "", reason="not processed")
        result = row.to_doc()
        doc["verdict"] = self.verdict
        if self.judged:
            doc.update(final_label=self.final_label, label_source=self.label_source)
            doc.update({k: result[k] for k in JUDGED_KEYS if k in result})
        else:
            doc.update(failure=row.reason or "?", final_label=self.final_label,
                       label_source=self.label_source)
        doc.update({k: result[k] for k in WORK_KEYS if k in result})
        return doc


@dataclass(frozen=True)
class StageRun:
    """A stage as this invocation met it (summary.json's stages[k]): run, with its wall time
    and whether it completed, or skipped (unchanged, or not needed), with the time it took
    when it ran."""

    name: str
    wall_s: float
    skipped: bool
    note: str = ""
    complete: bool | None = None  # run: whether every unit of its work finished
    wall_s_when_run: float | None = None  # skipped: the ledger's time of it

    def to_doc(self) -> JsonObject:
        if self.skipped:
            when = ({} if self.wall_s_when_run is None  # not needed: never ran
                    else {"wall_s_when_run": self.wall_s_when_run})
            return {"name": self.name, "wall_s": self.wall_s, "skipped": True, **when,
                    "note": self.note}
        return {"name": self.name, "wall_s": self.wall_s, "skipped": False, "note": self.note,
                "complete": self.complete}


@dataclass(frozen=True)
class ErrorRates:
    """The paper's error rates of a labelling, over the sites whose truth is known: eps_md
    the fraction of true mounds labelled no mound, eps_fa the fraction of the other sites
    labelled mound (None: no such site)."""

    eps_md: float | None
    eps_fa: float | None

    def to_doc(self) -> JsonObject:
        return {"eps_md": self.eps_md, "eps_fa": self.eps_fa}


@dataclass(frozen=True)
class ThreeAnswers:
    """The judged sites by the verdict's own answer, and the selective error rates: of the
    decided sites with a known truth (the undecided ones left to a second look or a
    person)."""

    decided: int
    undecided: int
    selective: ErrorRates
    decided_with_truth: int

    def to_doc(self) -> JsonObject:
        return {"decided": self.decided, "undecided": self.undecided,
                "selective": {**self.selective.to_doc(),
                              "decided_with_truth": self.decided_with_truth}}


@dataclass(frozen=True)
class SurveyMetrics:
    """summary.json's `metrics`: the survey's error rates beside the classifier's alone, a
    perfect verification's and (learning) the classifier's before any flight; the tour's
    reward and length; how many visited sites were judged and how many verdicts right."""

    survey: ErrorRates
    reward: float | None
    cost_m: float | None
    budget_m: float
    visited: int
    judged: int
    verdicts_correct: int
    verdicts_with_truth: int
    classifier_only: ErrorRates
    perfect_verification: ErrorRates
    three_answers: ThreeAnswers
    classifier_before_flights: ErrorRates | None = None

    @property
    def failed(self) -> int:
        return self.visited - self.judged

    def to_doc(self) -> JsonObject:
        doc: JsonObject = {
            **self.survey.to_doc(), "reward": self.reward, "cost_m": self.cost_m,
            "budget_m": self.budget_m, "visited": self.visited, "judged": self.judged,
            "failed": self.failed, "verdicts_correct": self.verdicts_correct,
            "verdicts_with_truth": self.verdicts_with_truth,
            "classifier_only": self.classifier_only.to_doc(),
            "perfect_verification": self.perfect_verification.to_doc(),
            "three_answers": self.three_answers.to_doc()}
        if self.classifier_before_flights is not None:
            doc["classifier_before_flights"] = self.classifier_before_flights.to_doc()
        return doc


@dataclass(frozen=True)
class FieldCounts:
    """summary.json's `field`: where the candidates came from and how many there are."""

    source: str
    sites: int
    true_mounds: int
    truth_known: int
    total_reward: float

    def to_doc(self) -> JsonObject:
        return {"source": self.source, "sites": self.sites, "true_mounds": self.true_mounds,
                "truth_known": self.truth_known, "total_reward": self.total_reward}


@dataclass(frozen=True)
class FieldTeamSite:
    """A site still undecided after every look the survey flew, for the field team: its
    p(mound) and why (the verdict's undecided reasons, by code and in words)."""

    id: str
    x_m: float
    y_m: float
    p_mound: float | None
    reasons: tuple[str | None, ...]
    why: str
    second_look_flown: bool

    def to_doc(self) -> JsonObject:
        return {"id": self.id, "x_m": self.x_m, "y_m": self.y_m, "p_mound": self.p_mound,
                "reasons": list(self.reasons), "why": self.why,
                "second_look_flown": self.second_look_flown}


def _flight_row(f: FlightSummary) -> JsonObject:
    """A flight of the summary's `mission`: its number, file, items, distance and sites,
    over a DEM its energy and lowest transit clearance."""
    return {"flight": f.flight, "file": f.file, "items": f.items,
            "flight_distance_m": f.flight_distance_m, "sites": [x.to_doc() for x in f.sites],
            **({"energy_m": f.terrain.energy_m,
                "lowest_clearance_m": f.terrain.lowest_clearance_m} if f.terrain else {})}


@dataclass(frozen=True)
class SurveySummary:
    """summary.json: `status` ok, partial (some visited sites failed), waiting (for a
    photo card) or failed, with `reason` unless ok; `options` as the run was asked; the
    documents the run made where it made them (the plan, the missions, the second looks'
    missions, the photo card's summary, the learning record) and the map page's name."""

    status: str
    reason: str
    created_utc: str
    origin: Origin | None
    options: JsonObject
    field: FieldCounts
    sites: tuple[SurveySite, ...]
    metrics: SurveyMetrics
    field_team: tuple[FieldTeamSite, ...]
    stages: tuple[StageRun, ...]
    wall_s: float
    learn: LearnRecord | None = None   # learn/learn.json (mound.learn v1)
    photos: CardSummary | None = None  # the photo card's counts and sites
    plan: Plan | None = None
    mission: MissionSummary | None = None
    second_look: MissionSummary | None = None  # second_look/mission.json, with looks
    map: str | None = None             # the map page, beside report.html

    @property
    def visited(self) -> list[SurveySite]:
        return [r for r in self.sites if r.visited]

    def to_doc(self) -> JsonObject:
        doc: JsonObject = {
            "schema": SCHEMA, "version": VERSION, "status": self.status,
            "created_utc": self.created_utc,
            "origin": {**self.origin.to_doc()} if self.origin else None,
            "options": self.options, "field": self.field.to_doc(),
            "sites": [r.to_doc() for r in self.sites], "metrics": self.metrics.to_doc(),
            "for_field_team": [t.to_doc() for t in self.field_team],
            "stages": [st.to_doc() for st in self.stages], "wall_s": self.wall_s}
        if self.reason:
            doc["reason"] = self.reason
        if self.learn is not None:
            doc["learn"] = self.learn.to_doc()
        if self.photos is not None:
            doc["photos"] = self.photos.to_doc()
        if self.plan is not None:
            written = self.plan.to_doc()
            doc["plan"] = {k: written.get(k) for k in PLAN_KEYS}
        if self.mission is not None:
            m = self.mission
            doc["mission"] = {"items": m.items, "flight_distance_m": m.flight_distance_m,
                              "budget_m": m.budget_m,
                              "upload": m.upload.to_doc() if m.upload else None,
                              "flights": [_flight_row(f) for f in m.flights]}
        second = self.second_look
        if second is not None and second.second_look is not None:
            doc["second_look_missions"] = {
                **second.second_look.to_doc(), "flight_distance_m": second.flight_distance_m,
                "flights": [{"flight": f.flight, "file": f.file, "items": f.items,
                             "flight_distance_m": f.flight_distance_m,
                             "sites": [x.id for x in f.sites]} for f in second.flights],
                "folder": "second_look"}
        if self.map is not None:
            doc["map"] = self.map
        return doc


@dataclass(frozen=True)
class SurveyAnswers:
    """What a later step reads back of summary.json (`mound day`): the run's status and
    each site's answer (`answer`, else its `verdict`: mound, no_mound, undecided or
    failed; None for a site not visited)."""

    status: str
    answers: Mapping[str, str | None]

    @classmethod
    def from_doc(cls, doc: object, path: str | Path) -> SurveyAnswers:
        d = check_doc(doc, path, SCHEMA, VERSION)
        where = str(path)
        answers: dict[str, str | None] = {}
        for k, x in enumerate(list_member(d, "sites", where)):
            at = f"{where}: sites[{k}]"
            site = as_object(x, at)
            sid = require_id(site.get("id"), f"{at}.id")
            said = site.get("answer", site.get("verdict"))
            answers[sid] = None if said is None else require_choice(
                said, SITE_ANSWERS, f"{at}.answer")
        return cls(require_choice(d.get("status"), STATUSES, f"{where}: status"), answers)

    @classmethod
    def read(cls, path: str | Path) -> SurveyAnswers:
        return cls.from_doc(load_json(path), path)
