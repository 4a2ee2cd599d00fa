"""Mission files that ground stations open: QGroundControl `.plan`, `QGC WPL 110` text,
and GeoJSON of the tour and the scan footprints.

- `.plan` (QGroundControl's JSON, fileType "Plan", version 1, mission version 2): items
  are SimpleItems with 7 params (p1-p4, latitude, longitude, altitude in degrees/metres),
  frame MAV_FRAME_GLOBAL_RELATIVE_ALT (3) for what we send as ..._INT (6), NaN written as
  null (as QGroundControl does), home in `plannedHomePosition`. Our summary rides along
  under the key "mound" (QGroundControl ignores unknown keys).
- WPL (`QGC WPL 110`, Mission Planner/MAVProxy): one tab-separated line per item,
  `seq current frame command p1 p2 p3 p4 lat lon alt autocontinue`; line 0 is home.
- GeoJSON (RFC 7946, lon/lat order): the flown path as a LineString, the sites as Points,
  and each image's footprint on flat ground (the corners' rays meeting z = 0) as Polygons.
Readers validate and raise InputError naming the file and item.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from mound.errors import InputError
from mound.geometry.geodesy import Origin, enu_to_geodetic
from mound.jsonio import (
    JsonObject,
    JsonValue,
    finite_number,
    json_text,
    parse_json,
    read_text,
    short_repr,
    write_atomic,
)
from mound.uav.mission_items import (
    FRAME_GLOBAL_RELATIVE_ALT,
    FRAME_GLOBAL_RELATIVE_ALT_INT,
    Mission,
    MissionItem,
)

WPL_MAGIC = "QGC WPL 110"
FIRMWARE = {"px4": 12, "ardupilot": 3}


def _file_frame(frame: int) -> int:
    return FRAME_GLOBAL_RELATIVE_ALT if frame == FRAME_GLOBAL_RELATIVE_ALT_INT else frame


def _link_frame(frame: int) -> int:
    return FRAME_GLOBAL_RELATIVE_ALT_INT if frame == FRAME_GLOBAL_RELATIVE_ALT else frame


def _json_number(v: float) -> float | None:
    return None if math.isnan(v) else v


def flight_path(path: str | Path, flight: int | None) -> Path:
    """The file of one flight of several (mission.plan -> mission_2.plan); of the only
    flight, `path` itself."""
    p = Path(path)
    return p if flight is None else p.with_name(f"{p.stem}_{flight}{p.suffix}")


def home_altitude(mission: Mission) -> float:
    """Home's AMSL altitude: the DEM's ground there when the mission was built over one,
    else the origin's stated altitude."""
    return mission.terrain.home_amsl_m if mission.terrain else mission.origin.alt_m


def plan_document(mission: Mission, firmware: str = "px4") -> JsonObject:
    items: list[JsonValue] = []
    for k, it in enumerate(mission.items):
        items.append({
            "type": "SimpleItem", "command": it.command, "frame": _file_frame(it.frame),
            "autoContinue": bool(it.autocontinue), "doJumpId": k + 1,
            "params": [_json_number(p) for p in it.params] + [it.lat_deg, it.lon_deg, it.z],
            "Altitude": it.z, "AltitudeMode": 1, "AMSLAltAboveTerrain": None,
        })
    o = mission.origin
    return {
        "fileType": "Plan", "version": 1, "groundStation": "QGroundControl",
        "mission": {"version": 2, "firmwareType": FIRMWARE[firmware], "vehicleType": 2,
                    "cruiseSpeed": mission.spec.cruise_speed_m_s,
                    "hoverSpeed": mission.spec.scan_speed_m_s,
                    "plannedHomePosition": [o.lat_deg, o.lon_deg, home_altitude(mission)],
                    "items": items},
        "geoFence": {"circles": [], "polygons": [], "version": 2},
        "rallyPoints": {"points": [], "version": 2},
        "mound": mission.summary().to_doc(),
    }


def plan_text(mission: Mission, firmware: str = "px4") -> str:
    return json_text(plan_document(mission, firmware))


def write_plan(path: str | Path, mission: Mission, firmware: str = "px4") -> None:
    write_atomic(path, plan_text(mission, firmware))


# MAVLink carries params p1-p4 and the altitude as float32: beyond its largest finite
# value a number becomes infinity on the link, so it is refused here.
F32_MAX = 3.4028234663852886e38
MAX_ALT_M = 1e5


def _param(v: Any, where: str, *, lo: float = -F32_MAX, hi: float = F32_MAX,
           allow_nan: bool = True) -> float:
    """A number of a mission item: null (NaN: "unset") where allowed, else finite in [lo, hi]."""
    if v is None or (isinstance(v, float) and math.isnan(v)):
        if allow_nan:
            return float("nan")
        raise InputError(f"{where}: expected a number, got {v!r}")
    return finite_number(v, where, lo=lo, hi=hi, expected="a number or null")


