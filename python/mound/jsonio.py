"""Versioned JSON documents: atomic writes and checked reads (../shared/STYLE.md)."""

from __future__ import annotations

import json
import math
import os
import tempfile
from pathlib import Path
from typing import Any

from mound.errors import InputError


def write_atomic(path: str | Path, text: str) -> None:
    """Writes `text` to `path` through a temporary file in the same folder and a rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=path.name + ".tmp.", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _reject_non_finite(value: Any, where: str) -> None:
    if isinstance(value, float) and not math.isfinite(value):
        raise InputError(f"{where}: non-finite number {value}")
    if isinstance(value, dict):
        for k, v in value.items():
            _reject_non_finite(v, f"{where}.{k}" if where else k)
    elif isinstance(value, list):
        for i, v in enumerate(value):
            _reject_non_finite(v, f"{where}[{i}]")


def write_json(path: str | Path, doc: dict[str, Any]) -> None:
    """Atomic JSON write; NaN/Infinity are refused (they are not JSON)."""
    _reject_non_finite(doc, "")
    write_atomic(path, json.dumps(doc, indent=1, allow_nan=False) + "\n")


def read_text(path: str | Path) -> str:
    """A UTF-8 text file; InputError naming the file if it cannot be read."""
    try:
        return Path(path).read_text(encoding="utf-8")
    except OSError as e:
        raise InputError(f"{path}: cannot read ({e.strerror})") from e


def parse_json(text: str, path: str | Path) -> Any:
    """JSON text read from `path`; a syntax error names the file, line and column."""
    try:
        return json.loads(text)
    except json.JSONDecodeError as e:
        raise InputError(f"{path}:{e.lineno}:{e.colno}: not valid JSON ({e.msg})") from e


def read_json(path: str | Path, schema: str, max_version: int) -> dict[str, Any]:
    """Reads a `schema` document of version 1..max_version; InputError on any defect."""
    doc = parse_json(read_text(path), path)
    if not isinstance(doc, dict):
        raise InputError(f"{path}: top level must be an object")
    if doc.get("schema") != schema:
        raise InputError(f"schema: expected {schema!r}, got {doc.get('schema')!r} in {path}")
    version = doc.get("version")
    if not isinstance(version, int) or isinstance(version, bool) or not 1 <= version <= max_version:
        raise InputError(f"version: unsupported {schema} version {version!r} in {path}")
    return doc
