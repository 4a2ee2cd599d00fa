"""DJI WPML `.kmz` for DJI Pilot 2 / FlightHub 2 (uav/dji.py): one wayline per flight,
heights above the take-off point or WGS84 ellipsoidal (template EGM96)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mound.errors import InputError
from mound.uav import dji, dji_read
from mound.uav.mission_format import About, Content, FileFormat, Record, WriteOptions
from mound.uav.mission_items import Mission
from mound.uav.route import Route, mission_route


def heights(m: Mission, route: Route, frame: str) -> dji.Heights:
    """The heights of a DJI file of this mission: the take-off point's ground (with a DEM)
    and the geoid where the file needs it."""
    if m.terrain is None:
        if frame == "wgs84":
            raise InputError("--dji-heights wgs84: needs --dem (the ground under home)")
        return dji.Heights("relative")
    home = m.terrain.home_amsl_m
    lat = np.array([route.home_lat_deg] + [p.lat_deg for p in route.points])
    lon = np.array([route.home_lon_deg] + [p.lon_deg for p in route.points])
    n = dji.geoid_separation(lat, lon)
    return dji.Heights(frame, home, float(n[0]), tuple(float(v) for v in n[1:]))


def kmz(m: Mission, craft: dji.Aircraft, frame: str = "relative") -> bytes:
    """The KMZ of mission `m` (InputError naming the DJI limit it breaks)."""
    route = dji.prepare(mission_route(m), craft)
    return dji.kmz_bytes(route, craft, heights(m, route, frame))


HELP = ("also a DJI WPML mission for DJI Pilot 2 / FlightHub 2 (one wayline per flight; "
        "see --aircraft, --dji-heights)")
LIMITS = (f"at most {dji.MAX_WAYPOINTS:,} waypoints, heights {dji.HEIGHT_RANGE_M[0]:g}.."
          f"{dji.HEIGHT_RANGE_M[1]:g} m above take-off, the aircraft's speed and climb limits; "
          "legs split or merged to DJI's spacing")


class DjiKmz(FileFormat):
    def check(self, opts: WriteOptions) -> None:
        dji.aircraft(opts.aircraft)
        if opts.dji_heights == "wgs84" and not opts.dem:
            raise InputError("--dji-heights wgs84: needs --dem (ellipsoidal heights need the "
                             "ground under home)")

    def describe(self, m: Mission, opts: WriteOptions) -> About:
        craft = dji.aircraft(opts.aircraft)
        frames = ({"template": "relativeToStartPoint", "waylines": "relativeToStartPoint"}
                  if opts.dji_heights == "relative"
                  else {"template": "EGM96", "waylines": "WGS84 (ellipsoidal)"})
        return {"aircraft": craft.key, "heights": frames, "lens": craft.survey_lens}

    def write(self, m: Mission, path: Path, opts: WriteOptions,
              record: Record) -> list[tuple[Path, Content]]:
        return [(path, kmz(m, dji.aircraft(opts.aircraft), opts.dji_heights))]

    def read(self, path: Path) -> tuple[str, list[Route]]:
        k = dji_read.read_kmz(path)
        frames = ", ".join(sorted({w.height_mode for w in k.waylines}))
        what = (f"DJI WPML, aircraft enum {k.drone_enum}/{k.drone_sub_enum}, payload "
                f"{k.payload_enum}, heights {frames}, finish {k.finish_action}, RTH height "
                f"{k.rth_height_m}")
        return what, [k.route(i) for i in range(len(k.waylines))]


FORMAT = DjiKmz("dji_kmz", ".kmz", "--dji-kmz", HELP, LIMITS, 3)
