"""The flown route of a mission, independent of its file format: the waypoints and, for the
leg that starts at each, its speed, photo spacing, gimbal pitch and heading. The MAVLink
items (mission_items.py, the `.plan`) are the reference; the DJI (dji.py) and Litchi
(litchi.py) files are written from this route and read back into it, so that a round trip
compares like with like.

Heights are metres above home's ground (the take-off point; the DEM's height there when
the mission was built over one), as in the `.plan`. Angles in degrees (the files' unit):
gimbal pitch 0 level, -90 straight down; heading clockwise from true north, in
(-180, 180], None where the aircraft turns along the path.

Semantics of the MAVLink items, kept here: a DO item after a waypoint sets what the legs
from that waypoint on fly (DO_CHANGE_SPEED the speed, DO_SET_CAM_TRIGG_DIST a photo every
so many metres, 0 off; DO_SET_ROI_LOCATION the point the camera looks at until
DO_SET_ROI_NONE: then the gimbal's pitch and the aircraft's heading aim at it). NAV_TAKEOFF
is the climb over home; a closed tour ends with NAV_RETURN_TO_LAUNCH (`end` "home"), a
path with NAV_LAND below its last waypoint (`end` "land").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from mound.errors import InputError
from mound.geometry.geodesy import Origin, enu_to_geodetic, geodetic_to_enu
from mound.uav import mission_items as mi

NADIR_DEG = -90.0


@dataclass(frozen=True)
class RoutePoint:
    lat_deg: float
    lon_deg: float
    height_m: float                 # above home's ground
    speed_m_s: float                # of the leg that starts here
    photo_every_m: float            # photos on the leg that starts here, every ... m (0: none)
    gimbal_pitch_deg: float         # -90: nadir
    heading_deg: float | None       # None: along the path

    def close_to(self, other: RoutePoint, origin: Origin, tol_m: float = 0.1,
                 tol_deg: float = 0.1) -> str | None:
        """What differs from `other` beyond the tolerances (None: the same point)."""
        a, b = (geodetic_to_enu(origin, np.array([[p.lat_deg, p.lon_deg, 0.0]]))[0]
                for p in (self, other))
        if math.hypot(*(a[:2] - b[:2])) > tol_m:
            return f"position {math.hypot(*(a[:2] - b[:2])):.3f} m apart"
        if abs(self.height_m - other.height_m) > tol_m:
            return f"height {self.height_m:.2f} vs {other.height_m:.2f} m"
        if abs(self.speed_m_s - other.speed_m_s) > 0.05:
            return f"speed {self.speed_m_s:g} vs {other.speed_m_s:g} m/s"
        if abs(self.photo_every_m - other.photo_every_m) > 0.05:
            return f"photo spacing {self.photo_every_m:g} vs {other.photo_every_m:g} m"
        if abs(self.gimbal_pitch_deg - other.gimbal_pitch_deg) > tol_deg:
            return f"gimbal pitch {self.gimbal_pitch_deg:g} vs {other.gimbal_pitch_deg:g} deg"
        if (self.heading_deg is None) != (other.heading_deg is None) or (
                self.heading_deg is not None and other.heading_deg is not None
                and abs(_wrap(self.heading_deg - other.heading_deg)) > tol_deg):
            return f"heading {self.heading_deg} vs {other.heading_deg}"
        return None


@dataclass(frozen=True)
class Route:
    home_lat_deg: float
    home_lon_deg: float
    points: tuple[RoutePoint, ...]
    end: str                        # "home": return to home; "land": land below the last point

    def origin(self) -> Origin:
        return Origin(self.home_lat_deg, self.home_lon_deg)

    def enu(self) -> np.ndarray:
        """(n, 3) ENU of the points about home, z the height above home's ground."""
        llh = np.array([[p.lat_deg, p.lon_deg, 0.0] for p in self.points])
        out = geodetic_to_enu(self.origin(), llh)
        out[:, 2] = [p.height_m for p in self.points]
        return out

    def leg_lengths_m(self) -> np.ndarray:
        e = self.enu()
        return np.linalg.norm(np.diff(e, axis=0), axis=1)

    def differs_from(self, other: Route, tol_m: float = 0.1) -> str | None:
        """The first difference from `other` (None: the same route within tol_m)."""
        if self.end != other.end:
            return f"ends {self.end} vs {other.end}"
        if len(self.points) != len(other.points):
            return f"{len(self.points)} vs {len(other.points)} waypoints"
        for k, (a, b) in enumerate(zip(self.points, other.points, strict=True)):
            why = a.close_to(b, self.origin(), tol_m)
            if why:
                return f"waypoint {k}: {why}"
        return None


def _wrap(deg: float) -> float:
    """An angle in (-180, 180]."""
    d = math.fmod(deg, 360.0)
    if d <= -180.0:
        d += 360.0
    elif d > 180.0:
        d -= 360.0
    return d


