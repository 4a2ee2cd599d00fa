"""The candidate sites of a survey: the paper's standard field, or the user's own file.

`--sites FILE` takes a mound.sites v1 document (INTERFACES.md) or a GeoJSON
FeatureCollection of Point features ([lon, lat] in WGS84): one feature with
`"kind": "home"` (the take-off point, which becomes the ENU origin), every other one a
candidate site with properties `id` (else the feature's `id`), `p_mound` in [0, 1]
(required: unvisited sites keep the classifier's label), optional `reward` (default: the
binary entropy of p_mound) and `truth` (bool, or {"mound": bool}: needed to simulate the
flight). A top-level `budget_m` member is read as the budget. Every defect stops the run
before anything is planned or flown, with an InputError naming the file and the field.

Scan costs always come from the scan the mission flies (ScanSpec.site_cost_m), so that a
plan within the budget is a flight within it; a file's own scan_cost_m is replaced.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from mound.classify.reward import binary_entropy_bits
from mound.errors import InputError
from mound.geojson import point_feature
from mound.geometry.flight import ScanSpec
from mound.geometry.geodesy import Origin, geodetic_to_enu
from mound.jsonio import (
    JsonObject,
    check_doc,
    load_json,
    optional_number,
    require_id,
    require_number,
)

SCHEMA = "mound.sites"
VERSION = 1


@dataclass(frozen=True)
class Node:
    """Home, the end of a path, or a site's position: local east/north metres of the
    document's origin."""

    id: str
    x_m: float
    y_m: float

    def to_doc(self) -> JsonObject:
        return {"id": self.id, "x_m": self.x_m, "y_m": self.y_m}

    @classmethod
    def from_doc(cls, doc: object, where: str) -> Node:
        if not isinstance(doc, dict):
            raise InputError(f"{where}: expected an object with id, x_m, y_m")
        return cls(require_id(doc.get("id"), f"{where}.id"),
                   require_number(doc, "x_m", where), require_number(doc, "y_m", where))


@dataclass(frozen=True)
class Truth:
    """What a site is, where it is known (a simulated or an inventoried site): `mound`,
    the inventory's height, the Statlog row the standard field drew it from."""

    mound: bool
    height_m: float | None = None
    statlog_row: int | None = None
    extra: Mapping[str, Any] = field(default_factory=dict)

    def to_doc(self) -> JsonObject:
        doc: JsonObject = {"mound": self.mound}
        if self.height_m is not None:
            doc["height_m"] = self.height_m
        if self.statlog_row is not None:
            doc["statlog_row"] = self.statlog_row
        return {**doc, **self.extra}

    @classmethod
    def from_doc(cls, doc: object, where: str) -> Truth:
        if not isinstance(doc, dict) or not isinstance(doc.get("mound"), bool):
            raise InputError(f"{where}: expected {{\"mound\": true/false, ...}}")
        row = doc.get("statlog_row")
        if row is not None and (isinstance(row, bool) or not isinstance(row, int) or row < 0):
            raise InputError(f"{where}.statlog_row: expected a row number, got {row!r:.40}")
        return cls(doc["mound"], optional_number(doc, "height_m", where, lo=0.0, hi=1000.0), row,
                   {k: v for k, v in doc.items()
                    if k not in ("mound", "height_m", "statlog_row")})


@dataclass(frozen=True)
class Site:
    """A candidate site of a mound.sites document (INTERFACES.md)."""

    id: str
    x_m: float
    y_m: float
    reward: float
    scan_cost_m: float = 0.0
    p_mound: float | None = None
    truth: Truth | None = None
    extra: Mapping[str, Any] = field(default_factory=dict)

    @property
    def xy(self) -> tuple[float, float]:
        return (self.x_m, self.y_m)

    def to_doc(self) -> JsonObject:
        doc: JsonObject = {"id": self.id, "x_m": self.x_m, "y_m": self.y_m,
                           "reward": self.reward, "scan_cost_m": self.scan_cost_m}
        if self.p_mound is not None:
            doc["p_mound"] = self.p_mound
        if self.truth is not None:
            doc["truth"] = self.truth.to_doc()
        return {**doc, **self.extra}

    @classmethod
    def from_doc(cls, doc: object, where: str) -> Site:
        node = Node.from_doc(doc, where)
        assert isinstance(doc, dict)
        return cls(node.id, node.x_m, node.y_m,
                   require_number(doc, "reward", where, lo=0.0),
                   require_number(doc, "scan_cost_m", where, lo=0.0, default=0.0),
                   optional_number(doc, "p_mound", where, lo=0.0, hi=1.0),
                   None if doc.get("truth") is None
                   else Truth.from_doc(doc["truth"], f"{where}.truth"),
                   {k: v for k, v in doc.items() if k not in _SITE_KEYS})


