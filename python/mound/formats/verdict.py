"""mound.verdict v1 (`mound_recon verdict`'s verdict.json), as the survey reads it.

`Verdict.read(path)` validates what the survey uses — the answer (mound, no_mound or
undecided), its two-answer label, the confidence, the calibrated p(mound), the judged
rise's measurements, the second look's advice — with an InputError naming the file and the
field. `row_fields()` is what a site's row (mound.survey_site) carries of it.

`VerdictFile.read(path)` is the whole file as every other reader takes it (the grids, the
verdict's training, the map, the figures): the status (a failed verdict has no answer),
the cloud judged, the look, the coverage, and the `Measurements` (the site's disc and
ground fit, the candidate set, every judged rise as a `Rise` with its features). The
model's provenance stays in the file.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mound.errors import InputError
from mound.jsonio import (
    JsonObject,
    as_object,
    check_doc,
    finite_number,
    load_json,
    number_map,
    optional_number,
    optional_number_list,
    optional_object,
    read_json,
    require_choice,
    short_repr,
    write_json,
    xy_metres,
)

SCHEMA = "mound.verdict"
VERSION = 1
ANSWERS = ("mound", "no_mound", "undecided")
TWO_ANSWERS = ("mound", "no_mound")
# What the row keeps of the judged rise (its features stay in verdict.json).
RISE_FIELDS = ("height_m", "base_diameter_m", "roundness", "dome_r2", "volume_m3",
               "centre_enu_m")
# The candidate rises `mound_recon verdict --candidates` measures (measurements.candidates,
# a model's detector.candidates; without it the first, which the built-in models learnt).
CANDIDATES = ("site_ground", "local_relief")
LOOKS = ("first", "second")


@dataclass(frozen=True)
class SecondLookAdvice:
    """The verdict's advice to fly the site again with a scan `scan_factor` x as wide."""

    advised: bool
    scan_factor: float | None = None
    extra: Mapping[str, Any] = field(default_factory=dict)

    def to_doc(self) -> JsonObject:
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

    def row_fields(self) -> JsonObject:
        """The row's verdict fields: `answer` the verdict's own (mound, no_mound or
        undecided), `verdict` its two answers (the paper's protocol: epsilon_MD and
        epsilon_FA, learning), `undecided` why and what next where it is undecided."""
        out: JsonObject = {"verdict": self.two_answer, "answer": self.label,
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


@dataclass(frozen=True)
class Rise:
    """A rise the verdict judged (measurements.judged_rises[k], or its chosen `rise`): its
    features (the model's input), the measurements the rules and the viewer read, and the
    ground it was measured over (`ground_plane`: z at its centre and the two slopes;
    `ground_curvature`: the quadratic terms, 1/m, over a curved ground)."""

    features: Mapping[str, float]
    centre_enu_m: tuple[float, float] | None = None
    base_diameter_m: float | None = None
    height_m: float | None = None
    roundness: float | None = None
    dome_r2: float | None = None
    ground_plane: tuple[float, ...] | None = None
    ground_curvature: tuple[float, ...] | None = None

    @classmethod
    def from_doc(cls, doc: object, where: str) -> Rise:
        d = as_object(doc, where)
        return cls(number_map(d.get("features", {}), f"{where}.features"),
                   xy_metres(d["centre_enu_m"], f"{where}.centre_enu_m") if "centre_enu_m" in d
                   else None,
                   optional_number(d, "base_diameter_m", where),
                   optional_number(d, "height_m", where),
                   optional_number(d, "roundness", where),
                   optional_number(d, "dome_r2", where),
                   optional_number_list(d, "ground_plane", where, 3),
                   optional_number_list(d, "ground_curvature", where, 3))


def rises_of(docs: object, where: str) -> tuple[Rise, ...]:
    """A verdict's judged rises (a list of rise objects)."""
    if not isinstance(docs, list):
        raise InputError(f"{where}: expected a list of rises, got {short_repr(docs)}")
    return tuple(Rise.from_doc(r, f"{where}[{k}]") for k, r in enumerate(docs))


@dataclass(frozen=True)
class Measurements:
    """A verdict's `measurements`: the scanned site's disc (centre, ENU m; radius, m), its
    ground fit z = c0 + c1 x + c2 y + c3 x^2 + c4 x y + c5 y^2 (x, y from the centre), the
    grid cell the rises were found on, the candidate set measured, every judged rise and
    the chosen one, the ground's descriptors (`terrain`), and the reference test's
    cloud-to-reference distance."""

    candidates: str = CANDIDATES[0]
    judged_rises: tuple[Rise, ...] = ()
    rise: Rise | None = None
    site_centre_enu_m: tuple[float, float] | None = None
    site_radius_m: float | None = None
    ground_coefficients: tuple[float, ...] | None = None
    cell_m: float | None = None
    terrain: Mapping[str, float] | None = None
    distance_m: float | None = None

    @classmethod
    def from_doc(cls, doc: object, where: str) -> Measurements:
        m = as_object(doc, where)
        candidates = m.get("candidates", CANDIDATES[0])
        if candidates not in CANDIDATES:
            raise InputError(f"{where}.candidates: one of {', '.join(CANDIDATES)}, "
                             f"got {short_repr(candidates)}")
        centre, terrain = m.get("site_centre_enu_m"), m.get("terrain")
        return cls(
            str(candidates), rises_of(m.get("judged_rises", []), f"{where}.judged_rises"),
            Rise.from_doc(m["rise"], f"{where}.rise") if m.get("rise") else None,
            None if centre is None else xy_metres(centre, f"{where}.site_centre_enu_m"),
            optional_number(m, "site_radius_m", where, lo=0.0),
            optional_number_list(m, "ground_coefficients", where, 6),
            optional_number(m, "cell_m", where, lo=0.0),
            None if terrain is None else {
                str(k): finite_number(x, f"{where}.terrain.{k}")
                for k, x in as_object(terrain, f"{where}.terrain").items()},
            optional_number(m, "distance_m", where))


@dataclass(frozen=True)
class VerdictFile:
    """A whole verdict.json: `status` ok or failed (then `reason` says why and there is no
    answer), the cloud judged (its path as written), the look (first or second), the
    coverage's status, the measurements, the grid's timings (`mound sim grid` adds them,
    seconds by step) and, when ok, the answer (`verdict`)."""

    path: str
    status: str
    reason: str = ""
    cloud: str = ""
    look: str = LOOKS[0]
    coverage_status: str | None = None
    measurements: Measurements | None = None
    grid_times_s: Mapping[str, float] = field(default_factory=dict)
    verdict: Verdict | None = None

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def cloud_kind(self) -> str:
        """dense (densify's dense.ply) or sparse (the reconstruction's points)."""
        return "dense" if self.cloud.endswith("dense.ply") else "sparse"

    @property
    def label(self) -> str:
        """The answer (mound, no_mound or undecided), or failed."""
        return self.verdict.label if self.verdict is not None else "failed"

    @property
    def p_mound(self) -> float | None:
        return self.verdict.p_mound if self.verdict is not None else None

    @classmethod
    def from_doc(cls, doc: object, path: str | Path) -> VerdictFile:
        d = check_doc(doc, path, SCHEMA, VERSION)
        where = str(path)
        status = require_choice(d.get("status"), ("ok", "failed"), f"{where}: status")
        reason, cloud = d.get("reason", ""), d.get("cloud", "")
        if not isinstance(reason, str) or not isinstance(cloud, str):
            raise InputError(f"{where}: reason, cloud: expected strings")
        look = require_choice(d.get("look", LOOKS[0]), LOOKS, f"{where}: look")
        coverage = optional_object(d, "coverage", where)
        cstatus = None if coverage is None else coverage.get("status")
        m = d.get("measurements")
        return cls(
            where, status, reason, cloud, look, cstatus if isinstance(cstatus, str) else None,
            None if m is None else Measurements.from_doc(m, f"{where}: measurements"),
            number_map(d.get("grid_times_s", {}), f"{where}: grid_times_s"),
            Verdict.from_doc(d, path) if status == "ok" else None)

    @classmethod
    def read(cls, path: str | Path) -> VerdictFile:
        return cls.from_doc(load_json(path), path)


def record_grid_times(path: str | Path, times: Mapping[str, float]) -> None:
    """Add a grid's timings (seconds by step: simulate, reconstruct, densify, verdict) to
    the verdict.json at `path`, as `grid_times_s`; the rest of the file as written."""
    doc = read_json(path, SCHEMA, VERSION)
    doc["grid_times_s"] = dict(times)
    write_json(path, doc)
