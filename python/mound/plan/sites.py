"""mound.sites documents as arrays: node 0 is home, node 1 the end node of a path."""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mound.errors import InputError
from mound.formats.sites import Sites
from mound.jsonio import JsonObject


@dataclass
class OpProblem:
    ids: list[str]
    xy: np.ndarray         # (n, 2) metres
    reward: np.ndarray     # (n,), 0 at home and end
    scan: np.ndarray       # (n,); home and end: takeoff_landing_m (0 unless given)
    budget: float          # less a path's terrain.path_offset_m (as mound_plan does)
    closed: bool           # closed tour (end == home) or path home -> node 1
    extra: np.ndarray | None = None  # (n, n) terrain.extra_m, the climbs' costs

    @property
    def end(self) -> int:
        return 0 if self.closed else 1

    def cost_matrix(self) -> np.ndarray:
        """Paper: the expanded costs c_ij = d_ij + (s_i + s_j) / 2 (INTERFACES.md), plus
        the terrain's climb costs when the document has them."""
        d = np.linalg.norm(self.xy[:, None, :] - self.xy[None, :, :], axis=2)
        c = d + 0.5 * (self.scan[:, None] + self.scan[None, :])
        return c if self.extra is None else c + self.extra

    def route_cost(self, route: list[int]) -> float:
        c = self.cost_matrix()
        return float(sum(c[a, b] for a, b in itertools.pairwise(route)))


def from_document(doc: object, budget: float | None = None) -> OpProblem:
    """The arrays of a mound.sites document (read by formats.sites.Sites: InputError naming
    the member on any defect)."""
    return from_sites(Sites.from_doc(doc, "sites"), budget)


def from_sites(doc: Sites, budget: float | None = None) -> OpProblem:
    """The arrays of a sites document: home, the end when the tour is a path, the sites;
    with the terrain's climb costs when the document has them."""
    closed = doc.closed
    # The take-off climb and landing descent, flown once per tour, as the home and end
    # nodes' cost: a closed tour pays home's twice by halves, a path home's and end's halves.
    overhead = doc.takeoff_landing_m
    nodes = [(doc.home.id, doc.home.x_m, doc.home.y_m, 0.0, overhead)]
    if not closed:
        nodes.append((doc.end.id, doc.end.x_m, doc.end.y_m, 0.0, overhead))
    nodes += [(s.id, s.x_m, s.y_m, s.reward, s.scan_cost_m) for s in doc.sites]
    extra = None
    offset = 0.0
    terrain = doc.terrain()
    if terrain is not None:
        try:
            extra = np.asarray(terrain["extra_m"], dtype=float)
            offset = 0.0 if closed else float(terrain.get("path_offset_m", 0.0))
        except (KeyError, TypeError, ValueError) as e:
            raise InputError(f"sites: terrain: malformed ({e!s:.60})") from None
        if extra.shape != (len(nodes), len(nodes)) or not np.isfinite(extra).all():
            raise InputError(f"terrain.extra_m: expected {len(nodes)} x {len(nodes)} numbers")
        extra = np.maximum(extra, extra.T)
    return OpProblem(
        ids=[n[0] for n in nodes],
        xy=np.array([[n[1], n[2]] for n in nodes], dtype=float),
        reward=np.array([n[3] for n in nodes], dtype=float),
        scan=np.array([n[4] for n in nodes], dtype=float),
        budget=float(doc.budget_m if budget is None else budget) - offset,
        closed=closed,
        extra=extra,
    )


def load(path: str | Path, budget: float | None = None) -> OpProblem:
    return from_sites(Sites.read(path), budget)


def from_classic_op_file(path: str | Path) -> JsonObject:
    """A classic orienteering benchmark file (Tsiligirides/Chao layout: "Tmax P", then
    "x y score" rows, the first the start and the second the end) as a mound.sites
    document for a start -> end path."""
    path = Path(path)
    rows = [ln.split() for ln in path.read_text().splitlines() if ln.strip()]
    try:
        budget = float(rows[0][0])
        pts = [(float(x), float(y), float(sc)) for x, y, sc in rows[1:]]
    except (IndexError, ValueError) as e:
        raise InputError(f"{path}: not a classic OP file ({e})") from None
    if len(pts) < 2:
        raise InputError(f"{path}: needs a start and an end node")
    return {
        "schema": "mound.sites", "version": 1,
        "home": {"id": "start", "x_m": pts[0][0], "y_m": pts[0][1]},
        "end": {"id": "end", "x_m": pts[1][0], "y_m": pts[1][1]},
        "budget_m": budget,
        "sites": [{"id": f"n{i}", "x_m": x, "y_m": y, "reward": sc}
                  for i, (x, y, sc) in enumerate(pts[2:], start=2)],
    }