def _item_numbers(p: list[Any], where: str, command: int) -> list[float]:
    """p1-p4 (float32 or unset), latitude, longitude (degrees), altitude (m). A navigation
    command (MAV_CMD_NAV_*, ids below 100) needs its position; other commands may leave
    latitude and longitude unset (NaN: sent as 0)."""
    nav = command < 100
    out = [_param(v, f"{where}[{i}]") for i, v in enumerate(p[:4])]
    out.append(_param(p[4], f"{where}[4] (latitude)", lo=-90, hi=90, allow_nan=not nav))
    out.append(_param(p[5], f"{where}[5] (longitude)", lo=-180, hi=180, allow_nan=not nav))
    out.append(_param(p[6], f"{where}[6] (altitude)", lo=-MAX_ALT_M, hi=MAX_ALT_M))
    out[4:6] = [0.0 if math.isnan(v) else v for v in out[4:6]]
    return out


def _int_field(v: Any, where: str, hi: int) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v <= hi:
        raise InputError(f"{where}: expected an integer in 0..{hi}, got {short_repr(v)}")
    return v


def _parse_plan(text: str, path: str | Path) -> tuple[list[MissionItem], Origin, str]:
    doc = parse_json(text, path)
    if not isinstance(doc, dict) or doc.get("fileType") != "Plan":
        raise InputError(f"{path}: fileType: not a QGroundControl plan")
    m = doc.get("mission")
    if not isinstance(m, dict) or not isinstance(m.get("items"), list):
        raise InputError(f"{path}: mission.items: missing")
    home = m.get("plannedHomePosition")
    if not (isinstance(home, list) and len(home) == 3):
        raise InputError(f"{path}: mission.plannedHomePosition: expected [lat, lon, alt]")
    where = f"{path}: mission.plannedHomePosition"
    origin = Origin(_param(home[0], f"{where}[0] (latitude)", lo=-90, hi=90, allow_nan=False),
                    _param(home[1], f"{where}[1] (longitude)", lo=-180, hi=180, allow_nan=False),
                    _param(home[2], f"{where}[2] (altitude)", lo=-MAX_ALT_M, hi=MAX_ALT_M,
                           allow_nan=False))
    items = []
    for k, raw in enumerate(m["items"]):
        where = f"{path}: mission.items[{k}]"
        if not isinstance(raw, dict) or raw.get("type") != "SimpleItem":
            raise InputError(f"{where}: only SimpleItem is supported (complex items: "
                             f"export them from QGroundControl as simple items)")
        params = raw.get("params")
        if not isinstance(params, list) or len(params) != 7:
            raise InputError(f"{where}.params: expected 7 numbers")
        frame = _int_field(raw.get("frame"), f"{where}.frame", 255)
        command = _int_field(raw.get("command"), f"{where}.command", 65535)
        p = _item_numbers(params, f"{where}.params", command)
        items.append(MissionItem(command, _link_frame(frame), tuple(p[:4]),  # type: ignore[arg-type]
                                 round(p[4] * 1e7), round(p[5] * 1e7),
                                 0.0 if math.isnan(p[6]) else p[6],
                                 int(bool(raw.get("autoContinue", True)))))
    firmware = "ardupilot" if m.get("firmwareType") == FIRMWARE["ardupilot"] else "px4"
    return items, origin, firmware


def read_plan(path: str | Path) -> tuple[list[MissionItem], Origin]:
    """Items (link frames, integer lat/lon) and home of a QGroundControl .plan file."""
    items, origin, _ = _parse_plan(read_text(path), path)
    return items, origin


def _fmt(v: float) -> str:
    return "nan" if math.isnan(v) else f"{v:.9g}"


def write_wpl(path: str | Path, mission: Mission) -> None:
    write_atomic(path, wpl_text(mission))


def wpl_text(mission: Mission) -> str:
    o = mission.origin
    lines = [WPL_MAGIC,
             f"0\t1\t0\t16\t0\t0\t0\t0\t{o.lat_deg:.8f}\t{o.lon_deg:.8f}\t"
             f"{home_altitude(mission):.6g}\t1"]
    for k, it in enumerate(mission.items, start=1):
        fields = [str(k), "0", str(_file_frame(it.frame)), str(it.command),
                  *(_fmt(p) for p in it.params), f"{it.lat_deg:.8f}", f"{it.lon_deg:.8f}",
                  _fmt(it.z), str(it.autocontinue)]
        lines.append("\t".join(fields))
    return "\n".join(lines) + "\n"


