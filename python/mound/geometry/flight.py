"""Flight patterns over a site: the poses the UAV camera takes its images from.

One generator for both the site simulator (what it renders) and the MAVLink mission (what
the aircraft flies), so the two agree: `ScanSpec` says how a site is scanned, and both
`mound.sim.site` and `mound.uav.mission_items` take it. Positions are in the site's ENU
frame (metres), heights above the site's ground reference z = 0.

raster: a lawnmower over a rectangle centred on the site, nadir camera, lines running
  north-south, line spacing from the side overlap and image spacing from the front overlap
  of the ground footprint at the flight height.
orbit: a circle around the site at a given radius and height, the camera looking at the
  site centre (oblique views), evenly spaced images.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import asdict, dataclass, fields, replace
from typing import Any

import numpy as np

from mound.bounds import HEIGHT_M, IMAGE_PX, SITE_DIAMETER_M, Bound
from mound.errors import InputError
from mound.geometry.camera import Camera, Pose
from mound.jsonio import JsonObject, renamed


@dataclass(frozen=True)
class Shot:
    pose: Pose
    line: int  # raster line (0-based), or 0 for an orbit


def _require(ok: bool, message: str) -> None:
    if not ok:
        raise InputError(message)


def raster(camera: Camera, centre_xy: tuple[float, float], width_m: float, height_m: float,
           altitude_m: float, front_overlap: float = 0.75, side_overlap: float = 0.6
           ) -> list[Shot]:
    _require(width_m > 0 and height_m > 0, "raster: area width and height must be > 0")
    _require(altitude_m > 0, "raster: altitude must be > 0 m above the ground reference")
    for name, v in (("front_overlap", front_overlap), ("side_overlap", side_overlap)):
        _require(0 < v < 1, f"raster: {name} must be in (0, 1), got {v}")
    fw, fh = camera.ground_footprint_m(altitude_m)
    line_step = fw * (1 - side_overlap)
    shot_step = fh * (1 - front_overlap)
    n_lines = max(1, math.ceil(width_m / line_step) + 1)
    n_shots = max(1, math.ceil(height_m / shot_step) + 1)
    x0 = centre_xy[0] - line_step * (n_lines - 1) / 2
    y0 = centre_xy[1] - shot_step * (n_shots - 1) / 2
    shots = []
    for i in range(n_lines):
        ys = range(n_shots) if i % 2 == 0 else range(n_shots - 1, -1, -1)
        for j in ys:
            c = np.array([x0 + i * line_step, y0 + j * shot_step, altitude_m])
            shots.append(Shot(Pose.look_at(c, c - np.array([0, 0, 1.0])), i))
    return shots


def orbit(centre_xyz: tuple[float, float, float], radius_m: float, altitude_m: float,
          n_images: int) -> list[Shot]:
    _require(radius_m > 0, "orbit: radius must be > 0")
    _require(altitude_m > 0, "orbit: altitude must be > 0 m above the ground reference")
    _require(n_images >= 3, "orbit: at least 3 images")
    target = np.asarray(centre_xyz, dtype=float)
    shots = []
    for k in range(n_images):
        a = 2 * math.pi * k / n_images
        c = np.array([target[0] + radius_m * math.cos(a), target[1] + radius_m * math.sin(a),
                      altitude_m])
        _require(c[2] > target[2], "orbit: the camera must fly above the site centre")
        shots.append(Shot(Pose.look_at(c, target, up=(0.0, 0.0, 1.0)), 0))
    return shots


PATTERNS = ("raster", "orbit", "both")


@dataclass
class ScanLeg:
    """One pattern of a site's scan as the aircraft flies it, relative to the site centre."""

    pattern: str
    points_enu: np.ndarray  # (k, 3) waypoints (raster: the ends of each line; orbit: every
    #                         camera position)
    trigger_m: float        # camera trigger distance
    images: int
    poses: list[Pose]       # the camera poses of the images


@dataclass(frozen=True)
class FlightLayout:
    """The camera and the scan's pattern(s) and geometry, shared by the mission's ScanSpec
    and the simulator's SimSpec. Lengths are metres; None scales the geometry to the site
    diameter D: a raster at height D over a D x D square, whose images then stay on the
    site, and an orbit of radius D at height 0.75 D (by default 18 nadir + 22 oblique = 40
    images)."""

    pattern: str = "both"
    width_px: int = 1280
    height_px: int = 960
    hfov_rad: float = 1.2217304763960306  # 70 degrees
    dist: tuple[float, float, float, float, float] = (0.0, 0.0, 0.0, 0.0, 0.0)
    raster_altitude_m: float | None = None
    raster_area_m: float | None = None
    front_overlap: float = 0.8
    side_overlap: float = 0.6
    orbit_radius_m: float | None = None
    orbit_altitude_m: float | None = None
    orbit_images: int = 22

    def layout(self) -> dict[str, Any]:
        """The layout's fields by name (to build another FlightLayout from this one)."""
        return {f.name: getattr(self, f.name) for f in fields(FlightLayout)}


