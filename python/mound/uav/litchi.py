"""Litchi CSV missions for the consumer DJI aircraft (Mini 4 Pro, Air 3, Mavic 3) that
Litchi flies: the 46 columns of Litchi's Mission Hub export, one row per waypoint, written
from the route of the flight's MAVLink items (route.py) and read back into it.

Columns: latitude, longitude, altitude(m), heading(deg), curvesize(m), rotationdir,
gimbalmode, gimbalpitchangle, 15 x (actiontypeN, actionparamN), altitudemode, speed(m/s),
poi_latitude, poi_longitude, poi_altitude(m), poi_altitudemode, photo_timeinterval,
photo_distinterval. What this project writes:
- altitude above the take-off point (`altitudemode` 0), the `.plan`'s frame: metres above
  home's ground (Litchi's other mode, above ground, uses Litchi's own elevation data, not
  the survey's DEM, and is not used);
- heading: the bearing of the tumulus's centre on an orbit, else of the next waypoint
  (Litchi's heading mode "custom": the aircraft turns between waypoints); curvesize 0
  (straight lines through the corners);
- gimbal `interpolate` (2) with the pitch the `.plan`'s camera has there (-90 nadir);
- speed of the leg that starts at the row; `photo_distinterval` its photo spacing (-1:
  none), which Litchi applies from that waypoint to the next; no actions (-1, 0).
Litchi's limits: 99 waypoints per mission (a longer flight is split into parts
`OUT_part1.csv`, ... each starting at the waypoint the last ended at), altitudes
-200..500 m above take-off (Litchi's, as DJI's SDKs: a valley below a take-off knoll is
flown with negative altitudes), speeds up to 15 m/s, adjacent waypoints 0.5-2,000 m apart
(closer ones merged, longer legs split), climbs and descents no faster than the consumer
aircraft's 5 m/s (Mini 4 Pro, Air 3 in their normal mode).

What the CSV cannot carry: the mission's heading mode and finish action are settings of
the Litchi mission, not of its rows; `CREW_SETTINGS` says what the crew sets before flying
(without heading mode "Custom" Litchi turns the aircraft along the track and the orbit's
photos face away from the tumulus).
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import replace
from pathlib import Path

from mound.errors import InputError
from mound.jsonio import number_text, read_text
from mound.uav.route import Route, RoutePoint, cap_vertical_speed, merge_close, split_long_legs

HEADER = (["latitude", "longitude", "altitude(m)", "heading(deg)", "curvesize(m)",
           "rotationdir", "gimbalmode", "gimbalpitchangle"]
          + [f"{k}{n}" for n in range(1, 16) for k in ("actiontype", "actionparam")]
          + ["altitudemode", "speed(m/s)", "poi_latitude", "poi_longitude", "poi_altitude(m)",
             "poi_altitudemode", "photo_timeinterval", "photo_distinterval"])
MAX_WAYPOINTS = 99
ALTITUDE_RANGE_M = (-200.0, 500.0)
MAX_ASCENT_M_S = MAX_DESCENT_M_S = 5.0
CREW_SETTINGS = ("in Litchi's mission settings set Heading Mode 'Custom' (the rows' headings "
                 "face the tumulus on the orbit), Finish Action 'Return to home' and Path "
                 "Mode 'Straight lines'; altitudes are above the take-off point: take off at "
                 "the plan's home")
MAX_SPEED_M_S = 15.0
MIN_LEG_M, MAX_LEG_M = 0.5, 2_000.0
GIMBAL_INTERPOLATE = 2


def prepare(route: Route) -> list[Route]:
    """The route within Litchi's limits, in parts of at most 99 waypoints (each starting
    at the waypoint the last ended at); InputError naming the limit and the waypoint."""
    route = split_long_legs(merge_close(route, MIN_LEG_M), MAX_LEG_M * 0.999)
    route = cap_vertical_speed(route, MAX_ASCENT_M_S, MAX_DESCENT_M_S)
    for k, p in enumerate(route.points):
        if not ALTITUDE_RANGE_M[0] <= p.height_m <= ALTITUDE_RANGE_M[1]:
            raise InputError(f"Litchi: waypoint {k} is {p.height_m:.1f} m above the take-off "
                             f"point; Litchi takes {ALTITUDE_RANGE_M[0]:g}..{ALTITUDE_RANGE_M[1]:g}"
                             " m above take-off: take off nearer the sites' height")
        if not 0 < p.speed_m_s <= MAX_SPEED_M_S:
            raise InputError(f"Litchi: waypoint {k}: speed {p.speed_m_s:g} m/s, Litchi flies "
                             f"waypoints at up to {MAX_SPEED_M_S:g} m/s")
    parts = []
    start = 0
    n = len(route.points)
    while True:
        stop = min(start + MAX_WAYPOINTS, n)
        parts.append(replace(route, points=route.points[start:stop],
                             end=route.end if stop == n else "continue"))
        if stop == n:
            return parts
        start = stop - 1


def _bearing(a: RoutePoint, b: RoutePoint) -> float:
    import numpy as np

    from mound.geometry.geodesy import Origin, geodetic_to_enu

    e = geodetic_to_enu(Origin(a.lat_deg, a.lon_deg),
                        np.array([[b.lat_deg, b.lon_deg, 0.0]]))[0]
    return math.degrees(math.atan2(e[0], e[1])) % 360.0


def _n(v: float, digits: int = 6) -> str:
    """Fixed decimals (Litchi and its readers take no exponents)."""
    s = f"{v:.{digits}f}"
    return "0" if float(s) == 0 else s


def csv_text(route: Route) -> str:
    """One part of a route prepared for Litchi (prepare)."""
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow(HEADER)
    pts = route.points
    for k, p in enumerate(pts):
        if p.heading_deg is not None:
            heading = p.heading_deg % 360.0
        elif k + 1 < len(pts):
            heading = _bearing(p, pts[k + 1])
        else:
            heading = _bearing(pts[k - 1], p) if k else 0.0
        row = [_n(p.lat_deg, 9), _n(p.lon_deg, 9), _n(p.height_m, 3), _n(heading, 3), "0", "0",
               str(GIMBAL_INTERPOLATE), _n(p.gimbal_pitch_deg, 3)]
        row += ["-1", "0"] * 15
        row += ["0", _n(p.speed_m_s, 3), "0", "0", "0", "0", "-1",
                _n(p.photo_every_m, 3) if p.photo_every_m > 0 else "-1"]
        w.writerow(row)
    return out.getvalue()


def part_path(path: str | Path, part: int, parts: int) -> Path:
    """The file of part `part` (1-based) of a flight split in `parts`."""
    p = Path(path)
    return p if parts == 1 else p.with_name(f"{p.stem}_part{part}{p.suffix}")


# ---------------------------------------------------------------------------- reading

def _field(row: list[str], k: int, where: str, lo: float, hi: float) -> float:
    return number_text(row[k], f"{where}: {HEADER[k]}", lo, hi)


def read_litchi(path: str | Path) -> list[RoutePoint]:
    """A Litchi CSV mission's waypoints (height above take-off in `height_m`, whatever
    its altitudemode says: see `modes`); InputError naming the file, line and column."""
    text = read_text(path)
    reader = csv.reader(io.StringIO(text, newline=""))
    try:
        rows = list(reader)
    except csv.Error as e:
        raise InputError(f"{path}:{reader.line_num}: not a CSV line ({e})") from None
    if not rows or [h.strip() for h in rows[0]] != HEADER:
        raise InputError(f"{path}:1: not Litchi's 46-column header (latitude,longitude,"
                         "altitude(m),...)")
    points = []
    for n, row in enumerate(rows[1:], start=2):
        if not row:
            continue
        where = f"{path}:{n}"
        if len(row) != len(HEADER):
            raise InputError(f"{where}: {len(row)} columns, Litchi's rows have {len(HEADER)}")
        lat = _field(row, 0, where, -90, 90)
        lon = _field(row, 1, where, -180, 180)
        alt = _field(row, 2, where, -200, 10_000)
        heading = _field(row, 3, where, -360, 360)
        _field(row, 4, where, 0, 10_000)
        if row[5].strip() not in ("0", "1"):
            raise InputError(f"{where}: rotationdir: expected 0 or 1")
        if row[6].strip() not in ("0", "1", "2"):
            raise InputError(f"{where}: gimbalmode: expected 0, 1 or 2")
        pitch = _field(row, 7, where, -120, 90)
        for a in range(15):
            t = row[8 + 2 * a].strip()
            if t not in ("-1", "0", "1", "2", "3", "4", "5"):
                raise InputError(f"{where}: {HEADER[8 + 2 * a]}: expected -1..5, got {t[:20]!r}")
            _field(row, 9 + 2 * a, where, -1e6, 1e6)
        if row[38].strip() not in ("0", "1"):
            raise InputError(f"{where}: altitudemode: expected 0 or 1")
        speed = _field(row, 39, where, 0, 100)
        for k in (40, 41, 42):
            _field(row, k, where, -1e4, 1e4)
        _field(row, 44, where, -1, 1e6)
        dist = _field(row, 45, where, -1, 1e6)
        points.append(RoutePoint(lat, lon, alt, speed, dist if dist > 0 else 0.0,
                                 pitch if row[6].strip() == "2" else -90.0, heading))
    if len(points) < 2:
        raise InputError(f"{path}: fewer than two waypoints")
    if len(points) > MAX_WAYPOINTS:
        raise InputError(f"{path}: {len(points)} waypoints, Litchi takes {MAX_WAYPOINTS}")
    return points
