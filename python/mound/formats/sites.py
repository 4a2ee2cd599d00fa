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
from mound.jsonio import check_doc, load_json, optional_number, require_id, require_number

SCHEMA = "mound.sites"
VERSION = 1


@dataclass(frozen=True)
class Node:
    """Home, the end of a path, or a site's position: local east/north metres of the
    document's origin."""

    id: str
    x_m: float
    y_m: float

    def to_doc(self) -> dict[str, object]:
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

    def to_doc(self) -> dict[str, object]:
        doc: dict[str, object] = {"mound": self.mound}
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

    def to_doc(self) -> dict[str, object]:
        doc: dict[str, object] = {"id": self.id, "x_m": self.x_m, "y_m": self.y_m,
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
        """The terrain the plan's costs climb over (uav.terrain.attach), or None."""
        t = self.extra.get("terrain")
        return t if isinstance(t, dict) else None

    def with_sites(self, sites: Sequence[Site], **extra: object) -> Sites:
        return replace(self, sites=tuple(sites), extra={**self.extra, **extra})

    def to_doc(self) -> dict[str, Any]:
        doc: dict[str, Any] = {"schema": SCHEMA, "version": VERSION}
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


def _number(obj: dict[str, Any], key: str, where: str, *, lo: float = -math.inf,
            hi: float = math.inf, required: bool = True) -> float | None:
    if key not in obj or obj[key] is None:
        if required:
            raise InputError(f"{where}.{key}: missing")
        return None
    v = obj[key]
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        raise InputError(f"{where}.{key}: expected a finite number, got {v!r}")
    if not lo <= v <= hi:
        raise InputError(f"{where}.{key}: must be in [{lo:g}, {hi:g}], got {v!r}")
    return float(v)


def _truth(value: Any, where: str) -> bool | None:
    if value is None:
        return None
    if isinstance(value, dict):
        value = value.get("mound")
    if not isinstance(value, bool):
        raise InputError(f"{where}.truth: expected true/false or {{\"mound\": true/false}}, "
                         f"got {value!r}")
    return value


def _site(props: dict[str, Any], site_id: Any, x: float, y: float, where: str,
          need_p: bool = True) -> dict[str, Any]:
    if not isinstance(site_id, str) or not site_id.strip():
        raise InputError(f"{where}.id: expected a non-empty string, got {site_id!r}")
    p = _number(props, "p_mound", where, lo=0.0, hi=1.0, required=need_p)
    reward = _number(props, "reward", where, lo=0.0, required=False)
    if reward is None:
        reward = float(binary_entropy_bits(p)) if p is not None else 0.0
    site: dict[str, Any] = {"id": site_id, "x_m": x, "y_m": y, "reward": reward,
                            **({"p_mound": p} if p is not None else {})}
    truth = _truth(props.get("truth"), where)
    if truth is not None:
        site["truth"] = {"mound": truth}
        raw = props.get("truth")
        if truth and isinstance(raw, dict) and raw.get("height_m") is not None:
            site["truth"]["height_m"] = _number(raw, "height_m", f"{where}.truth", lo=0.5,
                                                hi=60.0)
    return site


def _from_mound_sites(doc: dict[str, Any], path: Path, need_p: bool
                      ) -> tuple[dict[str, Any], list[Any]]:
    version = doc.get("version")
    if version != 1:
        raise InputError(f"{path}: version: unsupported mound.sites version {version!r}")
    if not isinstance(doc.get("origin"), dict):
        raise InputError(f"{path}: origin: missing (the mission needs the WGS84 origin of "
                         "x_m/y_m: {\"lat\", \"lon\", \"alt_m\"})")
    origin = Origin.from_doc(doc["origin"], f"{path}: origin")
    home = doc.get("home")
    if not isinstance(home, dict):
        raise InputError(f"{path}: home: missing (an object with id, x_m, y_m)")
    hx = _number(home, "x_m", f"{path}: home")
    hy = _number(home, "y_m", f"{path}: home")
    if not isinstance(home.get("id"), str):
        raise InputError(f"{path}: home.id: expected a string")
    out: dict[str, Any] = {"origin": origin.to_doc(),
                           "home": {"id": home["id"], "x_m": hx, "y_m": hy}}
    end = doc.get("end")
    if isinstance(end, dict) and end.get("id", home["id"]) != home["id"]:
        out["end"] = {"id": str(end["id"]), "x_m": _number(end, "x_m", f"{path}: end"),
                      "y_m": _number(end, "y_m", f"{path}: end")}
    else:
        out["end"] = {"id": home["id"]}
    budget = _number(doc, "budget_m", str(path), lo=0.0, required=False)
    if budget is not None:
        out["budget_m"] = budget
    sites = doc.get("sites")
    if not isinstance(sites, list) or not sites:
        raise InputError(f"{path}: sites: expected a non-empty list")
    rows = []
    for k, s in enumerate(sites):
        where = f"{path}: sites[{k}]"
        if not isinstance(s, dict):
            raise InputError(f"{where}: expected an object")
        rows.append(_site(s, s.get("id"), _number(s, "x_m", where),  # type: ignore[arg-type]
                          _number(s, "y_m", where), where, need_p))  # type: ignore[arg-type]
    return out, rows


def _from_geojson(doc: dict[str, Any], path: Path, need_p: bool
                  ) -> tuple[dict[str, Any], list[Any]]:
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
            alt = _number(props, "alt_m", f"{where}.properties", required=False) or 0.0
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
    out: dict[str, Any] = {"origin": home.to_doc(), "home": {"id": "home", "x_m": 0.0,
                                                            "y_m": 0.0},
                           "end": {"id": "home"}}
    budget = _number(doc, "budget_m", str(path), lo=0.0, required=False)
    if budget is not None:
        out["budget_m"] = budget
    return out, rows


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
        head, rows = _from_mound_sites(doc, path, need_p_mound)
    elif doc.get("type") == "FeatureCollection":
        head, rows = _from_geojson(doc, path, need_p_mound)
    else:
        raise InputError(f"{path}: schema: neither a mound.sites document nor a GeoJSON "
                         "FeatureCollection (type)")
    ids = [head["home"]["id"], head["end"]["id"]]
    seen = set(ids)
    for k, r in enumerate(rows):
        if r["id"] in seen:
            raise InputError(f"{path}: sites[{k}].id: {r['id']!r} is not unique (or is the "
                             "home/end id)")
        seen.add(r["id"])
        if need_truth and "truth" not in r:
            raise InputError(f"{path}: sites[{k}].truth: missing; the flights are simulated "
                             "from each site's truth (or give --images-root with the photos)")
        r["scan_cost_m"] = scan.site_cost_m()
    budget = budget_m if budget_m is not None else head.pop("budget_m", default_budget_m)
    head.pop("budget_m", None)
    if not budget > 0:
        raise InputError("budget_m: must be > 0")
    return Sites.from_doc(
        {"schema": SCHEMA, "version": VERSION, **head, "budget_m": float(budget),
         "scan": scan.to_doc(), "takeoff_landing_m": scan.takeoff_landing_m(),
         "sites": rows,
         "provenance": {"tool": "python/mission.py --sites", "source": str(path),
                        "total_reward": float(sum(r["reward"] for r in rows)),
                        "positives": sum(bool(r.get("truth", {}).get("mound"))
                                         for r in rows)}}, path)
