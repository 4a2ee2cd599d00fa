"""DJI WPML missions (`.kmz`) for DJI Pilot 2 and FlightHub 2: the survey's flights on the
enterprise aircraft field teams fly (Mavic 3 Enterprise, Matrice 30/300/350/4E).

A KMZ is a zip holding `wpmz/template.kml` (the mission as planned) and
`wpmz/waylines.wpml` (what the aircraft executes), in DJI's WPML (namespace
`http://www.dji.com/wpmz/1.0.6`; DJI Cloud API documentation, "DJI WPML"). Element names
and order follow the files DJI's own software exports (`../shared/data/dji/`). One
wayline per flight, written from the route of the flight's MAVLink items (route.py), so
the KMZ flies what the `.plan` flies:
- every navigation waypoint a Placemark (`toPointAndStopWithDiscontinuityCurvature`: the
  raster lines' corners are flown exactly), its `waypointSpeed` the speed of the leg that
  starts there (cruise on transit legs, scan speed on scans);
- photos: per run of legs with the same spacing, an action group over those waypoints
  triggered `multipleDistance` with the spacing, action `takePhoto` (what MAVLink's
  DO_SET_CAM_TRIGG_DIST does);
- gimbal: a `gimbalRotate` (absolute pitch) wherever the pitch changes: -90 (nadir) on the
  raster, and on the orbit the pitch that looks at the tumulus's centre, with the heading
  (`smoothTransition` to the bearing of the centre);
- the end: a closed tour's last waypoint is over home at the return leg's height, then
  `finishAction` goHome (the aircraft lands at home); a path's `autoLand` at its end.
  `globalRTHHeight` (an RC-lost return flies straight home at it) is the route's highest
  waypoint above home (at least DJI's 20 m), so the straight way home clears what the legs
  cleared; `takeOffSecurityHeight` the first climb's.

- photos start at the first waypoint of a scan (not at the transit point above it, so no
  photo is taken on the descent) and stop at its last;
- the camera: `payloadParam` in the template for every aircraft (focus on the first
  waypoint, average metering) and, on a payload with several lenses (wide, zoom, infrared),
  `imageFormat` and each `takePhoto`'s `payloadLensIndex` name the wide lens, the one the
  reconstruction is calibrated for (DJI's M30 export names `wide,ir` in both places);
- speeds: a leg that climbs or descends is flown no faster than the aircraft's vertical
  limit allows (`max_ascent_m_s`, `max_descent_m_s`: DJI's figures for the normal flight
  mode, 6 m/s where only sport-mode ones were found), and `duration` counts a stop at every waypoint
  (`toPointAndStop...`: each leg accelerates from rest and brakes to rest).

Heights. `relativeToStartPoint` (default): metres above the take-off point's ground, the
`.plan`'s own frame. The aircraft's barometric height is zeroed at take-off, as the
autopilots' relative altitude is, so the file needs no geoid and no GNSS altitude (metres
of vertical error without RTK). Over a DEM the take-off point's ground is known (the DEM's
height at home) and written as `takeOffRefPoint` (lat, lon, its WGS84 ellipsoidal height).
`wgs84` (`--dji-heights wgs84`): heights tied to the earth, only over a DEM (they need the
ground) and only worth it with RTK. DJI's rules (Cloud API, "DJI WPML") allow a template's
`heightMode` to be EGM96, relativeToStartPoint, aboveGroundLevel or
realTimeFollowSurface, and WGS84 only as the waylines' `executeHeightMode`; so, as DJI's
own exports do, the template states EGM96 heights (`height`; `ellipsoidHeight` beside it)
and the waylines WGS84 ellipsoidal heights: EGM96 plus the geoid separation through PROJ's
EGM96 grid (refused where the grid is missing: without it PROJ returns 0 silently, 46.5 m
wrong over the shared DEM).

Limits of the aircraft and DJI's formats are checked before anything is written: legs
longer than 2,000 m are split with waypoints on the line (DJI's waypoint missions take
adjacent waypoints 0.5-2,000 m apart; waypoints closer than 0.5 m are merged), heights
relative to take-off within [-200, 500] m (DJI's SDKs; the RTH height 20-500 m), speeds
within the aircraft's 15 m/s for waypoint flights, at most 65,535 waypoints per wayline
(WPML's index). A flight beyond one is refused naming the limit and the waypoint.
"""

from __future__ import annotations

