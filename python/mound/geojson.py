"""The pieces of GeoJSON (RFC 7946) that every reader of it shares: a WGS84 [lon, lat]
position and a Point Feature, each refused with an InputError naming where it failed.
The scene's labels and AOIs (mound.scene.vector) and the survey's sites
(mound.formats.sites) read their Point features through here; the scene's candidates and
the survey's home are written by point_feature_doc."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from mound.errors import InputError
from mound.jsonio import JsonObject, JsonValue, short_repr


def lonlat(c: Any, where: str) -> tuple[float, float]:
    """A position [lon, lat, ...] in WGS84 degrees: finite numbers within +-180 / +-90."""
    if not isinstance(c, list) or len(c) < 2:
        raise InputError(f"{where}: expected [lon, lat]")
    lon, lat = c[0], c[1]
    for v, name, lim in ((lon, "longitude", 180.0), (lat, "latitude", 90.0)):
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            raise InputError(f"{where}: {name} must be a finite number, got {short_repr(v)}")
        if abs(v) > lim:
            raise InputError(f"{where}: {name} {v} outside +-{lim:g} (coordinates must be "
                             "WGS84 [lon, lat], not projected)")
    return float(lon), float(lat)


def point_feature(f: Any, where: str,
                  why: str = "") -> tuple[float, float, Mapping[str, JsonValue]]:
    """(lon, lat, properties) of a Point Feature; `why` follows "expected a Point" in the
    message when the geometry is another."""
    if not isinstance(f, dict) or f.get("type") != "Feature":
        raise InputError(f"{where}: expected a GeoJSON Feature")
    geom = f.get("geometry")
    if not isinstance(geom, dict) or geom.get("type") != "Point":
        raise InputError(f"{where}.geometry: expected a Point{why}")
    lon, lat = lonlat(geom.get("coordinates"), f"{where}.geometry.coordinates")
    props = f.get("properties") or {}
    if not isinstance(props, dict):
        raise InputError(f"{where}.properties: expected an object")
    return lon, lat, props


def point_feature_doc(lat_lon: tuple[float, float], properties: Mapping[str, JsonValue],
                      fid: str | None = None) -> JsonObject:
    """A Point Feature at (lat, lon), WGS84 ([lon, lat] as RFC 7946 orders it), with the
    feature id `fid` where given: what point_feature reads back."""
    return {"type": "Feature", **({"id": fid} if fid is not None else {}),
            "geometry": {"type": "Point", "coordinates": [lat_lon[1], lat_lon[0]]},
            "properties": properties}