def _parse_wpl(text: str, path: str | Path) -> tuple[list[MissionItem], Origin]:
    rows = [ln for ln in text.splitlines() if ln.strip()]
    if not rows or rows[0].strip() != WPL_MAGIC:
        raise InputError(f"{path}:1: not a '{WPL_MAGIC}' waypoint file")
    parsed: list[Any] = []
    for n, line in enumerate(rows[1:], start=2):
        f = line.split("\t") if "\t" in line else line.split()
        if len(f) != 12:
            raise InputError(f"{path}:{n}: expected 12 fields, got {len(f)}")
        ints = [f[0], f[2], f[3], f[11]]
        if not all(v.isascii() and v.isdigit() and len(v) <= 9 for v in ints):
            raise InputError(f"{path}:{n}: seq, frame, command and autocontinue must be "
                             "non-negative integers")
        seq, frame, command, auto = (int(v) for v in ints)
        try:
            nums = [float(v) for v in f[4:11]]
        except ValueError:
            raise InputError(f"{path}:{n}: non-numeric field among p1-p4, lat, lon, alt") from None
        _int_field(frame, f"{path}:{n}: frame", 255)
        _int_field(command, f"{path}:{n}: command", 65535)
        nums = _item_numbers(nums, f"{path}:{n}: field", command)
        _int_field(auto, f"{path}:{n}: autocontinue", 1)
        if seq != len(parsed):
            raise InputError(f"{path}:{n}: sequence number {seq}, expected {len(parsed)}")
        parsed.append((frame, command, nums, auto))
    if not parsed:
        raise InputError(f"{path}: no home line")
    home = parsed[0][2]
    origin = Origin(home[4], home[5], home[6])
    items = [MissionItem(command, _link_frame(frame), tuple(nums[:4]),
                         round(nums[4] * 1e7), round(nums[5] * 1e7), nums[6], auto)
             for frame, command, nums, auto in parsed[1:]]
    return items, origin


def read_wpl(path: str | Path) -> tuple[list[MissionItem], Origin]:
    return _parse_wpl(read_text(path), path)


def read_mission(path: str | Path) -> tuple[list[MissionItem], Origin, str]:
    """Items, home and firmware ("px4" or "ardupilot") of a .plan (JSON) or WPL (text)
    file, told apart by content. A .plan names its firmware in firmwareType; a WPL file
    comes from the ArduPilot world (Mission Planner, MAVProxy)."""
    text = read_text(path)
    if text.lstrip().startswith("{"):
        return _parse_plan(text, path)
    return (*_parse_wpl(text, path), "ardupilot")


def _lonlat(origin: Origin, enu: np.ndarray) -> list[list[float]]:
    llh = enu_to_geodetic(origin, np.asarray(enu, dtype=float))
    return [[round(lon, 8), round(lat, 8), round(h - origin.alt_m, 3)] for lat, lon, h in llh]


def geojson_document(mission: Mission) -> JsonObject:
    o = mission.origin
    features: list[JsonObject] = [{
        "type": "Feature", "properties": {"kind": "flight_path",
                                          "length_m": mission.flight_distance_m,
                                          "budget_m": mission.budget_m,
                                          "altitude": "metres above home" + (
                                              "'s ground" if mission.terrain else ""),
                                          "home_amsl_m": home_altitude(mission)},
        "geometry": {"type": "LineString", "coordinates": _lonlat(o, np.array(mission.nav_enu))},
    }]
    for leg in mission.terrain.legs if mission.terrain else ():
        # The leg's profile (distance vs terrain vs flight height, AMSL) on its straight line.
        if leg.profile is None:
            continue
        ends = np.array([[*leg.profile.start_enu_m, 0.0], [*leg.profile.end_enu_m, 0.0]])
        features.append({"type": "Feature", "properties": {
            "kind": "leg_profile", **leg.to_doc(), "profile": leg.profile.to_doc(),
            **leg.profile.to_doc()},
            "geometry": {"type": "LineString",
                         "coordinates": [c[:2] for c in _lonlat(o, ends)]}})
    for s in mission.sites:
        features.append({"type": "Feature", "properties": {"kind": "site", **s.to_doc()},
                         "geometry": {"type": "Point",
                                      "coordinates": _lonlat(o, np.array([[s.x_m, s.y_m,
                                                                           0.0]]))[0][:2]}})
    for fp in mission.footprints:
        features.append({"type": "Feature",
                         "properties": {"kind": "image_footprint", "site": fp.site,
                                        "pattern": fp.pattern, "image": fp.image},
                         "geometry": {"type": "Polygon",
                                      "coordinates": [[c[:2] for c in _lonlat(o, fp.ring())]]}})
    return {"type": "FeatureCollection", "features": features}


def geojson_text(mission: Mission) -> str:
    return json.dumps(geojson_document(mission), allow_nan=False) + "\n"


def write_geojson(path: str | Path, mission: Mission) -> None:
    write_atomic(path, geojson_text(mission))