import io
import time
import zipfile
from dataclasses import dataclass
from typing import Any
from xml.sax.saxutils import escape

import numpy as np

from mound.errors import InputError
from mound.uav.route import (
    Route,
    RoutePoint,
    cap_vertical_speed,
    merge_close,
    split_long_legs,
)

WPML_NS = "http://www.dji.com/wpmz/1.0.6"
KML_NS = "http://www.opengis.net/kml/2.2"
TEMPLATE = "wpmz/template.kml"
WAYLINES = "wpmz/waylines.wpml"
HEIGHT_FRAMES = ("relative", "wgs84")
# DJI WPML's height modes (Cloud API, "DJI WPML"): a template's heightMode, and a wayline's
# executeHeightMode (WGS84 only there).
TEMPLATE_HEIGHT_MODES = ("EGM96", "relativeToStartPoint", "aboveGroundLevel",
                         "realTimeFollowSurface")
WAYLINE_HEIGHT_MODES = ("WGS84", "relativeToStartPoint", "realTimeFollowSurface")
# toPointAndStop...: each leg starts and ends at rest. DJI publishes no waypoint
# acceleration; 2 m/s^2 is an assumption, not a measurement (used only for the file's
# `duration`).
WAYPOINT_ACCEL_M_S2 = 2.0
MAX_WAYPOINTS = 65_535
MIN_LEG_M, MAX_LEG_M = 0.5, 2_000.0
HEIGHT_RANGE_M = (-200.0, 500.0)
RTH_RANGE_M = (20.0, 500.0)
TAKEOFF_SECURITY_RANGE_M = (1.2, 1_500.0)


@dataclass(frozen=True)
class Aircraft:
    """An aircraft DJI Pilot 2 flies WPML missions on, with its enum values (DJI Cloud
    API, "Product Support": type and sub_type of the aircraft and of its camera)."""

    key: str
    name: str
    drone_enum: int
    drone_sub_enum: int
    payload_enum: int
    payload: str
    lenses: tuple[str, ...]          # the payload's lenses, DJI's names (wide, zoom, ir, ...)
    max_ascent_m_s: float            # vertical limits: DJI's normal (N/P) mode figures, or
    #                                  lower where DJI gives only sport-mode ones (M4E)
    max_descent_m_s: float
    max_speed_m_s: float = 15.0

    @property
    def multi_lens(self) -> bool:
        return len(self.lenses) > 1

    @property
    def survey_lens(self) -> str:
        """The lens the photos are taken with: the wide camera (what the reconstruction's
        camera model and focal-length table describe), or a single-lens payload's own."""
        return "wide" if "wide" in self.lenses else self.lenses[0]


AIRCRAFT = {a.key: a for a in (
    Aircraft("m3e", "Mavic 3 Enterprise (M3E)", 77, 0, 66, "M3E camera", ("wide", "zoom"),
             6.0, 6.0),
    Aircraft("m3t", "Mavic 3 Thermal (M3T)", 77, 1, 67, "M3T camera", ("wide", "zoom", "ir"),
             6.0, 6.0),
    Aircraft("m30", "Matrice 30 (M30)", 67, 0, 52, "M30 camera", ("wide", "zoom"), 6.0, 5.0),
    Aircraft("m300", "Matrice 300 RTK", 60, 0, 50, "Zenmuse P1", ("visable",), 5.0, 4.0),
    Aircraft("m350", "Matrice 350 RTK", 89, 0, 50, "Zenmuse P1", ("visable",), 5.0, 4.0),
    Aircraft("m4e", "Matrice 4E", 99, 0, 88, "M4E camera", ("wide", "zoom"), 6.0, 6.0),
)}
# Aircraft flown with DJI Fly, which imports no WPML file DJI documents: Litchi flies them.
NOT_WPML = ("mini4pro", "air3")


def aircraft(key: str) -> Aircraft:
    """The table's aircraft; InputError naming --aircraft for one it lacks."""
    if key in NOT_WPML:
        raise InputError(f"--aircraft {key}: DJI Fly imports no WPML mission DJI documents; "
                         "fly it with Litchi (--litchi OUT.csv)")
    if key not in AIRCRAFT:
        raise InputError(f"--aircraft: {key!r} is not in the table of WPML aircraft "
                         f"({', '.join(AIRCRAFT)})")
    return AIRCRAFT[key]


