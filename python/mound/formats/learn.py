"""The learning between flights (learn/learn.json, mound.learn v1), typed once.

`LearnRecord` is the whole document: the weight the verdicts were learned with, the
held-out AUC before and after, and per flight (`FlightLearned`) its sites, the first
plan's, what it learned (`Example`) and how the classifier's p of the sites not flown
moved (`Change`, largest first). The survey's learn stage writes it, the report and
`mound day` read it (`read`), each member checked.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mound.jsonio import (
    JsonObject,
    as_object,
    check_doc,
    id_list,
    list_member,
    load_json,
    require_count,
    require_id,
    require_number,
    require_string,
)

SCHEMA = "mound.learn"
VERSION = 1
LARGEST_CHANGES = 5  # the changes of p a flight's record keeps


def _p(doc: Mapping[str, Any], key: str, where: str) -> float:
    return require_number(doc, key, where, lo=0.0, hi=1.0)


@dataclass(frozen=True)
class Example:
    """A judged site the classifier learns: its two-answer verdict, weighted by the
    verdict's confidence."""

    id: str
    verdict: str
    confidence: float

    def to_doc(self) -> JsonObject:
        return {"id": self.id, "verdict": self.verdict, "confidence": self.confidence}

    @classmethod
    def from_doc(cls, doc: object, where: str) -> Example:
        d = as_object(doc, where)
        return cls(require_id(d.get("id"), f"{where}.id"), require_string(d, "verdict", where),
                   _p(d, "confidence", where))


@dataclass(frozen=True)
class Change:
    """How a site's p_mound moved when the classifier learned a flight."""

    id: str
    p_before: float
    p_after: float

    def to_doc(self) -> JsonObject:
        return {"id": self.id, "p_before": self.p_before, "p_after": self.p_after}

    @classmethod
    def from_doc(cls, doc: object, where: str) -> Change:
        d = as_object(doc, where)
        return cls(require_id(d.get("id"), f"{where}.id"), _p(d, "p_before", where),
                   _p(d, "p_after", where))


@dataclass(frozen=True)
class FlightLearned:
    """What a flight taught (learn.json's flights[k]). `changes` are the sites not flown,
    largest change first: all of them as the stage made them, the LARGEST_CHANGES the file
    keeps when read."""

    flight: int
    sites: list[str]
    planned_reward: float
    first_plan_sites: list[str]
    cost_m: float
    note: str
    examples: list[Example]
    held_out_auc: float
    labels_flipped: int
    changes: list[Change]

    @property
    def max_abs_dp(self) -> float:
        """The largest change of p (0 when no site was left)."""
        top = self.changes[0] if self.changes else None
        return abs(top.p_after - top.p_before) if top else 0.0

    def to_doc(self) -> JsonObject:
        return {"flight": self.flight, "sites": self.sites,
                "planned_reward": self.planned_reward,
                "first_plan_sites": self.first_plan_sites, "cost_m": self.cost_m,
                "note": self.note, "examples": [e.to_doc() for e in self.examples],
                "held_out_auc": self.held_out_auc, "labels_flipped": self.labels_flipped,
                "max_abs_dp": self.max_abs_dp,
                "largest_changes": [c.to_doc() for c in self.changes[:LARGEST_CHANGES]]}

    @classmethod
    def from_doc(cls, doc: object, where: str) -> FlightLearned:
        d = as_object(doc, where)
        return cls(
            require_count(d, "flight", where), id_list(d, "sites", where),
            require_number(d, "planned_reward", where, lo=0.0, hi=1e12),
            id_list(d, "first_plan_sites", where),
            require_number(d, "cost_m", where, lo=0.0, hi=1e12),
            require_string(d, "note", where, default=""),
            [Example.from_doc(x, f"{where}.examples[{k}]")
             for k, x in enumerate(list_member(d, "examples", where))],
            _p(d, "held_out_auc", where), require_count(d, "labels_flipped", where),
            [Change.from_doc(x, f"{where}.largest_changes[{k}]")
             for k, x in enumerate(list_member(d, "largest_changes", where))])


@dataclass(frozen=True)
class LearnRecord:
    """learn/learn.json: the flights one after another and what each taught; `stopped` why
    the flights ended early (empty: they did not), `waiting_for_battery` the battery whose
    card a day on cards waits for (None: none)."""

    learn_weight: float
    held_out_auc_before: float
    held_out_auc_after: float
    held_out_rows: int
    evaluation: str
    flights: tuple[FlightLearned, ...]
    stopped: str = ""
    waiting_for_battery: int | None = None

    def to_doc(self) -> JsonObject:
        return {"schema": SCHEMA, "version": VERSION, "learn_weight": self.learn_weight,
                "held_out_auc_before": self.held_out_auc_before,
                "held_out_auc_after": self.held_out_auc_after,
                "held_out_rows": self.held_out_rows, "evaluation": self.evaluation,
                "flights": [f.to_doc() for f in self.flights], "stopped": self.stopped,
                "waiting_for_battery": self.waiting_for_battery}

    @classmethod
    def from_doc(cls, doc: object, path: str | Path) -> LearnRecord:
        d = check_doc(doc, path, SCHEMA, VERSION)
        where = str(path)
        waiting = None if d.get("waiting_for_battery") is None else require_count(
            d, "waiting_for_battery", where)
        return cls(require_number(d, "learn_weight", where, lo=0.0, hi=1e6),
                   _p(d, "held_out_auc_before", where), _p(d, "held_out_auc_after", where),
                   require_count(d, "held_out_rows", where),
                   require_string(d, "evaluation", where),
                   tuple(FlightLearned.from_doc(x, f"{where}: flights[{k}]")
                         for k, x in enumerate(list_member(d, "flights", where))),
                   require_string(d, "stopped", where, default=""), waiting)

    @classmethod
    def read(cls, path: str | Path) -> LearnRecord:
        return cls.from_doc(load_json(path), path)
