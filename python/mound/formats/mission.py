"""mound.mission v1 (mission.json): the missions the survey wrote, as one typed value.

A flight's summary (`FlightSummary`): its MAVLink items, flight distance and budget
(metres), the sites it scans (`MissionSite`), the heights' frame, the scan, the file and
each format's entry (`FormatEntry`: what its files are, or the limit that refused it), and
over a DEM its terrain (`FlightTerrain`: the DEM, home's ground, the clearances asked for
(`ClearanceSpec`), the energy, and each transit leg (`TerrainLeg`) with its clearance and,
in memory, its profile). `MissionSummary` is the file: the only flight's own members, or
of several their totals, each flight under `flights`; the upload's record when the
mission went to a vehicle, the second looks' sites when it is second_look/mission.json.

Written by the mission stage (survey/stages/mission.write_missions), each battery of a day
and the second looks; read by the report and the day's record (`MissionSummary.read`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass
from pathlib import Path

from mound.bounds import Bound
from mound.errors import InputError
from mound.geometry.geodesy import Origin
from mound.jsonio import (
    JsonObject,
    as_object,
    check_doc,
    id_list,
    list_member,
    load_json,
    number_list,
    optional_number,
    optional_number_list,
    optional_string,
    require_count,
    require_id,
    require_number,
    require_string,
    string_list,
)

SCHEMA = "mound.mission"
VERSION = 1
CLEARANCE_M = Bound(0, 10_000, "m")  # clearances and the footprint
FACTOR = Bound(1, 100)               # metres of level flight per metre climbed or descended
NOT_CHECKED = ("terrain not checked: heights above home, the sites' ground taken to be at "
               "home's height")


@dataclass(frozen=True)
class ClearanceSpec:
    """How the aircraft treats the terrain (metres, and metres of flight per metre): the
    `terrain` block's clearances of a sites.json, a plan and a mission over a DEM."""

    clearance_m: float = 30.0        # transit legs above the highest terrain near them
    scan_clearance_m: float = 10.0   # scan waypoints and lines above the terrain
    footprint_m: float = 10.0        # horizontal margin: GNSS error and the airframe
    climb_factor: float = 3.0
    descent_factor: float = 2.0
    vertical: str = "egm96"          # what the DEM's heights are above (before conversion)

    def check(self) -> None:
        for name in ("clearance_m", "scan_clearance_m", "footprint_m"):
            CLEARANCE_M.check(getattr(self, name), f"--{name.replace('_', '-')}")
        for name in ("climb_factor", "descent_factor"):
            FACTOR.check(getattr(self, name), f"--{name.replace('_', '-')}")

    def to_doc(self) -> JsonObject:
        return asdict(self)

    @classmethod
    def from_doc(cls, doc: object, where: str = "terrain") -> ClearanceSpec:
        d = as_object(doc, where)
        kw = {name: require_number(d, name, where, lo=0, hi=10_000, default=getattr(cls, name))
              for name in ("clearance_m", "scan_clearance_m", "footprint_m", "climb_factor",
                           "descent_factor")}
        spec = cls(**kw, vertical=require_string(d, "vertical", where, cls.vertical))
        spec.check()
        return spec


@dataclass(frozen=True)
class MissionSite:
    """A site the mission scans: where (ENU m), the scan flown and the plan's cost of it;
    over a DEM its ground (AMSL) and the legs' heights above it."""

    id: str
    x_m: float
    y_m: float
    scan_length_m: float
    images: int
    scan_cost_m: float
    ground_amsl_m: float | None = None
    scan_height_above_ground_m: tuple[float, ...] | None = None

    def to_doc(self) -> JsonObject:
        over: JsonObject = {}
        if self.ground_amsl_m is not None:
            over["ground_amsl_m"] = self.ground_amsl_m
        if self.scan_height_above_ground_m is not None:
            over["scan_height_above_ground_m"] = list(self.scan_height_above_ground_m)
        return {"id": self.id, "x_m": self.x_m, "y_m": self.y_m, **over,
                "scan_length_m": self.scan_length_m, "images": self.images,
                "scan_cost_m": self.scan_cost_m}

    @classmethod
    def from_doc(cls, doc: object, where: str) -> MissionSite:
        d = as_object(doc, where)
        return cls(require_id(d.get("id"), f"{where}.id"), require_number(d, "x_m", where),
                   require_number(d, "y_m", where),
                   require_number(d, "scan_length_m", where, lo=0),
                   require_count(d, "images", where), require_number(d, "scan_cost_m", where, lo=0),
                   optional_number(d, "ground_amsl_m", where),
                   optional_number_list(d, "scan_height_above_ground_m", where))