def route_of(items: list[mi.MissionItem], home_lat_deg: float, home_lon_deg: float) -> Route:
    """The route the MAVLink items fly (see the module text); InputError for items this
    project does not write (another tool's mission)."""
    origin = Origin(home_lat_deg, home_lon_deg)
    pts: list[dict[str, object]] = []
    state: dict[str, object] = {"speed": 0.0, "photo": 0.0, "roi": None}
    end = "home"

    def set_state(key: str, value: object) -> None:
        state[key] = value
        if pts:
            pts[-1][key] = value

    for k, it in enumerate(items):
        c = it.command
        if c in (mi.NAV_TAKEOFF, mi.NAV_WAYPOINT):
            lat, lon = (it.lat_deg, it.lon_deg) if (it.x or it.y) else (home_lat_deg,
                                                                          home_lon_deg)
            pts.append({"lat": lat, "lon": lon, "h": float(it.z), **state})
        elif c == mi.DO_CHANGE_SPEED:
            set_state("speed", float(it.params[1]))
        elif c == mi.DO_SET_CAM_TRIGG_DIST:
            set_state("photo", float(it.params[0]))
        elif c == mi.DO_SET_ROI_LOCATION:
            set_state("roi", (it.lat_deg, it.lon_deg, float(it.z)))
        elif c == mi.DO_SET_ROI_NONE:
            set_state("roi", None)
        elif c == mi.NAV_LAND:
            end = "land"
        elif c == mi.NAV_RETURN_TO_LAUNCH:
            end = "home"
        else:
            raise InputError(f"item {k}: command {c} is not one this project's missions use")
    if len(pts) < 2:
        raise InputError("the mission has fewer than two waypoints")
    out = []
    for p in pts:
        roi = p["roi"]
        pitch, heading = NADIR_DEG, None
        if roi is not None:
            here, there = geodetic_to_enu(origin, np.array(
                [[p["lat"], p["lon"], 0.0], [roi[0], roi[1], 0.0]]))  # type: ignore[index]
            dx, dy = there[:2] - here[:2]
            pitch = -math.degrees(math.atan2(float(p["h"]) - roi[2],  # type: ignore[index,arg-type]
                                             math.hypot(dx, dy)))
            heading = _wrap(math.degrees(math.atan2(dx, dy)))
        out.append(RoutePoint(float(p["lat"]), float(p["lon"]), float(p["h"]),  # type: ignore[arg-type]
                              float(p["speed"]), float(p["photo"]), pitch, heading))  # type: ignore[arg-type]
    return Route(home_lat_deg, home_lon_deg, tuple(out), end)


def items_route(items: list[mi.MissionItem]) -> Route:
    """The route of MAVLink items whose first is the take-off (this project's missions;
    an ArduPilot list's item 0, home, is skipped)."""
    items = list(items)
    if items and items[0].command == mi.NAV_WAYPOINT and items[0].frame == mi.FRAME_GLOBAL:
        items = items[1:]
    if not items or items[0].command != mi.NAV_TAKEOFF:
        raise InputError("the mission does not start with a take-off (NAV_TAKEOFF)")
    return route_of(items, items[0].lat_deg, items[0].lon_deg)


def mission_route(m: mi.Mission) -> Route:
    """The route of a built mission, about its take-off point."""
    return items_route(m.items)


def split_long_legs(route: Route, max_leg_m: float) -> Route:
    """The route with waypoints added (same heights, speed and settings as the leg's
    start) so that no leg is longer than max_leg_m (3-D)."""
    e = route.enu()
    out: list[RoutePoint] = []
    origin = route.origin()
    for k, p in enumerate(route.points):
        out.append(p)
        if k + 1 == len(route.points):
            break
        length = float(np.linalg.norm(e[k + 1] - e[k]))
        n = math.ceil(length / max_leg_m)
        for j in range(1, n):
            q = e[k] + (e[k + 1] - e[k]) * j / n
            lat, lon, _ = enu_to_geodetic(origin, np.array([[q[0], q[1], 0.0]]))[0]
            out.append(replace(p, lat_deg=float(lat), lon_deg=float(lon), height_m=float(q[2])))
    return replace(route, points=tuple(out))


def cap_vertical_speed(route: Route, ascent_m_s: float, descent_m_s: float) -> Route:
    """The route with each leg's speed lowered where its climb or descent would be faster
    than the aircraft's vertical limits (the leg flown straight at its speed: the vertical
    part is speed x rise / length). A MAVLink autopilot limits this itself; a DJI or Litchi
    waypoint flight holds the speed the file names."""
    e = route.enu()
    out = list(route.points)
    for k in range(len(out) - 1):
        d = e[k + 1] - e[k]
        length, rise = float(np.linalg.norm(d)), float(d[2])
        limit = ascent_m_s if rise > 0 else descent_m_s
        if abs(rise) > 1e-9 and out[k].speed_m_s * abs(rise) / length > limit:
            out[k] = replace(out[k], speed_m_s=limit * length / abs(rise))
    return replace(route, points=tuple(out))


def merge_close(route: Route, min_leg_m: float) -> Route:
    """The route without a waypoint closer than min_leg_m (3-D) to the one before it: the
    later one's leg settings are kept on the earlier."""
    e = route.enu()
    out = [route.points[0]]
    last = e[0]
    for k in range(1, len(route.points)):
        if float(np.linalg.norm(e[k] - last)) < min_leg_m:
            p = route.points[k]
            out[-1] = replace(out[-1], speed_m_s=p.speed_m_s, photo_every_m=p.photo_every_m,
                              gimbal_pitch_deg=p.gimbal_pitch_deg, heading_deg=p.heading_deg)
            continue
        out.append(route.points[k])
        last = e[k]
    return replace(route, points=tuple(out))
