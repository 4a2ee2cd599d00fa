"""Resuming a run: which stages are done for these inputs and options (ODM's rerun logic).

Each stage has a key, the SHA-256 of its options and of the keys (or file digests) of what
it reads. When a stage finishes, the ledger (DIR/stages.json, written atomically) records
its key, its outputs and its wall time. On a rerun a stage whose key is unchanged and whose
outputs all exist is skipped; a changed option or input changes its key and, through the
keys, those of every stage after it.
"""

from __future__ import annotations

import hashlib
import json
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from mound.errors import InputError
from mound.jsonio import (
    JsonObject,
    as_object,
    load_json,
    require_number,
    require_string,
    string_list,
    write_json,
)

SCHEMA = "mound.survey_ledger"
VERSION = 1


def digest(value: Any) -> str:
    """SHA-256 of a JSON-able value (keys sorted): the key of a stage or a site."""
    text = json.dumps(value, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()


@dataclass(frozen=True)
class StageRecord:
    """A stage the ledger holds: its key, its outputs (relative to the run directory), its
    wall time and note, and when it finished (UTC; set when recorded)."""

    name: str
    key: str
    wall_s: float
    outputs: tuple[str, ...]
    note: str = ""
    finished_utc: str = ""

    def to_doc(self) -> JsonObject:
        return {"key": self.key, "wall_s": self.wall_s, "outputs": list(self.outputs),
                "note": self.note, "finished_utc": self.finished_utc}

    @classmethod
    def of(cls, name: str, doc: object) -> StageRecord | None:
        """The stage `name` of a ledger's `stages`, or None when its entry is damaged (a
        rerun of the stage is all it costs)."""
        try:
            d = as_object(doc, name)
            return cls(name, require_string(d, "key", name),
                       require_number(d, "wall_s", name) if "wall_s" in d else 0.0,
                       tuple(string_list(d, "outputs", name)),
                       require_string(d, "note", name, default=""),
                       require_string(d, "finished_utc", name, default=""))
        except InputError:
            return None


class Ledger:
    """The stages done in a run directory."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.done: dict[str, StageRecord] = {}
        if path.is_file():
            doc = load_json(path)
            # A ledger of another version or a damaged one only costs a rerun.
            if isinstance(doc, dict) and doc.get("schema") == SCHEMA and \
                    doc.get("version") == VERSION and isinstance(doc.get("stages"), dict):
                for name, entry in doc["stages"].items():
                    rec = StageRecord.of(name, entry)
                    if rec is not None:
                        self.done[name] = rec

    def is_done(self, name: str, key: str) -> bool:
        rec = self.done.get(name)
        if rec is None or rec.key != key:
            return False
        root = self.path.parent
        return all((root / out).exists() for out in rec.outputs)

    def previous(self, name: str) -> StageRecord | None:
        return self.done.get(name)

    def record(self, rec: StageRecord) -> None:
        self.done[rec.name] = replace(
            rec, finished_utc=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()))
        self._write()

    def forget(self, name: str) -> None:
        if self.done.pop(name, None) is not None:
            self._write()

    def _write(self) -> None:
        write_json(self.path, {"schema": SCHEMA, "version": VERSION,
                               "stages": {k: r.to_doc() for k, r in self.done.items()}})
