"""A site's row of a verdict grid (GRID/grid.json, mound.verdict_grid v1, `rows[k]`), as
`mound sim grid` writes it: the site's folder, its truth, how its verdict came out (status,
the steps' times in seconds, the first look's p_mound, why it failed), the second looks
flown at it by folder, and the draw it was simulated from (`spec`).

`GridRow.from_doc` reads a row back (mound.training.verdict_data.load_grid, with the site's
verdict): the folder a plain name, the look's status one of STATUSES, its times and p_mound
numbers; the truth and the draw stay objects for their own readers (recon.grid_site).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from mound.errors import InputError
from mound.jsonio import (
    JsonObject,
    as_object,
    number_map,
    optional_number,
    optional_string,
    require_choice,
    short_repr,
)

SCHEMA = "mound.verdict_grid"
VERSION = 1
STATUSES = ("ok", "failed", "running")
# A row's members that are not a second look's folder (an object under another name is
# one; other members are ignored, as unknown members are).
_ROW_KEYS = ("dir", "truth", "spec", "status", "times", "reason", "p_mound")


def folder_name(name: str) -> bool:
    """A plain folder name: 1-255 bytes of UTF-8, no '/', no control character, not . or
    .. (a grid row's dir, joined to the grid's folder)."""
    if name in (".", "..") or "/" in name:
        return False
    try:
        size = len(name.encode("utf-8"))
    except UnicodeEncodeError:  # a lone surrogate
        return False
    return 0 < size <= 255 and not any(ord(c) < 32 for c in name)


@dataclass(frozen=True)
class GridLook:
    """A look at a grid site (the first, or a second in its own folder): `status` ok,
    failed or running (no verdict yet), the steps' times (s), p_mound of its verdict, and
    why it failed."""

    status: str = "running"
    times_s: Mapping[str, float] = field(default_factory=dict)
    p_mound: float | None = None
    reason: str | None = None

    def to_doc(self) -> JsonObject:
        return {"status": self.status, "times": dict(self.times_s),
                **({"reason": self.reason} if self.reason is not None else {})}

    @classmethod
    def from_doc(cls, doc: object, where: str) -> GridLook:
        """A look as a row holds it (`times` absent: none kept; `p_mound` the row's)."""
        d = as_object(doc, where)
        return cls(require_choice(d.get("status"), STATUSES, f"{where}.status"),
                   number_map(d.get("times", {}), f"{where}.times", lo=0.0),
                   optional_number(d, "p_mound", where, lo=0.0, hi=1.0),
                   optional_string(d, "reason", where))


@dataclass(frozen=True)
class GridRow:
    """grid.json's rows[k]: the site's folder and truth (mound.sim's truth fields), its
    first look, the second looks flown by folder, the draw (`spec`, None: not written)."""

    dir: str
    truth: JsonObject
    look: GridLook = field(default_factory=GridLook)
    second: Mapping[str, GridLook] = field(default_factory=dict)
    spec: JsonObject | None = None

    def to_doc(self) -> JsonObject:
        doc: JsonObject = {"dir": self.dir, "truth": self.truth, **self.look.to_doc(),
                           "p_mound": self.look.p_mound}
        doc.update({folder: look.to_doc() for folder, look in self.second.items()})
        if self.spec is not None:
            doc["spec"] = self.spec
        return doc

    @classmethod
    def from_doc(cls, doc: object, where: str) -> GridRow:
        d = as_object(doc, where)
        name = d.get("dir")
        if not isinstance(name, str) or not folder_name(name):
            raise InputError(f"{where}.dir: expected the site's folder name in the grid, "
                             f"got {short_repr(name)}")
        spec = d.get("spec")
        return cls(name, dict(as_object(d.get("truth"), f"{where}.truth")),
                   GridLook.from_doc(d, where),
                   {k: GridLook.from_doc(v, f"{where}.{k}") for k, v in d.items()
                    if k not in _ROW_KEYS and isinstance(v, dict)},
                   None if spec is None else dict(as_object(spec, f"{where}.spec")))
