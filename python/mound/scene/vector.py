"""The GeoJSON readers of the scene workflow: known mounds (labels) and areas of interest.

RFC 7946 GeoJSON: coordinates are WGS84 [longitude, latitude]. A top-level `crs` member
(GeoJSON 2008) is accepted only when it names WGS84 (OGC CRS84 or EPSG:4326); any other
CRS is refused rather than guessed. Every defect is an InputError naming the file and the
feature.

Labels: Point features; `properties.kind` is `mound` or `not_mound` (absent: a mound);
other properties (`height_m`, `visibility`, `land_use`, an id) are carried along.
AOI: Polygon or MultiPolygon geometries (bare, as Features, or a FeatureCollection of them).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mound.errors import InputError
from mound.geojson import lonlat, point_feature
from mound.jsonio import JsonObject, JsonValue, load_json, short_repr

WGS84_NAMES = ("urn:ogc:def:crs:OGC:1.3:CRS84", "urn:ogc:def:crs:OGC::CRS84", "CRS84",
               "EPSG:4326", "urn:ogc:def:crs:EPSG::4326", "urn:ogc:def:crs:EPSG:6.6:4326",
               "WGS84", "WGS 84")


@dataclass
class Label:
    lon: float
    lat: float
    mound: bool
    id: str
    props: Mapping[str, JsonValue] = field(default_factory=dict)  # the feature's properties


def _load(path: str | Path) -> JsonObject:
    path = Path(path)
    doc = load_json(path)
    if not isinstance(doc, dict):
        raise InputError(f"{path}: expected a GeoJSON object")
    crs = doc.get("crs")
    if crs is not None:
        name = crs.get("properties", {}).get("name") if isinstance(crs, dict) else None
        if not isinstance(name, str) or name.strip() not in WGS84_NAMES:
            raise InputError(f"{path}: crs: {short_repr(name)} is not WGS84; GeoJSON "
                             "coordinates must be WGS84 longitude, latitude (RFC 7946)")
    return doc


def _features(doc: dict[str, Any], path: Path) -> list[dict[str, Any]]:
    t = doc.get("type")
    if t == "FeatureCollection":
        feats = doc.get("features")
        if not isinstance(feats, list):
            raise InputError(f"{path}: features: expected a list")
        return feats
    if t == "Feature":
        return [doc]
    if t in ("Point", "Polygon", "MultiPolygon", "MultiPoint"):
        return [{"type": "Feature", "geometry": doc, "properties": {}}]
    raise InputError(f"{path}: type: expected a GeoJSON FeatureCollection, Feature or "
                     f"geometry, got {short_repr(t)}")


def read_labels(path: str | Path) -> list[Label]:
    path = Path(path)
    doc = _load(path)
    out = []
    for k, f in enumerate(_features(doc, path)):
        where = f"{path}: features[{k}]"
        lon, lat, props = point_feature(f, where, " (labels are points)")
        kind = props.get("kind", "mound")
        if kind not in ("mound", "not_mound"):
            raise InputError(f"{where}.properties.kind: expected 'mound' or 'not_mound', got "
                             f"{short_repr(kind)}")
        fid = props.get("id", f.get("id", props.get("trap_code", k)))
        h = props.get("height_m")
        if h is not None and (isinstance(h, bool) or not isinstance(h, int | float)
                              or not math.isfinite(h) or not 0 <= h < 1000):
            raise InputError(f"{where}.properties.height_m: expected metres in [0, 1000)")
        out.append(Label(lon, lat, kind == "mound", str(fid)[:64], props))
    if not out:
        raise InputError(f"{path}: no label points")
    return out


def read_aoi(path: str | Path) -> list[list[list[tuple[float, float]]]]:
    """Polygons as lists of rings of (lon, lat); InputError for anything else."""
    path = Path(path)
    doc = _load(path)
    polys: list[list[list[tuple[float, float]]]] = []
    for k, f in enumerate(_features(doc, path)):
        where = f"{path}: features[{k}]"
        if not isinstance(f, dict):
            raise InputError(f"{where}: expected a GeoJSON Feature")
        geom = f.get("geometry")
        if not isinstance(geom, dict) or geom.get("type") not in ("Polygon", "MultiPolygon"):
            raise InputError(f"{where}.geometry: expected a Polygon or MultiPolygon")
        coords = geom.get("coordinates")
        parts = [coords] if geom["type"] == "Polygon" else coords
        if not isinstance(parts, list) or not parts:
            raise InputError(f"{where}.geometry.coordinates: expected polygon rings")
        for pk, rings in enumerate(parts):
            if not isinstance(rings, list) or not rings:
                raise InputError(f"{where}.geometry.coordinates[{pk}]: expected rings")
            poly = []
            for rk, ring in enumerate(rings):
                w = f"{where}.geometry.coordinates[{pk}][{rk}]"
                if not isinstance(ring, list) or len(ring) < 4:
                    raise InputError(f"{w}: a ring needs at least 4 positions")
                if len(ring) > 1_000_000:
                    raise InputError(f"{w}: more than 1,000,000 positions")
                poly.append([lonlat(c, w) for c in ring])
            polys.append(poly)
    if not polys:
        raise InputError(f"{path}: no polygon")
    return polys


def labels_in_scene(labels: list[Label], scene: Any) -> tuple[np.ndarray, np.ndarray,
                                                             np.ndarray]:
    """(x, y) in the scene's CRS of every label and whether it falls inside the scene."""
    from mound.scene.raster import transformer_to_scene

    if not labels:
        return np.zeros(0), np.zeros(0), np.zeros(0, dtype=bool)
    tr = transformer_to_scene(scene)
    x, y = tr.transform(np.array([lb.lon for lb in labels]), np.array([lb.lat for lb in labels]))
    x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    w, s, e, n = scene.bounds()
    inside = np.isfinite(x) & np.isfinite(y) & (x >= w) & (x < e) & (y > s) & (y <= n)
    return x, y, inside
