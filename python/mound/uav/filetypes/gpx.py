"""GPX 1.1 of a flight, for ground crews (a GPS handheld, OsmAnd, QGIS): the take-off
point and each site as waypoints (`wpt`, `type` home or site, named by the site's id),
and the flown route as one track (`trk`, one `trkseg`, a `trkpt` per route waypoint).

Heights: `ele` is metres above mean sea level: home's ground (the DEM's, EGM96, over a
DEM; else the origin's stated altitude) plus the route's height above home, as GPX
readers expect; `metadata/desc` says which. What a GPX point cannot say (the leg's speed,
photo spacing, gimbal pitch and heading, the flight's end) rides in each `trkpt`'s and the
`trk`'s `extensions` in this project's namespace, so that a round trip compares the whole
route; a track without them reads back as positions and heights only.

Written with ElementTree; read back with defusedxml (no DTDs or entities); the tests read
it with gpxpy, an independent reader.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from mound.errors import InputError
from mound.geometry.geodesy import enu_to_geodetic
from mound.jsonio import number_text, parse_xml, read_text
from mound.uav import files
from mound.uav.mission_format import About, Content, FileFormat, Record, WriteOptions
from mound.uav.mission_items import Mission
from mound.uav.route import NADIR_DEG, Route, RoutePoint, mission_route

GPX_NS = "http://www.topografix.com/GPX/1/1"
NS = "https://github.com/mound-survey/gpx/1"   # this project's extensions
MAX_POINTS = 100_000
ET.register_namespace("", GPX_NS)   # the written document's prefixes
ET.register_namespace("mound", NS)


def _sub(parent: ET.Element, tag: str, text: str | None = None, **attrib: str) -> ET.Element:
    el = ET.SubElement(parent, f"{{{GPX_NS}}}{tag}", attrib)
    if text is not None:
        el.text = text
    return el


def _point(parent: ET.Element, tag: str, lat: float, lon: float, ele: float | None
           ) -> ET.Element:
    el = _sub(parent, tag, lat=f"{lat:.8f}", lon=f"{lon:.8f}")
    if ele is not None:
        _sub(el, "ele", f"{ele:.3f}")
    return el


def gpx_text(m: Mission) -> str:
    """The GPX of mission `m`."""
    route = mission_route(m)
    home = files.home_altitude(m)
    root = ET.Element(f"{{{GPX_NS}}}gpx", {"version": "1.1", "creator": "mound-survey"})
    meta = _sub(root, "metadata")
    _sub(meta, "name", f"mound-survey flight, {len(m.sites)} sites")
    _sub(meta, "desc", "ele: metres above mean sea level: home's ground "
         + ("(the DEM's, EGM96)" if m.terrain else "(the origin's stated altitude)")
         + " plus the height above home")
    wpt = _point(root, "wpt", route.home_lat_deg, route.home_lon_deg, home)
    _sub(wpt, "name", "home")
    _sub(wpt, "desc", "take-off point")
    _sub(wpt, "type", "home")
    if m.sites:
        enu = np.array([[s.x_m, s.y_m, 0.0] for s in m.sites])
        for s, (lat, lon, _) in zip(m.sites, enu_to_geodetic(m.origin, enu), strict=True):
            w = _point(root, "wpt", float(lat), float(lon), s.ground_amsl_m)
            _sub(w, "name", s.id)
            _sub(w, "desc", f"scan {s.scan_length_m:.0f} m, {s.images} images")
            _sub(w, "type", "site")
    trk = _sub(root, "trk")
    _sub(trk, "name", "flight")
    _sub(trk, "type", "uav_flight")
    ET.SubElement(_sub(trk, "extensions"), f"{{{NS}}}end").text = route.end
    seg = _sub(trk, "trkseg")
    for p in route.points:
        pt = _point(seg, "trkpt", p.lat_deg, p.lon_deg, home + p.height_m)
        leg = {"speed_m_s": f"{p.speed_m_s:g}", "photo_every_m": f"{p.photo_every_m:g}",
               "gimbal_pitch_deg": f"{p.gimbal_pitch_deg:.4f}"}
        if p.heading_deg is not None:
            leg["heading_deg"] = f"{p.heading_deg:.4f}"
        ET.SubElement(_sub(pt, "extensions"), f"{{{NS}}}leg", leg)
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, "unicode") + "\n"


def _latlon_ele(el: Any, ns: str, where: str) -> tuple[float, float, float | None]:
    lat = number_text(el.get("lat") or "", f"{where}: lat", -90.0, 90.0)
    lon = number_text(el.get("lon") or "", f"{where}: lon", -180.0, 180.0)
    ele = el.findtext(f"{ns}ele")
    return lat, lon, None if ele is None else number_text(ele, f"{where}: ele", -1e4, 1e5)


def _leg(el: Any, where: str) -> RoutePoint:
    """The leg of a trkpt from this project's extension (else a nadir leg, speed 0); the
    position and height are the caller's."""
    leg = el.find(f"{{{GPX_NS}}}extensions/{{{NS}}}leg")
    values = {"speed_m_s": 0.0, "photo_every_m": 0.0, "gimbal_pitch_deg": NADIR_DEG}
    ranges = {"speed_m_s": (0.0, 100.0), "photo_every_m": (0.0, 1e4),
              "gimbal_pitch_deg": (-90.0, 90.0)}
    heading = None
    if leg is not None:
        for key, (lo, hi) in ranges.items():
            if leg.get(key) is not None:
                values[key] = number_text(leg.get(key), f"{where}: {key}", lo, hi)
        if leg.get("heading_deg") is not None:
            heading = number_text(leg.get("heading_deg"), f"{where}: heading_deg", -180.0,
                                  180.0)
    return RoutePoint(0.0, 0.0, 0.0, values["speed_m_s"], values["photo_every_m"],
                      values["gimbal_pitch_deg"], heading)