@dataclass(frozen=True)
class LegProfile:
    """A transit leg's profile on its straight line: distance along it (m) against the
    terrain's height and the height flown (AMSL)."""

    distance_m: tuple[float, ...]
    terrain_amsl_m: tuple[float, ...]
    flight_amsl_m: float
    start_enu_m: tuple[float, float]   # where the leg's level part starts and ends (ENU)
    end_enu_m: tuple[float, float]

    def to_doc(self) -> JsonObject:
        return {"distance_m": list(self.distance_m),
                "terrain_amsl_m": list(self.terrain_amsl_m),
                "flight_amsl_m": self.flight_amsl_m}


@dataclass(frozen=True)
class TerrainLeg:
    """A transit leg over the DEM: from and to (node ids), the height flown (AMSL), the
    highest terrain near it and where (ENU), the clearance it keeps, its climbs' cost (m),
    and (in memory, for the figures and the GeoJSON) its profile."""

    from_id: str
    to_id: str
    transit_amsl_m: float
    terrain_max_amsl_m: float
    terrain_max_enu_m: tuple[float, float]
    clearance_m: float
    cost_m: float
    profile: LegProfile | None = None

    def to_doc(self) -> JsonObject:
        return {"from": self.from_id, "to": self.to_id, "transit_amsl_m": self.transit_amsl_m,
                "terrain_max_amsl_m": self.terrain_max_amsl_m,
                "terrain_max_enu_m": list(self.terrain_max_enu_m),
                "clearance_m": self.clearance_m, "cost_m": self.cost_m}

    @classmethod
    def from_doc(cls, doc: object, where: str) -> TerrainLeg:
        d = as_object(doc, where)
        top = number_list(d.get("terrain_max_enu_m"), f"{where}.terrain_max_enu_m", 2)
        return cls(require_id(d.get("from"), f"{where}.from"),
                   require_id(d.get("to"), f"{where}.to"),
                   require_number(d, "transit_amsl_m", where),
                   require_number(d, "terrain_max_amsl_m", where), (top[0], top[1]),
                   require_number(d, "clearance_m", where), require_number(d, "cost_m", where))


@dataclass(frozen=True)
class FlightTerrain:
    """A flight over a DEM: the DEM (its file and CRS), home's ground (AMSL), the
    clearances asked for, the energy flown (metres of level flight: the path plus the
    climbs' and descents' factors), the metres climbed and descended, the plan's cost of
    the flight, the transit legs and the lowest clearance among them."""

    dem: str
    dem_crs: str
    home_amsl_m: float
    clearance: ClearanceSpec
    energy_m: float
    climbed_m: float
    descended_m: float
    plan_cost_m: float | None
    legs: tuple[TerrainLeg, ...]

    @property
    def lowest_clearance_m(self) -> float | None:
        return min((leg.clearance_m for leg in self.legs), default=None)

    def to_doc(self) -> JsonObject:
        return {"checked": True, "dem": self.dem, "dem_crs": self.dem_crs,
                "vertical": self.clearance.vertical, "home_amsl_m": self.home_amsl_m,
                **self.clearance.to_doc(), "energy_m": self.energy_m,
                "climbed_m": self.climbed_m, "descended_m": self.descended_m,
                "plan_cost_m": self.plan_cost_m, "legs": [leg.to_doc() for leg in self.legs],
                "lowest_clearance_m": self.lowest_clearance_m}

    @classmethod
    def from_doc(cls, doc: object, where: str) -> FlightTerrain | None:
        """None: a flight whose terrain was not checked (no DEM)."""
        d = as_object(doc, where)
        if d.get("checked") is False:
            return None
        return cls(require_string(d, "dem", where), require_string(d, "dem_crs", where),
                   require_number(d, "home_amsl_m", where), ClearanceSpec.from_doc(d, where),
                   require_number(d, "energy_m", where, lo=0),
                   require_number(d, "climbed_m", where, lo=0),
                   require_number(d, "descended_m", where, lo=0),
                   optional_number(d, "plan_cost_m", where),
                   tuple(TerrainLeg.from_doc(x, f"{where}.legs[{k}]")
                         for k, x in enumerate(list_member(d, "legs", where))))


# What a format's files are (their heights, aircraft, crew settings): mission.json's words.
About = dict[str, str | dict[str, str]]