# The numbers of a scan and their bounds (the scan of a plan or sites file is the user's).
SCAN_NUMBERS = {
    "site_diameter_m": SITE_DIAMETER_M, "width_px": IMAGE_PX, "height_px": IMAGE_PX,
    "hfov_rad": Bound(0, 3.1, "rad", above=True), "raster_altitude_m": HEIGHT_M,
    "raster_area_m": SITE_DIAMETER_M, "front_overlap": Bound(0, 0.95),
    "side_overlap": Bound(0, 0.95), "orbit_radius_m": SITE_DIAMETER_M,
    "orbit_altitude_m": HEIGHT_M, "orbit_images": Bound(3, 1_000, integer=True),
    "target_height_m": Bound(-1_000, 1_000, "m"), "transit_altitude_m": HEIGHT_M}


# The scan's site diameter under its name until 2026-11-30 (read, never written)
LEGACY_DIAMETER = "scale_m"

# The site diameter a scan is scaled to unless told otherwise (the survey's, the grid's,
# the mission's and the photo card's default), m
DEFAULT_SITE_DIAMETER_M = 60.0


@dataclass(frozen=True)
class ScanSpec(FlightLayout):
    """How one site is scanned: the layout scaled to `site_diameter_m` (the site diameter D), the
    orbit looking at `target_height_m` above the site centre; `transit_altitude_m` is the
    height the aircraft flies between sites (None: the highest scan waypoint)."""

    site_diameter_m: float = DEFAULT_SITE_DIAMETER_M
    target_height_m: float = 0.0
    transit_altitude_m: float | None = None

    def camera(self) -> Camera:
        cam = Camera.from_fov(self.width_px, self.height_px, self.hfov_rad)
        return replace(cam, dist=tuple(float(d) for d in self.dist))

    def check(self) -> None:
        _require(self.pattern in PATTERNS,
                 f"scan: pattern must be one of {PATTERNS}, got {self.pattern!r}")
        for name, bound in SCAN_NUMBERS.items():
            value = getattr(self, name)
            if value is None and self.__dataclass_fields__[name].default is None:
                continue  # None: scaled to the site
            bound.check(value, f"scan.{name}")
        _require(len(self.dist) == 5 and all(math.isfinite(d) for d in self.dist),
                 "scan: distortion needs 5 finite coefficients k1 k2 p1 p2 k3")

    def shots(self) -> list[tuple[str, Shot]]:
        """The camera poses of the scan, labelled by pattern, relative to the site centre."""
        self.check()
        cam = self.camera()
        d = self.site_diameter_m
        out: list[tuple[str, Shot]] = []
        if self.pattern in ("raster", "both"):
            area = self.raster_area_m if self.raster_area_m is not None else d
            alt = self.raster_altitude_m if self.raster_altitude_m is not None else d
            out += [("raster", s) for s in raster(cam, (0.0, 0.0), area, area, alt,
                                                  self.front_overlap, self.side_overlap)]
        if self.pattern in ("orbit", "both"):
            radius = self.orbit_radius_m if self.orbit_radius_m is not None else d
            alt = self.orbit_altitude_m if self.orbit_altitude_m is not None else 0.75 * d
            out += [("orbit", s) for s in orbit((0.0, 0.0, self.target_height_m), radius, alt,
                                                self.orbit_images)]
        return out

    def legs(self) -> list[ScanLeg]:
        """The scan as flown: per pattern its waypoints and trigger distance."""
        shots = self.shots()
        legs = []
        for pattern in ("raster", "orbit"):
            mine = [s for p, s in shots if p == pattern]
            if not mine:
                continue
            centres = np.array([s.pose.centre for s in mine])
            if pattern == "raster":
                lines = [s.line for s in mine]
                last = len(mine) - 1
                # The first and last shot of each line.
                keep = [k for k in range(len(mine)) if k in (0, last)
                        or lines[k] != lines[k - 1] or lines[k] != lines[k + 1]]
                same_line = [k for k in range(1, len(mine)) if lines[k] == lines[k - 1]]
                step = (float(np.linalg.norm(centres[same_line[0]] - centres[same_line[0] - 1]))
                        if same_line else 1.0)
                legs.append(ScanLeg("raster", centres[keep], step, len(mine),
                                    [s.pose for s in mine]))
            else:
                step = float(np.linalg.norm(centres[1] - centres[0]))
                legs.append(ScanLeg("orbit", centres, step, len(mine), [s.pose for s in mine]))
        return legs

    def reach_m(self, legs: list[ScanLeg] | None = None) -> float:
        """The farthest camera position of the scan from the site centre, horizontally:
        a photo farther than this (plus GPS error) was not taken over the site."""
        return max(float(np.hypot(leg.points_enu[:, 0], leg.points_enu[:, 1]).max())
                   for leg in legs or self.legs())

    def transit_m(self, legs: list[ScanLeg] | None = None) -> float:
        """The height flown between sites."""
        if self.transit_altitude_m is not None:
            return self.transit_altitude_m
        return max(float(leg.points_enu[:, 2].max()) for leg in legs or self.legs())

    def site_path(self, legs: list[ScanLeg] | None = None) -> np.ndarray:
        """The flight over one site relative to its centre: from the transit point above the
        first scan waypoint through every scan waypoint (the mission flies exactly this)."""
        legs = legs or self.legs()
        first = legs[0].points_enu[0]
        entry = np.array([first[0], first[1], self.transit_m(legs)])
        return np.vstack([entry, *[leg.points_enu for leg in legs]])

    def site_cost_m(self) -> float:
        """The scan cost of a site for the planner (the node cost of the expanded edge costs):
        from the transit point above the site centre to the scan's entry, the scan itself,
        and from its last waypoint back to the transit point above the centre. With it, the
        3-D flight between two sites is never longer than the planar distance of their
        centres plus half of each site's cost (triangle inequality), so a tour within the
        planner's budget is a flight within it."""
        legs = self.legs()
        path = self.site_path(legs)
        above_centre = np.array([0.0, 0.0, self.transit_m(legs)])
        return float(np.linalg.norm(path[0] - above_centre) + path_length(path)
                     + np.linalg.norm(path[-1] - above_centre))

    def takeoff_landing_m(self) -> float:
        """The climb to the transit height after take-off and the descent to land, flown once
        per tour."""
        return 2 * self.transit_m()

    def to_doc(self) -> JsonObject:
        doc = asdict(self)
        doc["dist"] = list(self.dist)
        return doc

    @classmethod
    def from_doc(cls, doc: Any, where: str = "scan") -> ScanSpec:
        if not isinstance(doc, dict):
            raise InputError(f"{where}: expected an object")
        known = {f for f in cls.__dataclass_fields__}
        kwargs: dict[str, Any] = {}
        doc = renamed(doc, "site_diameter_m", LEGACY_DIAMETER, where)  # until 2026-11-30
        for key, value in doc.items():
            if key not in known:
                continue  # unknown keys are ignored (../shared/INTERFACES.md)
            if key == "pattern":
                if not isinstance(value, str):
                    raise InputError(f"{where}.pattern: expected a string")
            elif key == "dist":
                if (not isinstance(value, list) or len(value) != 5
                        or not all(_is_number(v) for v in value)):
                    raise InputError(f"{where}.dist: expected 5 numbers")
                value = tuple(float(v) for v in value)
            elif key in ("width_px", "height_px", "orbit_images"):
                if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
                    raise InputError(f"{where}.{key}: expected a positive integer")
            elif value is not None and not _is_number(value):
                raise InputError(f"{where}.{key}: expected a finite number or null")
            kwargs[key] = value
        spec = cls(**kwargs)
        spec.check()
        return spec


