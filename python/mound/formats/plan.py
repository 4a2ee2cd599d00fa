"""mound.plan v1 (INTERFACES.md `plan.json`): the flights `mound_plan` (or `mound plan exact`,
or the survey's second look) chose, as one typed value.

`Plan.read(path)` validates once what the Python side uses — the flights' tours (ids,
each site at most once per flight), rewards, costs, the budget, the origin, the waypoints
(`Waypoint`: each node's position, kind and scan cost) — and keeps every other member (the
solver's figures, scan, terrain) as it was written, so that `Plan.to_doc()` writes the
document back with the same members. A plan written by hand (for
`mound mission build` or `mound photos sort`) may leave out the flights' rewards and costs
(the mission builder measures a flight itself); `Plan.reward` and `Plan.cost_m` then say
so with an InputError instead of a number. A plan made in Python
(`Plan.of_flights`) has the same members as one `mound_plan` writes: `tour` the first
flight's, `reward` and `cost_m` the sums, `flights` always present.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mound.errors import InputError
from mound.geometry.flight import ScanSpec
from mound.geometry.geodesy import Origin
from mound.jsonio import (
    JsonObject,
    check_doc,
    load_json,
    optional_number,
    require_id,
    require_number,
    short_repr,
)

SCHEMA = "mound.plan"
VERSION = 1
MAX_M = 1e9  # the largest budget or cost read (a million kilometres)
# Magnitudes a plan's waypoints can have (the same bounds as mound_plan's reader): local
# coordinates within 10^8 m, scan costs within 10^8 m.
MAX_COORD_M = 1e8
MAX_COST_M = 1e8
WAYPOINT_KINDS = ("home", "site", "end")

# The members Plan types; the rest travel in `extra`.
_TYPED = ("schema", "version", "status", "algo", "tour", "flights", "reward", "cost_m",
          "budget_m", "budget_left_m", "closed", "origin", "waypoints")


@dataclass(frozen=True)
class Waypoint:
    """A node of the plan's `waypoints` (mound_plan writes home, the sites and the end):
    where (ENU metres about the plan's origin), what it is, its scan cost; the solver's
    other figures (reward, cum_cost_m, flight) as written."""

    id: str
    x_m: float
    y_m: float
    kind: str = "site"
    scan_cost_m: float = 0.0
    extra: Mapping[str, Any] = field(default_factory=dict)

    def to_doc(self) -> JsonObject:
        return {**self.extra, "id": self.id, "kind": self.kind, "x_m": self.x_m,
                "y_m": self.y_m, "scan_cost_m": self.scan_cost_m}

    @classmethod
    def from_doc(cls, doc: object, where: str) -> Waypoint:
        if not isinstance(doc, dict) or "id" not in doc:
            raise InputError(f"{where}: expected an object with an id")
        kind = doc.get("kind", "site")
        if kind not in WAYPOINT_KINDS:
            raise InputError(f"{where}.kind: expected home, site or end, got {kind!r:.40}")
        return cls(require_id(doc["id"], f"{where}.id"),
                   require_number(doc, "x_m", where, lo=-MAX_COORD_M, hi=MAX_COORD_M),
                   require_number(doc, "y_m", where, lo=-MAX_COORD_M, hi=MAX_COORD_M), kind,
                   require_number(doc, "scan_cost_m", where, lo=0, hi=MAX_COST_M,
                                  default=0.0),
                   {k: v for k, v in doc.items()
                    if k not in ("id", "x_m", "y_m", "kind", "scan_cost_m")})


def _waypoints(value: object, where: str) -> tuple[Waypoint, ...]:
    if value is None:
        return ()
    if not isinstance(value, list):
        raise InputError(f"{where}: expected a list of {{id, kind, x_m, y_m, scan_cost_m}}")
    return tuple(Waypoint.from_doc(w, f"{where}[{k}]") for k, w in enumerate(value))


@dataclass(frozen=True)
class Flight:
    """One flight: home (or start), the sites in the order flown, home (or end)."""

    tour: tuple[str, ...]
    reward: float | None       # None: a plan written by hand that does not say
    cost_m: float | None
    budget_left_m: float | None

    @property
    def sites(self) -> tuple[str, ...]:
        """The sites visited, in order (the tour less its two ends)."""
        return self.tour[1:-1]

    def to_doc(self, number: int) -> JsonObject:
        doc: JsonObject = {"flight": number, "tour": list(self.tour)}
        for k in ("reward", "cost_m", "budget_left_m"):
            if getattr(self, k) is not None:
                doc[k] = getattr(self, k)
        return doc

    @classmethod
    def from_doc(cls, doc: object, where: str) -> Flight:
        if not isinstance(doc, dict):
            raise InputError(f"{where}: expected an object with a tour")
        return cls(_tour(doc.get("tour"), f"{where}.tour"),
                   optional_number(doc, "reward", where, lo=0, hi=1e12),
                   optional_number(doc, "cost_m", where, lo=0, hi=MAX_M),
                   optional_number(doc, "budget_left_m", where, lo=-MAX_M, hi=MAX_M))


def _said(value: float | None, where: str) -> float:
    if value is None:
        raise InputError(f"plan: {where}: missing (a plan written by hand?)")
    return value


def _tour(value: object, where: str) -> tuple[str, ...]:
    if not isinstance(value, list) or len(value) < 2:
        raise InputError(f"{where}: expected a list of ids from home to home (or end)")
    tour = tuple(require_id(sid, f"{where}[{i}]") for i, sid in enumerate(value))
    inner = tour[1:-1]
    if len(set(inner)) != len(inner):
        raise InputError(f"{where}: a site visited twice")
    return tour


@dataclass(frozen=True)
class Plan:
    """A mound.plan document: `flights` (at least one; a plan without a `flights` member is
    its `tour` as one flight) within `budget_m` each."""

    algo: str
    flights: tuple[Flight, ...]
    budget_m: float
    closed: bool
    origin: Origin | None = None
    status: str = "ok"
    extra: Mapping[str, Any] = field(default_factory=dict)
    # mound_plan's waypoints: home, the sites and the end, with positions and costs
    waypoints: tuple[Waypoint, ...] = ()

    @property
    def home(self) -> str:
        return self.flights[0].tour[0]

    @property
    def end(self) -> str:
        return self.flights[0].tour[-1]

    @property
    def reward(self) -> float:
        """The flights' total reward; InputError for a plan that does not say."""
        return sum(_said(f.reward, f"flights[{k}].reward") for k, f in enumerate(self.flights))

    @property
    def cost_m(self) -> float:
        """The flights' total cost; InputError for a plan that does not say."""
        return sum(_said(f.cost_m, f"flights[{k}].cost_m") for k, f in enumerate(self.flights))

    @property
    def budget_left_m(self) -> float:
        """The budget of all flights less their cost; InputError for a plan that does not
        say its costs."""
        return self.budget_m * len(self.flights) - self.cost_m

    def visit_order(self) -> list[str]:
        """Every site any flight visits, once, in the order flown."""
        return list(dict.fromkeys(s for f in self.flights for s in f.sites))

    def visited(self) -> set[str]:
        return set(self.visit_order())

    def scan(self) -> ScanSpec | None:
        """The scan the plan's site costs were derived from (its sites document's `scan`,
        carried along by mound_plan), or None."""
        doc = self.extra.get("scan")
        return None if doc is None else ScanSpec.from_doc(doc, "plan: scan")

    def to_doc(self) -> JsonObject:
        doc: JsonObject = {"schema": SCHEMA, "version": VERSION, "status": self.status,
                           "algo": self.algo, **self.extra,
                           "closed": self.closed, "tour": list(self.flights[0].tour),
                           "flights": [f.to_doc(k + 1) for k, f in
                                       enumerate(self.flights)],
                           "budget_m": self.budget_m}
        if all(f.reward is not None for f in self.flights):
            doc["reward"] = self.reward
        if all(f.cost_m is not None for f in self.flights):
            doc["cost_m"] = self.cost_m
            doc["budget_left_m"] = self.budget_left_m
        if self.origin is not None:
            doc["origin"] = self.origin.to_doc()
        if self.waypoints:
            doc["waypoints"] = [w.to_doc() for w in self.waypoints]
        return doc

    @classmethod
    def of_flights(cls, algo: str, tours: Sequence[Sequence[str]], rewards: Sequence[float],
                   costs_m: Sequence[float], budget_m: float, closed: bool,
                   origin: Origin | None = None, waypoints: Sequence[Waypoint] = (),
                   **extra: object) -> Plan:
        """A plan made in Python (an exact solver's, the second look's): one flight per
        tour; `extra` members (solver, scan, ...) are written as given."""
        flights = tuple(Flight(tuple(t), float(r), float(c), float(budget_m - c))
                        for t, r, c in zip(tours, rewards, costs_m, strict=True))
        if not flights:
            raise ValueError("a plan has at least one flight")
        return cls(algo, flights, float(budget_m), closed, origin, "ok", dict(extra),
                   tuple(waypoints))

    @classmethod
    def from_doc(cls, doc: Any, path: str | Path) -> Plan:
        """The plan of a document parsed from `path`; InputError naming the file and the
        field on any defect."""
        doc = check_doc(doc, path, SCHEMA, VERSION)
        where = f"{path}: "
        if doc.get("status", "ok") != "ok":
            raise InputError(f"{where}status: {doc.get('status')!r}, not a plan to fly "
                             f"({doc.get('reason', 'no reason given')})")
        raw = doc.get("flights")
        flights: tuple[Flight, ...]
        if raw is None:
            top = f"{path}: plan"
            flights = (Flight(_tour(doc.get("tour"), f"{where}tour"),
                              optional_number(doc, "reward", top, lo=0, hi=1e12),
                              optional_number(doc, "cost_m", top, lo=0, hi=MAX_M),
                              optional_number(doc, "budget_left_m", top, lo=-MAX_M, hi=MAX_M)),)
        elif isinstance(raw, list) and raw:
            flights = tuple(Flight.from_doc(f, f"{where}flights[{k}]")
                            for k, f in enumerate(raw))
        else:
            raise InputError(f"{where}flights: expected a non-empty list of "
                             "{tour, reward, cost_m, budget_left_m}")
        ends = {(f.tour[0], f.tour[-1]) for f in flights}
        if len(ends) != 1:
            raise InputError(f"{where}flights: the flights start or end at different nodes")
        closed = doc.get("closed", flights[0].tour[0] == flights[0].tour[-1])
        if not isinstance(closed, bool):
            raise InputError(f"{where}plan.closed: expected true or false, got "
                             f"{short_repr(closed)}")
        algo = doc.get("algo", "")
        if not isinstance(algo, str):
            raise InputError(f"{where}algo: expected a string")
        origin = (Origin.from_doc(doc["origin"], f"{where}origin")
                  if doc.get("origin") is not None else None)
        return cls(algo, flights, require_number(doc, "budget_m", f"{path}: plan", lo=0, hi=MAX_M),
                   closed, origin, "ok",
                   {k: v for k, v in doc.items() if k not in _TYPED},
                   _waypoints(doc.get("waypoints"), f"{where}waypoints"))

    @classmethod
    def read(cls, path: str | Path) -> Plan:
        return cls.from_doc(load_json(path), path)