_SITE_KEYS = ("id", "x_m", "y_m", "reward", "scan_cost_m", "p_mound", "truth")
_SITES_KEYS = ("schema", "version", "origin", "home", "end", "budget_m", "takeoff_landing_m",
               "sites")


@dataclass(frozen=True)
class Sites:
    """A mound.sites v1 document: home, the end (home itself for a closed tour), the
    budget, the sites; `extra` keeps the members this type does not read (scan, terrain,
    provenance) as they were written."""

    home: Node
    end: Node
    budget_m: float
    sites: tuple[Site, ...]
    origin: Origin | None = None
    takeoff_landing_m: float = 0.0
    extra: Mapping[str, Any] = field(default_factory=dict)

    @property
    def closed(self) -> bool:
        return self.end.id == self.home.id

    def by_id(self) -> dict[str, Site]:
        return {s.id: s for s in self.sites}

    def scan(self) -> ScanSpec | None:
        doc = self.extra.get("scan")
        return None if doc is None else ScanSpec.from_doc(doc, "sites: scan")

    def terrain(self) -> Mapping[str, Any] | None:
        """The terrain the plan's costs climb over (flightplan.terrain.attach), or None."""
        t = self.extra.get("terrain")
        return t if isinstance(t, dict) else None

    def with_sites(self, sites: Sequence[Site], **extra: object) -> Sites:
        return replace(self, sites=tuple(sites), extra={**self.extra, **extra})

    def to_doc(self) -> JsonObject:
        doc: JsonObject = {"schema": SCHEMA, "version": VERSION}
        if self.origin is not None:
            doc["origin"] = self.origin.to_doc()
        doc.update(home=self.home.to_doc(),
                   end={"id": self.home.id} if self.closed else self.end.to_doc(),
                   budget_m=self.budget_m, takeoff_landing_m=self.takeoff_landing_m)
        return {**doc, **self.extra, "sites": [s.to_doc() for s in self.sites]}

    @classmethod
    def from_doc(cls, doc: Any, path: str | Path) -> Sites:
        """The sites of a mound.sites document parsed from `path` (as the project writes
        it: every site with its reward); InputError naming the file and field."""
        doc = check_doc(doc, path, SCHEMA, VERSION)
        home = Node.from_doc(doc.get("home"), f"{path}: home")
        end = doc.get("end")
        end_node = (home if not isinstance(end, dict) or end.get("id", home.id) == home.id
                    else Node.from_doc(end, f"{path}: end"))
        raw = doc.get("sites")
        if not isinstance(raw, list) or not raw:
            raise InputError(f"{path}: sites: expected a non-empty list")
        sites = tuple(Site.from_doc(s, f"{path}: sites[{k}]") for k, s in enumerate(raw))
        ids = [s.id for s in sites]
        if len(set(ids)) != len(ids) or {home.id, end_node.id} & set(ids):
            raise InputError(f"{path}: sites: ids are not unique (or one is home's or end's)")
        origin = (Origin.from_doc(doc["origin"], f"{path}: origin")
                  if doc.get("origin") is not None else None)
        return cls(home, end_node, require_number(doc, "budget_m", str(path), lo=0.0), sites,
                   origin, require_number(doc, "takeoff_landing_m", str(path), lo=0.0,
                                          default=0.0),
                   {k: v for k, v in doc.items() if k not in _SITES_KEYS})

    @classmethod
    def read(cls, path: str | Path) -> Sites:
        return cls.from_doc(load_json(path), path)