@dataclass(frozen=True)
class FormatEntry:
    """A format's entry in mission.json's `formats`: what its files are and their names,
    or (no files) the limit that refused the flight."""

    about: About
    files: tuple[str, ...] = ()
    refused: str | None = None

    def to_doc(self) -> JsonObject:
        return {**self.about, "files": list(self.files),
                **({"refused": self.refused} if self.refused is not None else {})}

    @classmethod
    def from_doc(cls, doc: object, where: str) -> FormatEntry:
        d = as_object(doc, where)
        files = string_list(d, "files", where)
        refused = optional_string(d, "refused", where)
        about: About = {}
        for k, v in d.items():
            if k in ("files", "refused"):
                continue
            if isinstance(v, str):
                about[k] = v
            elif isinstance(v, dict) and all(isinstance(x, str) for x in v.values()):
                about[k] = {str(a): b for a, b in v.items()}
            else:
                raise InputError(f"{where}.{k}: expected a string or an object of strings")
        return cls(about, tuple(files), refused)


@dataclass(frozen=True)
class ScanRecord:
    """The scan a flight flies: its pattern, the site's diameter it covers (m), the speeds
    (m/s) of the transit and of the scan."""

    pattern: str
    site_diameter_m: float
    cruise_speed_m_s: float
    scan_speed_m_s: float

    def to_doc(self) -> JsonObject:
        return asdict(self)

    @classmethod
    def from_doc(cls, doc: object, where: str) -> ScanRecord:
        d = as_object(doc, where)
        return cls(require_string(d, "pattern", where), require_number(d, "site_diameter_m", where),
                   require_number(d, "cruise_speed_m_s", where),
                   require_number(d, "scan_speed_m_s", where))


@dataclass(frozen=True)
class FlightSummary:
    """One flight's mission (mission.json, or its `flights[k]`; the .plan's `mound`
    member): `flight` its number (1 when it is the only one), `file` its reference (.plan)
    file, `formats` each format's entry (None, left out: not written yet)."""

    origin: Origin
    items: int
    flight_distance_m: float
    budget_m: float
    closed: bool
    sites: tuple[MissionSite, ...]
    altitude_frame: str
    terrain: FlightTerrain | None
    scan: ScanRecord
    flight: int | None = None
    file: str | None = None
    formats: Mapping[str, FormatEntry] | None = None

    def terrain_doc(self) -> JsonObject:
        return ({"checked": False, "note": NOT_CHECKED} if self.terrain is None
                else self.terrain.to_doc())

    def to_doc(self) -> JsonObject:
        return {"schema": SCHEMA, "version": VERSION, "origin": self.origin.to_doc(),
                "items": self.items, "flight_distance_m": self.flight_distance_m,
                "budget_m": self.budget_m, "closed": self.closed,
                "sites": [x.to_doc() for x in self.sites],
                "altitude_frame": self.altitude_frame, "terrain": self.terrain_doc(),
                "scan": self.scan.to_doc(),
                **({} if self.flight is None else {"flight": self.flight}),
                **({} if self.file is None else {"file": self.file}),
                **({} if self.formats is None else
                   {"formats": {name: e.to_doc() for name, e in self.formats.items()}})}

    @classmethod
    def from_doc(cls, doc: object, where: str) -> FlightSummary:
        d = as_object(doc, where)
        closed = d.get("closed")
        if not isinstance(closed, bool):
            raise InputError(f"{where}.closed: expected true or false")
        formats = d.get("formats")
        flight = optional_number(d, "flight", where, lo=1, hi=1e6)
        return cls(
            Origin.from_doc(d.get("origin"), f"{where}.origin"),
            require_count(d, "items", where), require_number(d, "flight_distance_m", where, lo=0),
            require_number(d, "budget_m", where, lo=0), closed,
            tuple(MissionSite.from_doc(x, f"{where}.sites[{k}]")
                  for k, x in enumerate(list_member(d, "sites", where))),
            require_string(d, "altitude_frame", where),
            FlightTerrain.from_doc(d.get("terrain"), f"{where}.terrain"),
            ScanRecord.from_doc(d.get("scan"), f"{where}.scan"),
            None if flight is None else int(flight),
            optional_string(d, "file", where),
            None if formats is None else
            {str(k): FormatEntry.from_doc(v, f"{where}.formats.{k}")
             for k, v in as_object(formats, f"{where}.formats").items()})


@dataclass(frozen=True)
class UploadRecord:
    """A mission sent to a vehicle over MAVLink (`--connect`) and, verified, read back."""

    connect: str
    file: str
    items: int
    target_system: int
    elapsed_s: float
    retransmissions: int
    restarts: int
    verified: bool | None  # None: not read back (no --verify)
    notes: tuple[str, ...] = ()

    def to_doc(self) -> JsonObject:
        return {**asdict(self), "notes": list(self.notes)}

    @classmethod
    def from_doc(cls, doc: object, where: str) -> UploadRecord:
        d = as_object(doc, where)
        verified = d.get("verified")
        if verified is not None and not isinstance(verified, bool):
            raise InputError(f"{where}.verified: expected true, false or null")
        return cls(require_string(d, "connect", where), require_string(d, "file", where),
                   require_count(d, "items", where), require_count(d, "target_system", where),
                   require_number(d, "elapsed_s", where, lo=0),
                   require_count(d, "retransmissions", where), require_count(d, "restarts", where),
                   verified, tuple(str(x) for x in list_member(d, "notes", where)))