def _is_number(v: Any) -> bool:
    return not isinstance(v, bool) and isinstance(v, int | float) and math.isfinite(v)


def path_length(points: np.ndarray | list[np.ndarray]) -> float:
    """Length of the polyline through `points` (3-D)."""
    return float(sum(np.linalg.norm(np.asarray(b) - np.asarray(a))
                     for a, b in itertools.pairwise(points)))


def scan_for_site(site_diameter_m: float = DEFAULT_SITE_DIAMETER_M, pattern: str = "raster",
                  raster_altitude_m: float | None = None,
                  transit_altitude_m: float | None = None) -> ScanSpec:
    """The scan of a site of `site_diameter_m` as the simulator lays it out for a mound of
    that diameter (height D / 5, the orbit looking at a third of it)."""
    SITE_DIAMETER_M.check(site_diameter_m, "--site-diameter")
    return ScanSpec(pattern=pattern, site_diameter_m=site_diameter_m,
                    raster_altitude_m=raster_altitude_m, target_height_m=site_diameter_m / 15,
                    transit_altitude_m=transit_altitude_m)


def flight_budget_m(endurance_s: float = 25 * 60, cruise_speed_m_s: float = 12.0,
                    reserve: float = 0.2) -> float:
    """A distance budget from the aircraft's endurance: a survey multicopter's 25 minutes
    at the default cruise speed, 20 % kept in reserve (14,400 m)."""
    return endurance_s * cruise_speed_m_s * (1 - reserve)
