"""mound.verdict v1 (`mound_recon verdict`'s verdict.json), as the survey reads it.

`Verdict.read(path)` validates what the survey uses — the answer (mound, no_mound or
undecided), its two-answer label, the confidence, the calibrated p(mound), the judged
rise's measurements, the second look's advice — with an InputError naming the file and the
field; the rest of the document (every feature, the model's provenance) stays in the file.
`row_fields()` is what a site's row (mound.survey_site) carries of it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mound.errors import InputError
from mound.jsonio import (
    check_doc,
    load_json,
    optional_number,
    optional_object,
    require_choice,
)

SCHEMA = "mound.verdict"
VERSION = 1
ANSWERS = ("mound", "no_mound", "undecided")
TWO_ANSWERS = ("mound", "no_mound")
# What the row keeps of the judged rise (its features stay in verdict.json).
RISE_FIELDS = ("height_m", "base_diameter_m", "roundness", "dome_r2", "volume_m3",
               "centre_enu_m")


@dataclass(frozen=True)
class SecondLookAdvice:
    """The verdict's advice to fly the site again with a scan `scan_factor` x as wide."""

    advised: bool
    scan_factor: float | None = None
    extra: Mapping[str, Any] = field(default_factory=dict)

    def to_doc(self) -> dict[str, object]:
        return {"advised": self.advised, "scan_factor": self.scan_factor, **self.extra}

    @classmethod
    def from_doc(cls, doc: object, where: str) -> SecondLookAdvice:
        if not isinstance(doc, dict):
            raise InputError(f"{where}: expected an object")
        advised = doc.get("advised", False)
        if not isinstance(advised, bool):
            raise InputError(f"{where}.advised: expected true or false")
        factor = optional_number(doc, "scan_factor", where, lo=1.0, hi=100.0)
        if advised and factor is None:
            raise InputError(f"{where}.scan_factor: missing (a second look was advised)")
        return cls(advised, factor,
                   {k: v for k, v in doc.items() if k not in ("advised", "scan_factor")})


@dataclass(frozen=True)
class Verdict:
    """A site's verdict: `label` the verdict's own answer, `two_answer` the paper's
    protocol's (the band's undecided sites fall to one side of the threshold)."""

    label: str
    two_answer: str
    method: str
    reason: str = ""
    confidence: float | None = None
    p_mound: float | None = None       # the reference-free verdict's calibrated p
    undecided: Mapping[str, Any] | None = None
    coverage: Mapping[str, Any] | None = None
    rise: Mapping[str, Any] | None = None  # RISE_FIELDS of the judged rise
    distance_m: float | None = None    # the reference test's cloud-to-reference distance
    second_look: SecondLookAdvice | None = None

    def row_fields(self) -> dict[str, Any]:
        """The row's verdict fields: `answer` the verdict's own (mound, no_mound or
        undecided), `verdict` its two answers (the paper's protocol: epsilon_MD and
        epsilon_FA, learning), `undecided` why and what next where it is undecided."""
        out: dict[str, Any] = {"verdict": self.two_answer, "answer": self.label,
                               "confidence": self.confidence, "method": self.method,
                               "reason": self.reason}
        if self.undecided is not None:
            out["undecided"] = dict(self.undecided)
        if self.p_mound is not None:
            out["verdict_p_mound"] = self.p_mound
        if self.coverage is not None:
            out["coverage"] = dict(self.coverage)
        if self.rise is not None:
            out["rise"] = dict(self.rise)
        if self.distance_m is not None:
            out["distance_m"] = self.distance_m
        return out

    @classmethod
    def from_doc(cls, doc: Any, path: str | Path) -> Verdict:
        doc = check_doc(doc, path, SCHEMA, VERSION)
        where = str(path)
        label = require_choice(doc.get("label"), ANSWERS, f"{where}: label")
        two = optional_object(doc, "two_answer", where)
        two_answer = require_choice(two.get("label", label) if two is not None else label,
                                    TWO_ANSWERS, f"{where}: two_answer.label")
        method, reason = doc.get("method", ""), doc.get("reason", "")
        if not isinstance(method, str) or not isinstance(reason, str):
            raise InputError(f"{where}: method, reason: expected strings")
        m = optional_object(doc, "measurements", where) or {}
        rise = optional_object(m, "rise", f"{where}: measurements")
        advice = doc.get("second_look")
        return cls(label, two_answer, method, reason,
                   optional_number(doc, "confidence", where, lo=0.0, hi=1.0),
                   optional_number(doc, "p_mound", where, lo=0.0, hi=1.0),
                   optional_object(doc, "undecided", where),
                   optional_object(doc, "coverage", where),
                   None if rise is None else {k: rise.get(k) for k in RISE_FIELDS},
                   optional_number(m, "distance_m", f"{where}: measurements"),
                   None if advice is None
                   else SecondLookAdvice.from_doc(advice, f"{where}: second_look"))

    @classmethod
    def read(cls, path: str | Path) -> Verdict:
        return cls.from_doc(load_json(path), path)