def read_gpx(path: str | Path) -> tuple[str, Route]:
    """(what the file is, the route of its first track) of a GPX 1.1 file; heights above
    its `home` waypoint (else above the track's first point). InputError naming the file
    and the element for anything else."""
    root = parse_xml(read_text(path).encode(), str(path))
    if root.tag != f"{{{GPX_NS}}}gpx":
        raise InputError(f"{path}: not GPX 1.1 (root element {str(root.tag)[:60]!r})")
    ns = f"{{{GPX_NS}}}"
    trk = root.find(f"{ns}trk")
    if trk is None:
        raise InputError(f"{path}: no trk (a track of the flight)")
    points = [p for seg in trk.findall(f"{ns}trkseg") for p in seg.findall(f"{ns}trkpt")]
    if not 2 <= len(points) <= MAX_POINTS:
        raise InputError(f"{path}: trk: {len(points)} track points (need 2..{MAX_POINTS})")
    home = next((w for w in root.findall(f"{ns}wpt") if w.findtext(f"{ns}type") == "home"),
                None)
    lat0, lon0, ele0 = _latlon_ele(points[0] if home is None else home, ns,
                                   f"{path}: {'trkpt 0' if home is None else 'home wpt'}")
    base = ele0 or 0.0
    out = []
    for k, el in enumerate(points):
        where = f"{path}: trkpt {k}"
        lat, lon, ele = _latlon_ele(el, ns, where)
        out.append(replace(_leg(el, where), lat_deg=lat, lon_deg=lon,
                           height_m=(base if ele is None else ele) - base))
    end = trk.findtext(f"{ns}extensions/{{{NS}}}end")
    what = (f"GPX track, {len(root.findall(f'{ns}wpt'))} waypoints, heights above "
            + ("the first track point" if home is None else "the home waypoint"))
    return what, Route(lat0, lon0, tuple(out),
                       end if end in ("home", "land") else "unknown")


class Gpx(FileFormat):
    def describe(self, m: Mission, opts: WriteOptions) -> About:
        return {"heights": "ele above mean sea level (home's ground + height above home)"}

    def write(self, m: Mission, path: Path, opts: WriteOptions,
              record: Record) -> list[tuple[Path, Content]]:
        return [(path, gpx_text(m))]

    def read(self, path: Path) -> tuple[str, list[Route]]:
        what, route = read_gpx(path)
        return what, [route]


FORMAT = Gpx("gpx", ".gpx", "--gpx", "also a GPX track and waypoints of the flight for "
             "ground crews (a GPS handheld)", "none: any route (ele above mean sea level)", 5)