@dataclass(frozen=True)
class Heights:
    """How the file states heights: `relative` (above the take-off point's ground) or
    `wgs84` (ellipsoidal); `home_amsl_m` the take-off point's ground (the DEM's; None
    without a DEM), `geoid_m` the EGM96 geoid separation at each waypoint and at home
    (wgs84 and takeOffRefPoint)."""

    frame: str = "relative"
    home_amsl_m: float | None = None
    home_geoid_m: float | None = None
    geoid_m: tuple[float, ...] = ()


def geoid_separation(lat: np.ndarray, lon: np.ndarray) -> np.ndarray:
    """EGM96 geoid height above the WGS84 ellipsoid (m): minus the EGM96 height of the
    ellipsoid's surface, through the DEM reader's conversion (geometry/dem.vertical_shift:
    PROJ's grid, InputError where it is not installed, never PROJ's silent 0)."""
    from mound.geometry.dem import vertical_shift

    lat = np.atleast_1d(np.asarray(lat, dtype=float))
    out = -vertical_shift("ellipsoid", np.atleast_1d(np.asarray(lon, dtype=float)), lat,
                          np.zeros(len(lat)), "the DJI mission's WGS84 heights")
    if np.any(np.abs(out) > 120):
        raise InputError("PROJ gave no geoid separation here (outside its grid?)")
    return out


def prepare(route: Route, craft: Aircraft) -> Route:
    """The route within DJI's limits (legs split or merged, climbs and descents no faster
    than the aircraft's vertical limits), or InputError naming the limit and the
    waypoint."""
    route = split_long_legs(merge_close(route, MIN_LEG_M), MAX_LEG_M * 0.999)
    route = cap_vertical_speed(route, craft.max_ascent_m_s, craft.max_descent_m_s)
    if len(route.points) > MAX_WAYPOINTS:
        raise InputError(f"DJI WPML: {len(route.points)} waypoints, more than a wayline's "
                         f"{MAX_WAYPOINTS:,}: fly fewer sites per flight (--flights)")
    for k, p in enumerate(route.points):
        if not HEIGHT_RANGE_M[0] <= p.height_m <= HEIGHT_RANGE_M[1]:
            raise InputError(f"DJI WPML: waypoint {k} is {p.height_m:.1f} m above the take-off "
                             f"point, outside DJI's {HEIGHT_RANGE_M[0]:g}..{HEIGHT_RANGE_M[1]:g}"
                             " m: take off nearer the sites' height")
        if not 0 < p.speed_m_s <= craft.max_speed_m_s:
            raise InputError(f"DJI WPML: waypoint {k}: speed {p.speed_m_s:g} m/s, the "
                             f"{craft.name} flies waypoints at up to {craft.max_speed_m_s:g} m/s"
                             " (--cruise-speed, --scan-speed)")
    return route


def _f(v: float, digits: int = 3) -> str:
    s = f"{v:.{digits}f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def _el(name: str, value: Any, indent: int) -> str:
    return f"{' ' * indent}<wpml:{name}>{escape(str(value))}</wpml:{name}>\n"


def _mission_config(route: Route, craft: Aircraft, heights: Heights, template: bool,
                    finish: str, rth_m: float, takeoff_m: float, speed: float) -> str:
    s = "    <wpml:missionConfig>\n"
    s += _el("flyToWaylineMode", "safely", 6)
    s += _el("finishAction", finish, 6)
    s += _el("exitOnRCLost", "executeLostAction", 6)
    s += _el("executeRCLostAction", "goBack", 6)
    s += _el("takeOffSecurityHeight", _f(takeoff_m, 2), 6)
    if template and heights.home_amsl_m is not None and heights.home_geoid_m is not None:
        ell = heights.home_amsl_m + heights.home_geoid_m
        s += _el("takeOffRefPoint", f"{route.home_lat_deg:.8f},{route.home_lon_deg:.8f},"
                 f"{ell:.3f}", 6)
        s += _el("takeOffRefPointAGLHeight", "0", 6)
    s += _el("globalTransitionalSpeed", _f(speed, 2), 6)
    s += _el("globalRTHHeight", _f(rth_m, 1), 6)
    s += "      <wpml:droneInfo>\n"
    s += _el("droneEnumValue", craft.drone_enum, 8)
    s += _el("droneSubEnumValue", craft.drone_sub_enum, 8)
    s += "      </wpml:droneInfo>\n"
    s += _el("waylineAvoidLimitAreaMode", 0, 6)
    s += "      <wpml:payloadInfo>\n"
    s += _el("payloadEnumValue", craft.payload_enum, 8)
    s += _el("payloadSubEnumValue", 0, 8)
    s += _el("payloadPositionIndex", 0, 8)
    s += "      </wpml:payloadInfo>\n"
    s += "    </wpml:missionConfig>\n"
    return s