def _number(obj: Mapping[str, object], key: str, where: str, *, lo: float = -math.inf,
            hi: float = math.inf) -> float | None:
    """obj[key] as a float in [lo, hi], None when absent or null (the user readers'
    messages: `where.key: ...`)."""
    v = obj.get(key)
    if v is None:
        return None
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        raise InputError(f"{where}.{key}: expected a finite number, got {v!r}")
    if not lo <= v <= hi:
        raise InputError(f"{where}.{key}: must be in [{lo:g}, {hi:g}], got {v!r}")
    return float(v)


def _required(obj: Mapping[str, object], key: str, where: str) -> float:
    v = _number(obj, key, where)
    if v is None:
        raise InputError(f"{where}.{key}: missing")
    return v


def _truth(value: object, where: str) -> bool | None:
    if value is None:
        return None
    if isinstance(value, dict):
        value = value.get("mound")
    if not isinstance(value, bool):
        raise InputError(f"{where}.truth: expected true/false or {{\"mound\": true/false}}, "
                         f"got {value!r}")
    return value


def _site(props: Mapping[str, object], site_id: object, x: float, y: float, where: str,
          need_p: bool = True) -> Site:
    if not isinstance(site_id, str) or not site_id.strip():
        raise InputError(f"{where}.id: expected a non-empty string, got {site_id!r}")
    p = _number(props, "p_mound", where, lo=0.0, hi=1.0)
    if p is None and need_p:
        raise InputError(f"{where}.p_mound: missing")
    reward = _number(props, "reward", where, lo=0.0)
    if reward is None:
        reward = float(binary_entropy_bits(p)) if p is not None else 0.0
    mound = _truth(props.get("truth"), where)
    truth = None
    if mound is not None:
        raw = props.get("truth")
        height = (_number(raw, "height_m", f"{where}.truth", lo=0.5, hi=60.0)
                  if mound and isinstance(raw, dict) else None)
        truth = Truth(mound, height)
    return Site(site_id, x, y, reward, p_mound=p, truth=truth)


@dataclass(frozen=True)
class _UserField:
    """What a user's sites file says before the survey's scan costs its sites."""

    origin: Origin
    home: Node
    end: Node
    budget_m: float | None
    sites: list[Site]


def _node(doc: object, where: str) -> Node:
    if not isinstance(doc, dict):
        raise InputError(f"{where}: missing (an object with id, x_m, y_m)")
    x, y = _required(doc, "x_m", where), _required(doc, "y_m", where)
    if not isinstance(doc.get("id"), str):
        raise InputError(f"{where}.id: expected a string")
    return Node(require_id(doc["id"], f"{where}.id"), x, y)


def _from_mound_sites(doc: Mapping[str, object], path: Path, need_p: bool) -> _UserField:
    version = doc.get("version")
    if version != 1:
        raise InputError(f"{path}: version: unsupported mound.sites version {version!r}")
    given = doc.get("origin")
    if not isinstance(given, dict):
        raise InputError(f"{path}: origin: missing (the mission needs the WGS84 origin of "
                         "x_m/y_m: {\"lat\", \"lon\", \"alt_m\"})")
    origin = Origin.from_doc(given, f"{path}: origin")
    home = _node(doc.get("home"), f"{path}: home")
    end = doc.get("end")
    end_node = (_node(end, f"{path}: end")
                if isinstance(end, dict) and end.get("id", home.id) != home.id else home)
    budget = _number(doc, "budget_m", str(path), lo=0.0)
    sites = doc.get("sites")
    if not isinstance(sites, list) or not sites:
        raise InputError(f"{path}: sites: expected a non-empty list")
    rows = []
    for k, s in enumerate(sites):
        where = f"{path}: sites[{k}]"
        if not isinstance(s, dict):
            raise InputError(f"{where}: expected an object")
        rows.append(_site(s, s.get("id"), _required(s, "x_m", where),
                          _required(s, "y_m", where), where, need_p))
    return _UserField(origin, home, end_node, budget, rows)


