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
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mound.jsonio import load_json, write_json

SCHEMA = "mound.survey_ledger"
VERSION = 1


def digest(value: Any) -> str:
    """SHA-256 of a JSON-able value (keys sorted): the key of a stage or a site."""
    text = json.dumps(value, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()


@dataclass
class StageRecord:
    name: str
    key: str
    wall_s: float
    outputs: list[str]
    skipped: bool = False
    note: str = ""


class Ledger:
    """The stages done in a run directory."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.done: dict[str, dict[str, Any]] = {}
        if path.is_file():
            doc = load_json(path)
            # A ledger of another version or a damaged one only costs a rerun.
            if isinstance(doc, dict) and doc.get("schema") == SCHEMA and \
                    doc.get("version") == VERSION and isinstance(doc.get("stages"), dict):
                self.done = doc["stages"]

    def is_done(self, name: str, key: str) -> bool:
        rec = self.done.get(name)
        if not isinstance(rec, dict) or rec.get("key") != key:
            return False
        root = self.path.parent
        return all((root / out).exists() for out in rec.get("outputs", []))

    def previous(self, name: str) -> dict[str, Any]:
        rec = self.done.get(name)
        return rec if isinstance(rec, dict) else {}

    def record(self, rec: StageRecord) -> None:
        self.done[rec.name] = {"key": rec.key, "wall_s": rec.wall_s, "outputs": rec.outputs,
                               "note": rec.note,
                               "finished_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ",
                                                             time.gmtime())}
        write_json(self.path, {"schema": SCHEMA, "version": VERSION, "stages": self.done})

    def forget(self, name: str) -> None:
        if self.done.pop(name, None) is not None:
            write_json(self.path, {"schema": SCHEMA, "version": VERSION, "stages": self.done})