def _gimbal_action(action_id: int, pitch: float, indent: int) -> str:
    i = " " * indent
    s = f"{i}<wpml:action>\n" + _el("actionId", action_id, indent + 2)
    s += _el("actionActuatorFunc", "gimbalRotate", indent + 2)
    s += f"{i}  <wpml:actionActuatorFuncParam>\n"
    for name, value in (("gimbalHeadingYawBase", "north"), ("gimbalRotateMode", "absoluteAngle"),
                        ("gimbalPitchRotateEnable", 1), ("gimbalPitchRotateAngle", _f(pitch)),
                        ("gimbalRollRotateEnable", 0), ("gimbalRollRotateAngle", 0),
                        ("gimbalYawRotateEnable", 0), ("gimbalYawRotateAngle", 0),
                        ("gimbalRotateTimeEnable", 0), ("gimbalRotateTime", 0),
                        ("payloadPositionIndex", 0)):
        s += _el(name, value, indent + 4)
    s += f"{i}  </wpml:actionActuatorFuncParam>\n{i}</wpml:action>\n"
    return s


def _photo_action(action_id: int, craft: Aircraft, indent: int) -> str:
    """takePhoto with the lens named on a multi-lens payload (DJI's M30 export names
    `payloadLensIndex` with `useGlobalPayloadLensIndex` 0); a single-lens payload's as
    DJI's M3E export writes it."""
    i = " " * indent
    s = f"{i}<wpml:action>\n" + _el("actionId", action_id, indent + 2)
    s += _el("actionActuatorFunc", "takePhoto", indent + 2)
    s += f"{i}  <wpml:actionActuatorFuncParam>\n"
    s += _el("payloadPositionIndex", 0, indent + 4)
    s += _el("useGlobalPayloadLensIndex", 0, indent + 4)
    if craft.multi_lens:
        s += _el("payloadLensIndex", craft.survey_lens, indent + 4)
    s += f"{i}  </wpml:actionActuatorFuncParam>\n{i}</wpml:action>\n"
    return s


def _payload_param(craft: Aircraft) -> str:
    """The template's camera settings (after the placemarks, as DJI's exports place it):
    focus on the first waypoint, average metering, and on a multi-lens payload the lens
    whose photos are stored (`imageFormat`)."""
    s = "      <wpml:payloadParam>\n" + _el("payloadPositionIndex", 0, 8)
    s += _el("focusMode", "firstPoint", 8) + _el("meteringMode", "average", 8)
    if craft.multi_lens:
        s += _el("imageFormat", craft.survey_lens, 8)
    return s + "      </wpml:payloadParam>\n"


def _group(group_id: int, start: int, end: int, trigger: str, param: float | None,
           actions: str) -> str:
    i = " " * 8
    s = f"{i}<wpml:actionGroup>\n"
    s += _el("actionGroupId", group_id, 10)
    s += _el("actionGroupStartIndex", start, 10)
    s += _el("actionGroupEndIndex", end, 10)
    s += _el("actionGroupMode", "sequence", 10)
    s += f"{i}  <wpml:actionTrigger>\n" + _el("actionTriggerType", trigger, 12)
    if param is not None:
        s += _el("actionTriggerParam", _f(param), 12)
    s += f"{i}  </wpml:actionTrigger>\n" + actions + f"{i}</wpml:actionGroup>\n"
    return s


def _photo_runs(points: tuple[RoutePoint, ...]) -> list[tuple[int, int, float]]:
    """(first, last waypoint, spacing) of each run of legs photographed at one spacing:
    the legs from `first` to `last`."""
    runs = []
    k = 0
    while k < len(points) - 1:
        d = points[k].photo_every_m
        if d > 0:
            j = k
            while j + 1 < len(points) - 1 and points[j + 1].photo_every_m == d:
                j += 1
            runs.append((k, j + 1, d))
            k = j + 1
        else:
            k += 1
    return runs


