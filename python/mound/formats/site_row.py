"""mound.survey_site v1: a visited site's row (DIR/sites/<id>/site_result.json), what its
3-D work (mound.survey.site_work) did and concluded.

A row is `ok` when the site was judged (`verdict` holds the verdict; after a second look,
both flights' verdict, with `first_look` the first flight's) or `failed` with `reason` and
whether a rerun should try again (`retry`; `internal_error` when a bug stopped it). The
document flattens the verdict into the row (`verdict` the two-answer label, `answer` the
verdict's own, `confidence`, `verdict_p_mound`, `undecided`, `rise`, ...) as the report and
outside scripts read it; `SiteRow.from_doc` reads it back, validated.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mound.errors import InputError
from mound.formats.verdict import ANSWERS, TWO_ANSWERS, Verdict
from mound.jsonio import (
    JsonObject,
    JsonValue,
    check_doc,
    finite_number,
    load_json,
    optional_number,
    optional_object,
    renamed,
    require_choice,
    require_id,
    short_repr,
)

SCHEMA = "mound.survey_site"
VERSION = 1
STATUSES = ("ok", "failed")
# What a row keeps of its first look when a second look decided the site.
FIRST_LOOK_KEYS = ("verdict", "answer", "confidence", "verdict_p_mound", "reason", "rise",
                   "undecided")
# The members of a row SiteRow types; the others (simulated, recon, dense, rasters, the
# errors of the optional steps) travel in `extra`.
_VERDICT_KEYS = ("verdict", "answer", "confidence", "method", "reason", "undecided",
                 "verdict_p_mound", "coverage", "rise", "distance_m")
_TYPED = ("schema", "version", "id", "key", "first_key", "status", "source", "worker",
          "timings_s", "retry", "internal_error", "verdict_cloud", "files", "second_look",
          "first_look", *_VERDICT_KEYS)


@dataclass
class SecondLookRecord:
    """What became of a second look a row's first verdict advised: its scan factor,
    whether it was flown (the wider scan's site diameter, the photos' source, the second
    verdict's p and file) or why not. A field is None where the row does not say it."""

    advised: bool | None = True
    scan_factor: float | None = None
    flown: bool | None = False
    site_diameter_m: float | None = None   # m, of the wider scan
    source: str | None = None
    reason: str | None = None
    p_mound: float | None = None
    verdict_file: str | None = None
    extra: Mapping[str, JsonValue] = field(default_factory=dict)

    def to_doc(self) -> JsonObject:
        said = {"advised": self.advised, "scan_factor": self.scan_factor,
                "flown": self.flown, "site_diameter_m": self.site_diameter_m, "source": self.source,
                "reason": self.reason, "p_mound": self.p_mound,
                "verdict_file": self.verdict_file}
        return {**{k: v for k, v in said.items() if v is not None}, **self.extra}

    @classmethod
    def from_doc(cls, doc: object, where: str) -> SecondLookRecord:
        if not isinstance(doc, dict):
            raise InputError(f"{where}: expected an object")
        flags = {k: doc.get(k) for k in ("advised", "flown")}
        texts = {k: doc.get(k) for k in ("source", "reason", "verdict_file")}
        for k, v in flags.items():
            if v is not None and not isinstance(v, bool):
                raise InputError(f"{where}.{k}: expected true or false, got {short_repr(v)}")
        for k, v in texts.items():
            if v is not None and not isinstance(v, str):
                raise InputError(f"{where}.{k}: expected a string, got {short_repr(v)}")
        doc = renamed(doc, "site_diameter_m", LEGACY_LOOK_DIAMETER, where)  # until 2026-11-30
        return cls(flags["advised"], optional_number(doc, "scan_factor", where),
                   flags["flown"], optional_number(doc, "site_diameter_m", where, lo=0.0),
                   texts["source"], texts["reason"],
                   optional_number(doc, "p_mound", where, lo=0.0, hi=1.0),
                   texts["verdict_file"],
                   {k: v for k, v in doc.items() if k not in _LOOK_KEYS})


# The wider scan's site diameter under its name until 2026-11-30 (read, never written).
LEGACY_LOOK_DIAMETER = "scan_m"
_LOOK_KEYS = ("advised", "scan_factor", "flown", "site_diameter_m", LEGACY_LOOK_DIAMETER,
              "source", "reason", "p_mound", "verdict_file")


@dataclass
class SiteRow:
    """A visited site's row; built up by the site's work, then written once."""

    id: str
    key: str
    first_key: str = ""
    status: str = "failed"
    source: str = "simulated"        # simulated, or the UAV's photos
    worker: str = ""                 # host:pid of the Dask worker
    timings_s: dict[str, float] = field(default_factory=dict)
    reason: str = ""                 # why it failed (the verdict's own reason is in it)
    retry: bool | None = None        # failed: would a rerun try again
    internal_error: bool = False     # failed by a bug (the traceback is in the site's log)
    verdict: Verdict | None = None
    first_look: Verdict | None = None  # after a second look: the first flight's verdict
    verdict_cloud: str | None = None   # the cloud judged: dense or sparse
    files: dict[str, str] = field(default_factory=dict)  # relative to the run directory
    second_look: SecondLookRecord | None = None
    extra: JsonObject = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def answer(self) -> str | None:
        """The verdict's own answer (mound, no_mound or undecided), None when not judged."""
        return self.verdict.label if self.verdict and self.ok else None

    def to_doc(self) -> JsonObject:
        doc: JsonObject = {"schema": SCHEMA, "version": VERSION, "id": self.id,
                           "key": self.key, "first_key": self.first_key,
                           "status": self.status, "source": self.source,
                           "worker": self.worker, "timings_s": dict(self.timings_s),
                           **self.extra}
        if self.verdict is not None:
            doc.update(self.verdict.row_fields())
        if self.first_look is not None:
            first = self.first_look.row_fields()
            doc["first_look"] = {k: first[k] for k in FIRST_LOOK_KEYS
                                 if first.get(k) is not None}
        if self.verdict_cloud is not None:
            doc["verdict_cloud"] = self.verdict_cloud
        if self.files:
            doc["files"] = dict(self.files)
        if self.second_look is not None:
            doc["second_look"] = self.second_look.to_doc()
        if not self.ok:
            doc["reason"] = self.reason
            if self.retry is not None:
                doc["retry"] = self.retry
            if self.internal_error:
                doc["internal_error"] = True
        return doc

    @classmethod
    def from_doc(cls, doc: Any, path: str | Path) -> SiteRow:
        doc = check_doc(doc, path, SCHEMA, VERSION)
        where = str(path)
        status = require_choice(doc.get("status"), STATUSES, f"{where}: status")
        strings = {k: doc.get(k, "") for k in ("key", "first_key", "source", "worker",
                                               "reason")}
        for k, v in strings.items():
            if not isinstance(v, str):
                raise InputError(f"{where}: {k}: expected a string, got {short_repr(v)}")
        timings = doc.get("timings_s", {})
        if not isinstance(timings, dict):
            raise InputError(f"{where}: timings_s: expected an object")
        files = doc.get("files", {})
        if not isinstance(files, dict) or not all(isinstance(v, str) for v in files.values()):
            raise InputError(f"{where}: files: expected an object of paths")
        retry = doc.get("retry")
        if retry is not None and not isinstance(retry, bool):
            raise InputError(f"{where}: retry: expected true or false")
        second = doc.get("second_look")
        look = (None if second is None
                else SecondLookRecord.from_doc(second, f"{where}: second_look"))
        cloud = doc.get("verdict_cloud")
        if cloud not in (None, "dense", "sparse"):
            raise InputError(f"{where}: verdict_cloud: expected dense or sparse")
        first = doc.get("first_look")
        if first is not None and not isinstance(first, dict):
            raise InputError(f"{where}: first_look: expected an object")
        if "verdict" not in doc:
            stray = [k for k in _VERDICT_KEYS if k in doc and k != "reason"]
            if stray or first is not None or status == "ok":
                raise InputError(f"{where}: verdict: missing (the row is "
                                 f"{'judged' if status == 'ok' else 'half a verdict'})")
        return cls(require_id(doc.get("id"), f"{where}: id"), strings["key"],
                   strings["first_key"], status, strings["source"], strings["worker"],
                   {str(k): finite_number(v, f"{where}: timings_s.{k}", lo=0.0)
                    for k, v in timings.items()},
                   strings["reason"], retry, doc.get("internal_error") is True,
                   _verdict_of(doc, where) if "verdict" in doc else None,
                   None if first is None else _verdict_of(first, f"{where}: first_look"),
                   cloud, dict(files), look,
                   {k: v for k, v in doc.items() if k not in _TYPED})

    @classmethod
    def read(cls, path: str | Path) -> SiteRow:
        return cls.from_doc(load_json(path), path)


def _verdict_of(row: Mapping[str, object], where: str) -> Verdict:
    """The verdict a row (or its first_look) carries, flattened by Verdict.row_fields."""
    two = require_choice(row.get("verdict"), TWO_ANSWERS, f"{where}: verdict")
    answer = require_choice(row.get("answer", two), ANSWERS, f"{where}: answer")
    return Verdict(answer, two, str(row.get("method", "")), str(row.get("reason", "")),
                   optional_number(row, "confidence", where, lo=0.0, hi=1.0),
                   optional_number(row, "verdict_p_mound", where, lo=0.0, hi=1.0),
                   optional_object(row, "undecided", where),
                   optional_object(row, "coverage", where), optional_object(row, "rise", where),
                   optional_number(row, "distance_m", where))
