"""A site's row of a verdict grid (GRID/grid.json, mound.verdict_grid v1, `rows[k]`), as
`mound sim grid` writes it: the site's folder, its truth, how its verdict came out (status,
the steps' times in seconds, the first look's p_mound, why it failed), the second looks
flown at it by folder, and the draw it was simulated from (`spec`).

The rows are read back with the site's verdict by mound.training.verdict_data.load_grid.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from mound.jsonio import JsonObject

SCHEMA = "mound.verdict_grid"
VERSION = 1


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