def _height(p: RoutePoint, k: int, heights: Heights, datum: str) -> float:
    """Waypoint k's height in the file's frame: above take-off (relative), EGM96
    (the template of a wgs84 file) or the WGS84 ellipsoid (its waylines)."""
    if heights.frame == "relative":
        return p.height_m
    egm96 = heights.home_amsl_m + p.height_m  # type: ignore[operator]
    return egm96 if datum == "EGM96" else egm96 + heights.geoid_m[k]


def _placemarks(route: Route, craft: Aircraft, heights: Heights, template: bool) -> str:
    out = []
    runs = {first: (last, d) for first, last, d in _photo_runs(route.points)}
    group_id = 0
    pitch_before: float | None = None
    for k, p in enumerate(route.points):
        s = "      <Placemark>\n        <Point>\n          <coordinates>\n"
        s += f"            {p.lon_deg:.9f},{p.lat_deg:.9f}\n"
        s += "          </coordinates>\n        </Point>\n"
        s += _el("index", k, 8)
        if template:
            s += _el("ellipsoidHeight", _f(_height(p, k, heights, "WGS84")), 8)
            s += _el("height", _f(_height(p, k, heights, "EGM96")), 8)
        else:
            s += _el("executeHeight", _f(_height(p, k, heights, "WGS84")), 8)
        s += _el("waypointSpeed", _f(p.speed_m_s, 2), 8)
        s += "        <wpml:waypointHeadingParam>\n"
        if p.heading_deg is None:
            s += _el("waypointHeadingMode", "followWayline", 10)
            s += _el("waypointHeadingAngle", 0, 10)
        else:
            s += _el("waypointHeadingMode", "smoothTransition", 10)
            s += _el("waypointHeadingAngle", _f(p.heading_deg), 10)
        s += _el("waypointPoiPoint", "0.000000,0.000000,0.000000", 10)
        if not template:
            s += _el("waypointHeadingAngleEnable", int(p.heading_deg is not None), 10)
        s += _el("waypointHeadingPathMode", "followBadArc", 10)
        s += _el("waypointHeadingPoiIndex", 0, 10)
        s += "        </wpml:waypointHeadingParam>\n"
        s += "        <wpml:waypointTurnParam>\n"
        s += _el("waypointTurnMode", "toPointAndStopWithDiscontinuityCurvature", 10)
        s += _el("waypointTurnDampingDist", 0, 10)
        s += "        </wpml:waypointTurnParam>\n"
        if template:
            s += _el("useGlobalSpeed", 0, 8) + _el("useGlobalHeadingParam", 0, 8)
            s += _el("useGlobalTurnParam", 0, 8)
            s += _el("gimbalPitchAngle", _f(p.gimbal_pitch_deg), 8)
        s += _el("useStraightLine", 1, 8)
        if pitch_before is None or abs(p.gimbal_pitch_deg - pitch_before) > 1e-6:
            s += _group(group_id, k, k, "reachPoint", None,
                        _gimbal_action(0, p.gimbal_pitch_deg, 10))
            group_id += 1
            pitch_before = p.gimbal_pitch_deg
        if k in runs:
            last, d = runs[k]
            s += _group(group_id, k, last, "multipleDistance", d,
                        _photo_action(0, craft, 10))
            group_id += 1
        if not template:
            s += "        <wpml:waypointGimbalHeadingParam>\n"
            s += _el("waypointGimbalPitchAngle", _f(p.gimbal_pitch_deg), 10)
            s += _el("waypointGimbalYawAngle", 0, 10)
            s += "        </wpml:waypointGimbalHeadingParam>\n"
        s += "      </Placemark>\n"
        out.append(s)
    return "".join(out)


def flight_seconds(legs_m: np.ndarray, speeds_m_s: np.ndarray,
                   accel_m_s2: float = WAYPOINT_ACCEL_M_S2) -> float:
    """The time to fly legs that each start and end at rest (a stop at every waypoint):
    accelerate at `accel_m_s2` to the leg's speed, cruise, brake; a leg too short to
    reach its speed is a triangle."""
    legs = np.asarray(legs_m, dtype=float)
    v = np.maximum(np.asarray(speeds_m_s, dtype=float), 0.1)
    reach = v * v / accel_m_s2               # the distance spent speeding up and braking
    t = np.where(legs >= reach, legs / v + v / accel_m_s2,
                 2.0 * np.sqrt(legs / accel_m_s2))
    return float(np.sum(t))


