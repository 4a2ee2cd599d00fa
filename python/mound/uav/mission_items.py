"""From a planned tour (plan.json) to a MAVLink mission: a list of MISSION_ITEM_INT.

The mission, in order (MAVLink command numbers from common.xml):
    NAV_TAKEOFF (22) at home to the transit height; DO_CHANGE_SPEED (178) to the cruise
    speed; then for each visited site:
        NAV_WAYPOINT (16) transit to the site's scan entry point,
        DO_CHANGE_SPEED to the scan speed,
        for each scan pattern (raster and/or orbit, from the ScanSpec of
        mound.geometry.flight: the very poses the site simulator renders):
            [orbit: DO_SET_ROI_LOCATION (195) at the site centre]
            NAV_WAYPOINT to the pattern's first waypoint,
            DO_SET_CAM_TRIGG_DIST (206) on, at the pattern's image spacing (trigger now:
            the first photo there; none on the way down from the transit height),
            the pattern's other NAV_WAYPOINTs (raster: the ends of each line; orbit:
            every camera position),
            DO_SET_CAM_TRIGG_DIST 0 (off), [orbit: DO_SET_ROI_NONE (197)]
        DO_CHANGE_SPEED back to cruise;
    NAV_RETURN_TO_LAUNCH (20) for a closed tour, or NAV_WAYPOINT + NAV_LAND (21) at the end
    node of a path.
Navigation items use MAV_FRAME_GLOBAL_RELATIVE_ALT_INT (6): x, y are latitude and
longitude in 1e-7 degrees, z metres above home; commands use MAV_FRAME_MISSION (2).
Without a DEM the sites' ground is taken to be at home's height, and the summary says
"terrain not checked". With one (`terrain`, see flightplan/terrain.py) every height is planned in
metres above mean sea level and written relative to home's ground (the DEM's height at the
take-off point): the autopilot's relative altitude is zeroed there by its barometer at
take-off, which is steadier than GNSS altitude (metres of vertical error) and free of the
vehicle's geoid model, so the relative frame puts the aircraft where the DEM says; the
offset (home's AMSL height) is in the summary. Each leg climbs in place to a height that
clears the terrain by the clearance, flies level and descends in place over the next site;
the flight ends with an explicit landing at home instead of NAV_RETURN_TO_LAUNCH, whose
height is a vehicle parameter the mission cannot vouch for. Parameters are stored as
float32 values, as they travel on the link, so a mission read back from a vehicle compares
equal item by item.

Without a DEM, the flight distance (3-D length of home on the ground -> take-off height -> every
navigation waypoint -> home (or the end node) -> the ground) is checked against the plan's
budget before anything is written or uploaded. A plan made from a sites document whose
scan costs came from the same ScanSpec (`mound field make --scan-pattern`, which also
records the spec and the take-off/landing climb in the document, carried into plan.json by
mound_plan) always passes: the flight is at most the plan's cost (see
ScanSpec.site_cost_m). With a DEM the check is on the flight's energy (horizontal metres
plus the climb and descent factors times the metres climbed and descended), and a flight
over the budget is refused naming the leg whose climb costs most and the terrain point
that forces it; so is a scan that passes too close to the ground.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from mound.errors import InputError
from mound.flightplan.terrain import TerrainNode
from mound.formats.mission import (
    ClearanceSpec,
    FlightSummary,
    FlightTerrain,
    MissionSite,
    ScanRecord,
)
from mound.formats.plan import Plan
from mound.geometry.camera import Camera, Pose
from mound.geometry.flight import PATTERNS, ScanSpec, scan_for_site
from mound.geometry.geodesy import Origin, enu_to_geodetic

# MAV_CMD
NAV_WAYPOINT = 16
NAV_RETURN_TO_LAUNCH = 20
NAV_LAND = 21
NAV_TAKEOFF = 22
DO_CHANGE_SPEED = 178
DO_SET_ROI_LOCATION = 195
DO_SET_ROI_NONE = 197
DO_SET_CAM_TRIGG_DIST = 206
NAV_COMMANDS = {NAV_WAYPOINT, NAV_RETURN_TO_LAUNCH, NAV_LAND, NAV_TAKEOFF}
# MAV_FRAME
FRAME_GLOBAL = 0
FRAME_GLOBAL_RELATIVE_ALT = 3
FRAME_MISSION = 2
FRAME_GLOBAL_RELATIVE_ALT_INT = 6

NAN = float("nan")


def f32(v: float) -> float:
    """The float32 value a parameter has on the link."""
    return float(np.float32(v))


@dataclass(frozen=True)
class MissionItem:
    """One MISSION_ITEM_INT (seq is the item's position in the list)."""

    command: int
    frame: int
    params: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    x: int = 0      # latitude * 1e7 in global frames
    y: int = 0      # longitude * 1e7
    z: float = 0.0  # metres (above home in the relative frame)
    autocontinue: int = 1

    def __post_init__(self) -> None:
        object.__setattr__(self, "params", tuple(f32(p) for p in self.params))
        object.__setattr__(self, "z", f32(self.z))

    def same_as(self, other: MissionItem) -> bool:
        """Equal on the link: NaN parameters (\"unchanged\") compare equal."""
        def eq(a: float, b: float) -> bool:
            return (math.isnan(a) and math.isnan(b)) or a == b
        return (self.command == other.command and self.frame == other.frame
                and self.x == other.x and self.y == other.y and eq(self.z, other.z)
                and self.autocontinue == other.autocontinue
                and all(eq(a, b) for a, b in zip(self.params, other.params, strict=True)))

    @property
    def lat_deg(self) -> float:
        return self.x / 1e7

    @property
    def lon_deg(self) -> float:
        return self.y / 1e7


def home_item(origin: Origin) -> MissionItem:
    """ArduPilot's seq 0: the home position (absolute altitude)."""
    return MissionItem(NAV_WAYPOINT, FRAME_GLOBAL, (0, 0, 0, 0), round(origin.lat_deg * 1e7),
                       round(origin.lon_deg * 1e7), origin.alt_m)


@dataclass(frozen=True)
class TerrainInput:
    """The DEM a mission is flown over and how (flightplan/terrain.py)."""

    dem_path: str
    vertical: str | None = None       # None: what the DEM's CRS says
    spec: ClearanceSpec | None = None  # None: the defaults


@dataclass(frozen=True)
class MissionSpec:
    """How each site is scanned (the ScanSpec, shared with the simulator and the planner's
    scan costs) and how fast the aircraft flies."""

    scan: ScanSpec = field(default_factory=scan_for_site)
    cruise_speed_m_s: float = 12.0
    scan_speed_m_s: float = 5.0
    budget_slack: float = 0.0          # allowed excess over budget_m, as a fraction

    def check(self) -> None:
        if self.scan.pattern not in PATTERNS:
            raise InputError(f"mission: pattern must be one of {PATTERNS}")
        self.scan.check()
        for name in ("cruise_speed_m_s", "scan_speed_m_s"):
            if not getattr(self, name) > 0:
                raise InputError(f"mission: {name} must be > 0")
        if not 0 <= self.budget_slack <= 1:  # a fraction of the budget (NaN refused)
            raise InputError("mission: budget_slack must be in [0, 1]")


def image_footprint(camera: Camera, pose: Pose, max_range_m: float) -> np.ndarray:
    """(4, 3) ENU points where the image corners' rays meet the ground z = 0 (rays that
    miss it, above the horizon, are cut at `max_range_m`)."""
    w, h = camera.width_px - 1, camera.height_px - 1
    corners = np.array([[0, 0, 1], [w, 0, 1], [w, h, 1], [0, h, 1]], dtype=float)
    rays = (pose.R.T @ (np.linalg.inv(camera.K) @ corners.T)).T
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    c = pose.centre
    out = []
    for r in rays:
        t = -c[2] / r[2] if r[2] < -1e-9 else np.inf
        out.append(c + min(t, max_range_m) * r)
    return np.array(out)


def up(h: float) -> np.ndarray:
    return np.array([0.0, 0.0, h])


@dataclass(frozen=True)
class Footprint:
    """An image's footprint on the ground: its corners, ENU metres (z 0 at the site's
    ground), of image `image` of the site's `pattern` leg."""

    site: str
    pattern: str
    image: int
    corners_enu_m: list[list[float]]

    def ring(self) -> np.ndarray:
        """The corners closed (the first again at the end), (5, 3)."""
        return np.array(self.corners_enu_m + self.corners_enu_m[:1])


@dataclass
class Mission:
    items: list[MissionItem]
    origin: Origin
    flight_distance_m: float
    budget_m: float
    closed: bool
    sites: list[MissionSite]
    nav_enu: list[np.ndarray]  # the 3-D flight path, ENU, z above home, for exports
    footprints: list[Footprint]
    spec: MissionSpec
    # With a DEM: home's ground, the energy, the legs' heights and terrain profiles.
    terrain: FlightTerrain | None = None
    # Each site's scan as the indexes of its first and last item (ItemWriter.scans): what
    # an in-flight re-plan keeps of a mission the aircraft is flying.
    scans: dict[str, tuple[int, int]] = field(default_factory=dict)

    def summary(self) -> FlightSummary:
        """The flight's summary (its number, file and formats are the writer's to add)."""
        return FlightSummary(
            self.origin, len(self.items), self.flight_distance_m, self.budget_m, self.closed,
            tuple(self.sites), "MAV_FRAME_GLOBAL_RELATIVE_ALT: metres above home"
            + ("'s ground (the DEM's height there)" if self.terrain else ""), self.terrain,
            ScanRecord(self.spec.scan.pattern, self.spec.scan.site_diameter_m,
                       self.spec.cruise_speed_m_s, self.spec.scan_speed_m_s))


# Magnitudes a plan can have (the same bounds as mound_plan's reader): local coordinates
# within 10^8 m, scan costs within 10^8 m, budgets within 10^12 m.
MAX_BUDGET_M = 1e12


def plan_nodes(plan: Plan) -> tuple[list[TerrainNode], bool, float]:
    """Validated (tour nodes with positions, closed?, budget) of a plan of one flight."""
    if len(plan.flights) != 1:
        raise InputError(f"flights: a mission flies one flight, the plan has "
                         f"{len(plan.flights)} (mission_items.flight_plans splits them)")
    tour = plan.flights[0].tour
    if not plan.waypoints:
        raise InputError("waypoints: missing (positions of the tour's nodes); re-plan with "
                         "mound_plan, which writes them")
    by_id = {w.id: w for w in plan.waypoints}
    nodes = []
    for k, node_id in enumerate(tour):
        w = by_id.get(node_id)
        if w is None:
            raise InputError(f"tour[{k}]: site {node_id!r} has no coordinates in waypoints")
        nodes.append(TerrainNode(node_id, w.kind, w.x_m, w.y_m, w.scan_cost_m))
    if not plan.budget_m <= MAX_BUDGET_M:
        raise InputError(f"plan.budget_m: must be a number in [0, {MAX_BUDGET_M:g}]")
    return nodes, plan.closed, plan.budget_m


def flight_plans(plan: Plan) -> list[tuple[int, Plan]]:
    """Each flight that visits a site as a plan of its own, with its number (1-based;
    mound_plan orders flights by reward); a plan of one flight is itself (build() says when
    there is nothing to fly)."""
    if len(plan.flights) == 1:
        return [(1, plan)]
    return [(k, replace(plan, flights=(f,))) for k, f in enumerate(plan.flights, start=1)
            if f.sites]  # of several flights, one with nothing to visit is not flown


class ItemWriter:
    """The one writer of a mission's items, flat or over terrain: positions are ENU metres
    whose z is above the frame's datum `datum_m` (0 without a DEM, where z is already above
    home; home's ground AMSL over one), written relative to it in
    MAV_FRAME_GLOBAL_RELATIVE_ALT_INT; `path` holds every position flown, from `start`."""

    def __init__(self, origin: Origin, datum_m: float, start: np.ndarray) -> None:
        self.origin = origin
        self.datum_m = float(datum_m)
        self.items: list[MissionItem] = []
        self.path: list[np.ndarray] = [np.asarray(start, dtype=float)]
        self.scans: dict[str, tuple[int, int]] = {}  # site id -> its scan's first, last item

    def _geo(self, p: np.ndarray) -> tuple[int, int]:
        lat, lon, _ = enu_to_geodetic(self.origin, np.array([[p[0], p[1], 0.0]]))[0]
        return round(lat * 1e7), round(lon * 1e7)

    def nav(self, command: int, p: np.ndarray, params: tuple = (0.0, 0.0, 0.0, NAN)) -> None:
        """A navigation item to `p` (flown: it joins the path)."""
        x, y = self._geo(p)
        self.items.append(MissionItem(command, FRAME_GLOBAL_RELATIVE_ALT_INT, params, x, y,
                                      float(p[2]) - self.datum_m))
        self.path.append(np.asarray(p, dtype=float))

    def do(self, command: int, params: tuple, p: np.ndarray | None = None,
           frame: int = FRAME_MISSION) -> None:
        """A command item (at `p` where it names a place)."""
        x, y = self._geo(p) if p is not None else (0, 0)
        z = float(p[2]) - self.datum_m if p is not None else 0.0
        self.items.append(MissionItem(command, frame, params, x, y, z))

    def scan_site(self, spec: MissionSpec, centre: np.ndarray, site_id: str,
                  legs: list[Any] | None = None) -> tuple[int, list[Footprint]]:
        """The site's scan from where the aircraft is (over its entry point): the scan
        speed, each pattern's waypoints with the camera triggered (and the region of
        interest on an orbit), back to cruise. `centre` is the site's centre on its ground
        (z: the ground's height in the writer's frame); `legs` the scan's (scan.legs(), once
        per mission). Returns the images taken and the images' footprints (ENU corners
        about the centre at z 0)."""
        scan = spec.scan
        cam = scan.camera()
        images = 0
        first = len(self.items)
        footprints: list[Footprint] = []
        self.do(DO_CHANGE_SPEED, (1.0, spec.scan_speed_m_s, -1.0, 0.0))
        for leg in legs if legs is not None else scan.legs():
            if leg.pattern == "orbit":
                self.do(DO_SET_ROI_LOCATION, (0.0, 0.0, 0.0, 0.0),
                        centre + up(scan.target_height_m), FRAME_GLOBAL_RELATIVE_ALT_INT)
            # The camera starts at the pattern's first waypoint (a photo there, then every
            # trigger_m), not above it: no photo on the way down from the transit height.
            self.nav(NAV_WAYPOINT, centre + leg.points_enu[0])
            self.do(DO_SET_CAM_TRIGG_DIST, (leg.trigger_m, 0.0, 1.0, 0.0))
            for p in leg.points_enu[1:]:
                self.nav(NAV_WAYPOINT, centre + p)
            self.do(DO_SET_CAM_TRIGG_DIST, (0.0, 0.0, 0.0, 0.0))
            if leg.pattern == "orbit":
                self.do(DO_SET_ROI_NONE, (0.0, 0.0, 0.0, 0.0))
            images += leg.images
            reach = 3 * float(leg.points_enu[:, 2].max())
            on_ground = np.array([centre[0], centre[1], 0.0])
            for k, pose in enumerate(leg.poses):
                footprints.append(Footprint(site_id, leg.pattern, k, (
                    on_ground + image_footprint(cam, pose, reach)).tolist()))
        self.do(DO_CHANGE_SPEED, (1.0, spec.cruise_speed_m_s, -1.0, 0.0))
        self.scans[site_id] = (first, len(self.items) - 1)
        return images, footprints