@dataclass(frozen=True)
class Refusal:
    """A site a second look could not fly, and why."""

    id: str
    reason: str

    def to_doc(self) -> JsonObject:
        return {"id": self.id, "reason": self.reason}


@dataclass(frozen=True)
class SecondLookMissions:
    """second_look/mission.json's `second_look`: the sites the verdicts advised a second
    look at, the scan factor and the site diameter its scan covers (m), the sites flown and
    those refused (why)."""

    sites: tuple[str, ...]
    scan_factor: float
    site_diameter_m: float
    flown: tuple[str, ...]
    refused: tuple[Refusal, ...] = ()

    def to_doc(self) -> JsonObject:
        return {"sites": list(self.sites), "scan_factor": self.scan_factor,
                "site_diameter_m": self.site_diameter_m, "flown": list(self.flown),
                "refused": [r.to_doc() for r in self.refused]}

    @classmethod
    def from_doc(cls, doc: object, where: str) -> SecondLookMissions:
        d = as_object(doc, where)
        refused = []
        for k, r in enumerate(list_member(d, "refused", where)):
            w = f"{where}.refused[{k}]"
            refused.append(Refusal(require_id(as_object(r, w).get("id"), f"{w}.id"),
                                   require_string(r, "reason", w)))
        return cls(tuple(id_list(d, "sites", where)),
                   require_number(d, "scan_factor", where, lo=1, hi=100),
                   require_number(d, "site_diameter_m", where, lo=0),
                   tuple(id_list(d, "flown", where)),
                   tuple(refused))


@dataclass(frozen=True)
class MissionSummary:
    """mission.json: its flights (none: a second look that could fly no site), with their
    totals (MAVLink items, flight distance, m) and the budget; the upload and the second
    looks' record where there are."""

    flights: tuple[FlightSummary, ...]
    budget_m: float
    origin: Origin | None = None  # without a flight (else the first flight's)
    upload: UploadRecord | None = None
    second_look: SecondLookMissions | None = None

    @property
    def items(self) -> int:
        return sum(f.items for f in self.flights)

    @property
    def flight_distance_m(self) -> float:
        return sum(f.flight_distance_m for f in self.flights)

    def to_doc(self) -> JsonObject:
        """The only flight's own members (with `flights` holding it), or of several (or
        none) their totals."""
        origin = self.flights[0].origin if self.flights else self.origin
        doc: JsonObject = (
            self.flights[0].to_doc() if len(self.flights) == 1 else
            {"schema": SCHEMA, "version": VERSION,
             "origin": None if origin is None else origin.to_doc(),
             "items": self.items, "flight_distance_m": self.flight_distance_m,
             "budget_m": self.budget_m,
             **({"terrain": self.flights[0].terrain_doc()} if self.flights else {})})
        doc["flights"] = [f.to_doc() for f in self.flights]
        if self.upload is not None:
            doc["upload"] = self.upload.to_doc()
        if self.second_look is not None:
            doc["second_look"] = self.second_look.to_doc()
        return doc

    @classmethod
    def from_doc(cls, doc: object, path: str | Path) -> MissionSummary:
        """The flights, the upload and the second looks; the totals are the flights' (the
        only flight's members are its own; the origin is read only without a flight)."""
        d = check_doc(doc, path, SCHEMA, VERSION)
        where = str(path)
        flights = tuple(FlightSummary.from_doc(f, f"{where}: flights[{k}]")
                        for k, f in enumerate(list_member(d, "flights", where)))
        origin = d.get("origin")
        upload, second = d.get("upload"), d.get("second_look")
        return cls(flights, flights[0].budget_m if len(flights) == 1
                   else require_number(d, "budget_m", where, lo=0),
                   None if origin is None or flights
                   else Origin.from_doc(origin, f"{where}: origin"),
                   None if upload is None else UploadRecord.from_doc(upload, f"{where}: upload"),
                   None if second is None
                   else SecondLookMissions.from_doc(second, f"{where}: second_look"))

    @classmethod
    def read(cls, path: str | Path) -> MissionSummary:
        return cls.from_doc(load_json(path), path)