def _from_geojson(doc: Mapping[str, object], path: Path, need_p: bool) -> _UserField:
    features = doc.get("features")
    if not isinstance(features, list) or not features:
        raise InputError(f"{path}: features: expected a non-empty list of Point features")
    home = None
    points = []
    for k, f in enumerate(features):
        where = f"{path}: features[{k}]"
        lon, lat, props = point_feature(f, where)
        if props.get("kind") == "home":
            if home is not None:
                raise InputError(f"{where}: a second feature with kind 'home'")
            alt = _number(props, "alt_m", f"{where}.properties", lo=-1e5, hi=1e5) or 0.0
            home = Origin(lat, lon, alt)
        else:
            points.append((k, lat, lon, props, props.get("id", f.get("id"))))
    if home is None:
        raise InputError(f"{path}: features: no feature with properties.kind = 'home' (the "
                         "take-off point, the origin of the survey's local frame)")
    if not points:
        raise InputError(f"{path}: features: no candidate site besides home")
    llh = np.array([[lat, lon, home.alt_m] for _, lat, lon, _, _ in points])
    enu = geodetic_to_enu(home, llh)
    rows = [_site(props, sid, float(e[0]), float(e[1]), f"{path}: features[{k}].properties",
                  need_p)
            for (k, _, _, props, sid), e in zip(points, enu, strict=True)]
    at_home = Node("home", 0.0, 0.0)
    return _UserField(home, at_home, at_home, _number(doc, "budget_m", str(path), lo=0.0),
                      rows)


def load_user_sites(path: str | Path, scan: ScanSpec, budget_m: float | None,
                    default_budget_m: float, need_truth: bool,
                    need_p_mound: bool = True) -> Sites:
    """The run's sites from the user's file; InputError on any defect.
    `need_truth`: every site must carry its truth (the flights are simulated);
    `need_p_mound`: every site its p_mound (a survey's unvisited sites keep the
    classifier's label; sorting photos needs only where the sites are)."""
    path = Path(path)
    return user_sites(load_json(path), path, scan, budget_m,
                      default_budget_m, need_truth, need_p_mound)


def user_sites(doc: Any, path: Path, scan: ScanSpec, budget_m: float | None,
               default_budget_m: float, need_truth: bool,
               need_p_mound: bool = True) -> Sites:
    """load_user_sites of a document already parsed from `path`."""
    if not isinstance(doc, dict):
        raise InputError(f"{path}: expected a JSON object (mound.sites or GeoJSON)")
    if doc.get("schema") == "mound.sites":
        given = _from_mound_sites(doc, path, need_p_mound)
    elif doc.get("type") == "FeatureCollection":
        given = _from_geojson(doc, path, need_p_mound)
    else:
        raise InputError(f"{path}: schema: neither a mound.sites document nor a GeoJSON "
                         "FeatureCollection (type)")
    seen = {given.home.id, given.end.id}
    for k, r in enumerate(given.sites):
        if r.id in seen:
            raise InputError(f"{path}: sites[{k}].id: {r.id!r} is not unique (or is the "
                             "home/end id)")
        require_id(r.id, f"{path}: sites[{k}].id")
        seen.add(r.id)
        if need_truth and r.truth is None:
            raise InputError(f"{path}: sites[{k}].truth: missing; the flights are simulated "
                             "from each site's truth (or give --images-root with the photos)")
    budget = budget_m if budget_m is not None else (
        given.budget_m if given.budget_m is not None else default_budget_m)
    if not budget > 0:
        raise InputError("budget_m: must be > 0")
    cost = scan.site_cost_m()
    sites = tuple(replace(r, scan_cost_m=cost) for r in given.sites)
    return Sites(given.home, given.end, float(budget), sites, given.origin,
                 scan.takeoff_landing_m(),
                 {"scan": scan.to_doc(),
                  "provenance": {"tool": "python/mission.py --sites", "source": str(path),
                                 "total_reward": float(sum(r.reward for r in sites)),
                                 "positives": sum(bool(r.truth and r.truth.mound)
                                                  for r in sites)}})
