"""The survey's flights in every format a field team flies, from one built Mission (its
MAVLink items are the reference): DJI WPML `.kmz` (dji.py), Litchi `.csv` (litchi.py),
beside the `.plan` and WPL of files.py; and any of them read back as a Route (route.py),
for `mound mission show` and the round-trip tests."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from mound.errors import InputError
from mound.uav import dji, litchi
from mound.uav import files as mission_files
from mound.uav import mission_items as mi
from mound.uav.route import Route, route_of


def mission_route(m: mi.Mission) -> Route:
    """The route of a built mission, about its take-off point."""
    return items_route(m.items)


def items_route(items: list[mi.MissionItem]) -> Route:
    """The route of MAVLink items whose first is the take-off (this project's missions;
    an ArduPilot list's item 0, home, is skipped)."""
    items = list(items)
    if items and items[0].command == mi.NAV_WAYPOINT and items[0].frame == mi.FRAME_GLOBAL:
        items = items[1:]
    if not items or items[0].command != mi.NAV_TAKEOFF:
        raise InputError("the mission does not start with a take-off (NAV_TAKEOFF)")
    return route_of(items, items[0].lat_deg, items[0].lon_deg)


def dji_heights(m: mi.Mission, route: Route, frame: str) -> dji.Heights:
    """The heights of a DJI file of this mission: the take-off point's ground (with a DEM)
    and the geoid where the file needs it."""
    if m.terrain is None:
        if frame == "wgs84":
            raise InputError("--dji-heights wgs84: needs --dem (the ground under home)")
        return dji.Heights("relative")
    home = float(m.terrain["home_amsl_m"])
    lat = np.array([route.home_lat_deg] + [p.lat_deg for p in route.points])
    lon = np.array([route.home_lon_deg] + [p.lon_deg for p in route.points])
    n = dji.geoid_separation(lat, lon)
    return dji.Heights(frame, home, float(n[0]), tuple(float(v) for v in n[1:]))


def kmz(m: mi.Mission, craft: dji.Aircraft, frame: str = "relative") -> bytes:
    route = dji.prepare(mission_route(m), craft)
    return dji.kmz_bytes(route, craft, dji_heights(m, route, frame))


def litchi_parts(m: mi.Mission) -> list[str]:
    return [litchi.csv_text(r) for r in litchi.prepare(mission_route(m))]


def dji_heights_doc(frame: str) -> dict[str, str]:
    """What a KMZ's heights are above, per file (mission.json's `formats.dji_kmz`)."""
    if frame == "relative":
        return {"template": "relativeToStartPoint", "waylines": "relativeToStartPoint"}
    return {"template": "EGM96", "waylines": "WGS84 (ellipsoidal)"}


def other_formats(m: mi.Mission, craft: dji.Aircraft | None, frame: str = "relative",
                  with_litchi: bool = True) -> tuple[dict[str, Any], dict[str, Any]]:
    """The DJI and Litchi files of a mission, each made on its own: (contents, formats).
    contents: `dji_kmz` the KMZ's bytes, `litchi_csv` the CSV parts' texts, for each that
    could be made; formats: for each asked for (a craft, with_litchi), what it is or
    `refused` with the limit that refused it (mission.json's `formats`; the caller names
    the files: `file` and `files` are None and [] until it does). One format's
    refusal never stops the others: the `.plan` is the reference and is made apart."""
    contents: dict[str, Any] = {}
    formats: dict[str, Any] = {}
    if craft is not None:
        try:
            contents["dji_kmz"] = kmz(m, craft, frame)
            formats["dji_kmz"] = {"file": None, "aircraft": craft.key,
                                  "heights": dji_heights_doc(frame), "lens": craft.survey_lens}
        except InputError as e:
            formats["dji_kmz"] = {"file": None, "aircraft": craft.key, "refused": str(e)}
    if with_litchi:
        try:
            contents["litchi_csv"] = litchi_parts(m)
            formats["litchi_csv"] = {"files": [], "heights": "above the take-off point",
                                     "crew": litchi.CREW_SETTINGS}
        except InputError as e:
            formats["litchi_csv"] = {"files": [], "refused": str(e)}
    return contents, formats


def read_any(path: str | Path) -> tuple[str, list[Route]]:
    """(what the file is, its routes: one per wayline or file) of a .plan, WPL, DJI .kmz or
    Litchi .csv mission. Heights as the file states them (a WGS84 KMZ's are ellipsoidal)."""
    p = Path(path)
    if p.suffix.lower() == ".kmz":
        k = dji.read_kmz(p)
        frames = ", ".join(sorted({w.height_mode for w in k.waylines}))
        what = (f"DJI WPML, aircraft enum {k.drone_enum}/{k.drone_sub_enum}, payload "
                f"{k.payload_enum}, heights {frames}, finish {k.finish_action}, RTH height "
                f"{k.rth_height_m}")
        return what, [k.route(i) for i in range(len(k.waylines))]
    if p.suffix.lower() == ".csv":
        pts = litchi.read_litchi(p)
        return ("Litchi CSV, altitudes above take-off",
                [Route(pts[0].lat_deg, pts[0].lon_deg, tuple(pts), "unknown")])
    items, origin, kind = mission_files.read_mission(p)
    return (f"{kind}, heights above home", [items_route(items)])


def show(path: str | Path) -> str:
    """A table of the mission's waypoints (one block per wayline)."""
    what, routes = read_any(path)
    lines = [f"{path}: {what}"]
    for k, r in enumerate(routes):
        if len(routes) > 1:
            lines.append(f"wayline {k}")
        lines.append(f"{'#':>4} {'lat':>12} {'lon':>13} {'height_m':>9} {'speed':>6} "
                     f"{'photo_m':>8} {'pitch':>6} {'heading':>8}")
        for i, p in enumerate(r.points):
            heading = "path" if p.heading_deg is None else f"{p.heading_deg:.1f}"
            photo = f"{p.photo_every_m:.2f}" if p.photo_every_m > 0 else "-"
            lines.append(f"{i:>4} {p.lat_deg:>12.7f} {p.lon_deg:>13.7f} {p.height_m:>9.2f} "
                         f"{p.speed_m_s:>6.1f} {photo:>8} {p.gimbal_pitch_deg:>6.1f} "
                         f"{heading:>8}")
        length = float(np.sum(r.leg_lengths_m())) if len(r.points) > 1 else 0.0
        lines.append(f"{len(r.points)} waypoints, {length:.0f} m, ends: {r.end}")
    return "\n".join(lines)