def kmz_bytes(route: Route, craft: Aircraft, heights: Heights, created_ms: int | None = None
              ) -> bytes:
    """The KMZ of a route prepared for the aircraft (see prepare)."""
    if heights.frame == "wgs84" and (heights.home_amsl_m is None
                                     or len(heights.geoid_m) != len(route.points)):
        raise InputError("--dji-heights wgs84: needs the ground under home (--dem) and the "
                         "geoid at every waypoint")
    cruise = max(p.speed_m_s for p in route.points)
    top = max(p.height_m for p in route.points)
    rth = min(max(top, RTH_RANGE_M[0]), RTH_RANGE_M[1])
    if top > RTH_RANGE_M[1]:
        raise InputError(f"DJI WPML: the route reaches {top:.0f} m above take-off, higher than "
                         f"DJI's RTH height limit {RTH_RANGE_M[1]:g} m")
    takeoff = min(max(route.points[0].height_m, TAKEOFF_SECURITY_RANGE_M[0]),
                  TAKEOFF_SECURITY_RANGE_M[1])
    finish = "goHome" if route.end == "home" else "autoLand"
    legs = route.leg_lengths_m()
    length = float(np.sum(legs))
    duration = flight_seconds(legs, np.array([p.speed_m_s for p in route.points[:-1]]))
    now = created_ms if created_ms is not None else int(time.time() * 1000)
    head = (f'<?xml version="1.0" encoding="UTF-8"?>\n'
            f'<kml xmlns="{KML_NS}" xmlns:wpml="{WPML_NS}">\n')
    tpl_mode, wl_mode = (("relativeToStartPoint", "relativeToStartPoint")
                         if heights.frame == "relative" else ("EGM96", "WGS84"))
    tpl = head + "  <Document>\n" + _el("author", "mound-survey", 4)
    tpl += _el("createTime", now, 4) + _el("updateTime", now, 4)
    tpl += _mission_config(route, craft, heights, True, finish, rth, takeoff, cruise)
    tpl += "    <Folder>\n" + _el("templateType", "waypoint", 6) + _el("templateId", 0, 6)
    tpl += "      <wpml:waylineCoordinateSysParam>\n" + _el("coordinateMode", "WGS84", 8)
    tpl += _el("heightMode", tpl_mode, 8) + "      </wpml:waylineCoordinateSysParam>\n"
    tpl += _el("autoFlightSpeed", _f(cruise, 2), 6)
    tpl += _el("globalHeight", _f(_height(route.points[0], 0, heights, "EGM96")), 6)
    tpl += _el("caliFlightEnable", 0, 6) + _el("gimbalPitchMode", "usePointSetting", 6)
    tpl += "      <wpml:globalWaypointHeadingParam>\n"
    tpl += _el("waypointHeadingMode", "followWayline", 8)
    tpl += _el("waypointHeadingAngle", 0, 8)
    tpl += _el("waypointPoiPoint", "0.000000,0.000000,0.000000", 8)
    tpl += _el("waypointHeadingPathMode", "followBadArc", 8)
    tpl += _el("waypointHeadingPoiIndex", 0, 8)
    tpl += "      </wpml:globalWaypointHeadingParam>\n"
    tpl += _el("globalWaypointTurnMode", "toPointAndStopWithDiscontinuityCurvature", 6)
    tpl += _el("globalUseStraightLine", 1, 6)
    tpl += _placemarks(route, craft, heights, True) + _payload_param(craft)
    tpl += "    </Folder>\n  </Document>\n</kml>\n"
    wl = head + "  <Document>\n"
    wl += _mission_config(route, craft, heights, False, finish, rth, takeoff, cruise)
    wl += "    <Folder>\n" + _el("templateId", 0, 6) + _el("executeHeightMode", wl_mode, 6)
    wl += _el("waylineId", 0, 6) + _el("distance", _f(length, 2), 6)
    wl += _el("duration", _f(duration, 2), 6) + _el("autoFlightSpeed", _f(cruise, 2), 6)
    wl += _placemarks(route, craft, heights, False) + "    </Folder>\n  </Document>\n</kml>\n"
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        for name, text in ((TEMPLATE, tpl), (WAYLINES, wl)):
            info = zipfile.ZipInfo(name, date_time=(2026, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            z.writestr(info, text.encode("utf-8"))
    return buf.getvalue()
