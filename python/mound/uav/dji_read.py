"""DJI WPML missions read back (`read_kmz`): ours, to check what was written, and DJI's
own exports (`../shared/data/dji/`), the files the writer (dji.py) is held to.

The zip is read with bounds (its directory's sizes and again while inflating: no zip
bomb), the XML without DTDs or entities (jsonio.parse_xml); each wayline's waypoints
(position, height in its `executeHeightMode`, speed, heading), its photo spacing by action
group and the gimbal pitch in force at each waypoint; from the template its height mode
(one DJI allows there: WGS84 is a waylines mode only), its waypoints' heights, the
payload's image format and the take-off point. Every defect is an InputError naming the
file, the member and the element.
"""

from __future__ import annotations

import math
import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

from mound.errors import InputError
from mound.jsonio import number_text, parse_xml
from mound.uav.dji import (
    KML_NS,
    MAX_WAYPOINTS,
    TEMPLATE,
    TEMPLATE_HEIGHT_MODES,
    WAYLINE_HEIGHT_MODES,
    WAYLINES,
    WPML_NS,
)
from mound.uav.route import NADIR_DEG, Route, RoutePoint

if TYPE_CHECKING:
    from xml.etree.ElementTree import Element

MAX_MEMBER_BYTES = 32 * 2**20   # a wayline of 65,535 placemarks is about 100 MB: far more
MAX_MEMBERS = 64                 # than a survey flight's; DJI's own KMZs hold 2-3 files


@dataclass(frozen=True)
class Wayline:
    wayline_id: int
    height_mode: str
    points: tuple[RoutePoint, ...]


@dataclass(frozen=True)
class KmzMission:
    """What a DJI KMZ's waylines.wpml says (and its template's takeOffRefPoint)."""

    drone_enum: int
    drone_sub_enum: int
    payload_enum: int | None
    finish_action: str
    rth_height_m: float | None
    takeoff_ref: tuple[float, float, float] | None   # lat, lon, ellipsoidal height
    waylines: tuple[Wayline, ...]
    template_height_mode: str | None = None    # the template's heightMode (None: no template)
    template_heights: tuple[float, ...] = ()   # its waypoints' `height`, in that mode
    lenses: tuple[str, ...] = ()               # every takePhoto's payloadLensIndex, in order
    image_format: str | None = None            # the template's payloadParam imageFormat

    def route(self, wayline: int = 0) -> Route:
        """A wayline as a Route about the take-off point (its first waypoint where the
        template states none)."""
        w = self.waylines[wayline]
        lat, lon = (self.takeoff_ref[:2] if self.takeoff_ref
                    else (w.points[0].lat_deg, w.points[0].lon_deg))
        return Route(lat, lon, w.points, "home" if self.finish_action == "goHome" else "land")


class _Mark(NamedTuple):
    """A waypoint as its Placemark states it (the photo spacing and pitch come after)."""
    lat: float
    lon: float
    height_m: float
    speed_m_s: float
    heading_deg: float | None


class Template(NamedTuple):
    """What the template says of the mission: its heightMode (None: none, or no template),
    its waypoints' `height` in that mode and the payload's imageFormat."""
    height_mode: str | None = None
    heights: tuple[float, ...] = ()
    image_format: str | None = None


def _members(path: str | Path) -> dict[str, bytes]:
    """The KMZ's template and waylines, read with bounds (zip bombs: sizes checked from the
    directory and again while inflating)."""
    try:
        z = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError, ValueError) as e:
        raise InputError(f"{path}: not a KMZ (zip) file ({e})") from None
    with z:
        infos = z.infolist()
        if len(infos) > MAX_MEMBERS:
            raise InputError(f"{path}: {len(infos)} files in the zip, a KMZ holds a few")
        out = {}
        for name in (TEMPLATE, WAYLINES):
            info = next((i for i in infos if i.filename == name), None)
            if info is None:
                if name == TEMPLATE:
                    continue
                raise InputError(f"{path}: no {name} in the zip (not a DJI WPML mission)")
            if info.file_size > MAX_MEMBER_BYTES:
                raise InputError(f"{path}: {name} inflates to {info.file_size:,} bytes, more "
                                 f"than {MAX_MEMBER_BYTES:,}")
            try:
                with z.open(info) as f:
                    data = f.read(MAX_MEMBER_BYTES + 1)
            except (zipfile.BadZipFile, OSError, ValueError, NotImplementedError,
                    EOFError, RuntimeError, zlib.error) as e:
                raise InputError(f"{path}: {name}: cannot inflate ({e})") from None
            if len(data) > MAX_MEMBER_BYTES:
                raise InputError(f"{path}: {name} inflates beyond {MAX_MEMBER_BYTES:,} bytes")
            out[name] = data
    return out


def _opt_text(el: Element, name: str) -> str | None:
    """The text of `el`'s wpml:`name`, stripped (None where it is absent or empty)."""
    child = el.find(f"{{{WPML_NS}}}{name}")
    if child is None or child.text is None or not child.text.strip():
        return None
    return child.text.strip()


def _text(el: Element, name: str, where: str) -> str:
    text = _opt_text(el, name)
    if text is None:
        raise InputError(f"{where}: wpml:{name} missing")
    return text


def _opt_num(el: Element, name: str, where: str, lo: float, hi: float) -> float | None:
    text = _opt_text(el, name)
    return None if text is None else number_text(text, f"{where}: wpml:{name}", lo, hi)


def _num(el: Element, name: str, where: str, lo: float, hi: float) -> float:
    return number_text(_text(el, name, where), f"{where}: wpml:{name}", lo, hi)


def _whole(v: float, name: str, where: str) -> int:
    if v != int(v):
        raise InputError(f"{where}: wpml:{name}: expected an integer, got {v:g}")
    return int(v)


def _opt_int(el: Element, name: str, where: str, lo: int, hi: int) -> int | None:
    v = _opt_num(el, name, where, lo, hi)
    return None if v is None else _whole(v, name, where)


def _int(el: Element, name: str, where: str, lo: int, hi: int) -> int:
    return _whole(_num(el, name, where, lo, hi), name, where)


def _wayline(folder: Element, where: str) -> Wayline:
    ns = f"{{{WPML_NS}}}"
    mode = _text(folder, "executeHeightMode", where)
    if mode not in WAYLINE_HEIGHT_MODES:
        raise InputError(f"{where}: wpml:executeHeightMode: {mode!r:.40} is not a wayline "
                         f"height mode ({', '.join(WAYLINE_HEIGHT_MODES)})")
    wid = _int(folder, "waylineId", where, 0, 65_535)
    default_speed = _opt_num(folder, "autoFlightSpeed", where, 0, 100) or 0.0
    marks = folder.findall(f"{{{KML_NS}}}Placemark")
    if not marks:
        raise InputError(f"{where}: no Placemark (waypoint)")
    if len(marks) > MAX_WAYPOINTS:
        raise InputError(f"{where}: {len(marks)} waypoints, more than {MAX_WAYPOINTS:,}")
    rows: list[_Mark] = []
    photos: list[tuple[int, int, float]] = []
    pitch_at: dict[int, float] = {}
    for k, pm in enumerate(marks):
        at = f"{where}: Placemark[{k}]"
        coords = pm.find(f"{{{KML_NS}}}Point/{{{KML_NS}}}coordinates")
        text = "" if coords is None else (coords.text or "").strip()
        if not text:
            raise InputError(f"{at}: Point/coordinates missing")
        parts = text.split(",")
        try:
            lon, lat = (float(v) for v in parts[:2])
        except ValueError:
            raise InputError(f"{at}: coordinates: expected lon,lat, got {text[:40]!r}") from None
        if len(parts) not in (2, 3) or not (-180 <= lon <= 180 and -90 <= lat <= 90):
            raise InputError(f"{at}: coordinates: not a WGS84 lon,lat")
        index = _int(pm, "index", at, 0, MAX_WAYPOINTS)
        if index != k:
            raise InputError(f"{at}: wpml:index {index}: expected {k} (in order)")
        height = _num(pm, "executeHeight", at, -2_000, 10_000)
        speed = _opt_num(pm, "waypointSpeed", at, 0, 100)
        heading: float | None = None
        hp = pm.find(f"{ns}waypointHeadingParam")
        if hp is not None and _text(hp, "waypointHeadingMode", at) == "smoothTransition":
            heading = _num(hp, "waypointHeadingAngle", f"{at}.waypointHeadingParam", -180, 180)
        for g, group in enumerate(pm.findall(f"{ns}actionGroup")):
            gw = f"{at}: actionGroup[{g}]"
            start = _int(group, "actionGroupStartIndex", gw, 0, MAX_WAYPOINTS)
            end = _int(group, "actionGroupEndIndex", gw, 0, MAX_WAYPOINTS)
            trig = group.find(f"{ns}actionTrigger")
            if trig is None:
                raise InputError(f"{gw}: wpml:actionTrigger missing")
            kind = _text(trig, "actionTriggerType", gw)
            funcs = []
            for a, action in enumerate(group.findall(f"{ns}action")):
                aw = f"{gw}.action[{a}]"
                func = _text(action, "actionActuatorFunc", aw)
                funcs.append(func)
                param = action.find(f"{ns}actionActuatorFuncParam")
                if func == "gimbalRotate" and param is not None and _opt_text(
                        param, "gimbalPitchRotateEnable") == "1":
                    pitch_at[k] = _num(param, "gimbalPitchRotateAngle", aw, -120, 90)
            if kind == "multipleDistance" and "takePhoto" in funcs:
                d = _num(trig, "actionTriggerParam", gw, 0.01, 10_000)
                if not start <= end:
                    raise InputError(f"{gw}: start and end index out of order")
                photos.append((start, end, d))
        rows.append(_Mark(lat, lon, height, speed if speed is not None else default_speed,
                          heading))
    photo_every = [0.0] * len(rows)
    for start, end, d in photos:
        if end >= len(rows):
            raise InputError(f"{where}: an action group ends at waypoint {end}, past the last")
        for k in range(start, end):
            photo_every[k] = d
    pitch = NADIR_DEG
    points = []
    for k, r in enumerate(rows):
        pitch = pitch_at.get(k, pitch)
        points.append(RoutePoint(r.lat, r.lon, r.height_m, r.speed_m_s, photo_every[k], pitch,
                                 r.heading_deg))
    return Wayline(wid, mode, tuple(points))


def read_kmz(path: str | Path) -> KmzMission:
    """A DJI WPML KMZ (ours or DJI's own): its waylines' waypoints, heights in the file's
    frame, photos and gimbal pitches; InputError naming the file and element."""
    members = _members(path)
    root = parse_xml(members[WAYLINES], f"{path}: {WAYLINES}")
    if root.tag != f"{{{KML_NS}}}kml":
        raise InputError(f"{path}: {WAYLINES}: the root is not a KML <kml> element")
    doc = root.find(f"{{{KML_NS}}}Document")
    where = f"{path}: {WAYLINES}"
    if doc is None:
        raise InputError(f"{where}: no Document")
    mc = doc.find(f"{{{WPML_NS}}}missionConfig")
    if mc is None:
        raise InputError(f"{where}: wpml:missionConfig missing (namespace {WPML_NS}?)")
    drone = mc.find(f"{{{WPML_NS}}}droneInfo")
    if drone is None:
        raise InputError(f"{where}: wpml:droneInfo missing")
    payload = mc.find(f"{{{WPML_NS}}}payloadInfo")
    finish = _text(mc, "finishAction", where)
    folders = doc.findall(f"{{{KML_NS}}}Folder")
    if not folders:
        raise InputError(f"{where}: no Folder (wayline)")
    waylines = tuple(_wayline(f, f"{where}: Folder[{k}]") for k, f in enumerate(folders))
    takeoff = None
    template = Template()
    if TEMPLATE in members:
        troot = parse_xml(members[TEMPLATE], f"{path}: {TEMPLATE}")
        template = _template(troot, f"{path}: {TEMPLATE}")
        ref = troot.find(f"{{{KML_NS}}}Document/{{{WPML_NS}}}missionConfig/"
                         f"{{{WPML_NS}}}takeOffRefPoint")
        if ref is not None and ref.text:
            try:
                lat, lon, h = (float(v) for v in ref.text.strip().split(","))
            except ValueError:
                raise InputError(f"{path}: {TEMPLATE}: wpml:takeOffRefPoint: expected "
                                 "lat,lon,height") from None
            if not (-90 <= lat <= 90 and -180 <= lon <= 180 and math.isfinite(h)):
                raise InputError(f"{path}: {TEMPLATE}: wpml:takeOffRefPoint: not a place")
            takeoff = (lat, lon, h)
    return KmzMission(
        drone_enum=_int(drone, "droneEnumValue", where, 0, 65_535),
        drone_sub_enum=_opt_int(drone, "droneSubEnumValue", where, 0, 65_535) or 0,
        payload_enum=None if payload is None else _opt_int(payload, "payloadEnumValue", where, 0,
                                                       65_535),
        finish_action=str(finish),
        rth_height_m=_opt_num(mc, "globalRTHHeight", where, 0, 10_000),
        takeoff_ref=takeoff, waylines=waylines, lenses=_lenses(root),
        template_height_mode=template.height_mode, template_heights=template.heights,
        image_format=template.image_format)


def _lenses(root: Element) -> tuple[str, ...]:
    """Every takePhoto's payloadLensIndex (empty where a photo names none)."""
    out = []
    for param in root.iter(f"{{{WPML_NS}}}actionActuatorFuncParam"):
        lens = _opt_text(param, "payloadLensIndex")
        if lens is not None:
            out.append(lens[:40])
    return tuple(out)


def _template(root: Element, where: str) -> Template:
    """The template's height mode (one DJI allows there: WGS84 is a waylines mode only),
    its waypoints' heights in it and its payloadParam's imageFormat."""
    if root.tag != f"{{{KML_NS}}}kml":
        raise InputError(f"{where}: the root is not a KML <kml> element")
    folder = root.find(f"{{{KML_NS}}}Document/{{{KML_NS}}}Folder")
    if folder is None:
        return Template()
    sys_param = folder.find(f"{{{WPML_NS}}}waylineCoordinateSysParam")
    mode = None if sys_param is None else _opt_text(sys_param, "heightMode")
    if mode is not None and mode not in TEMPLATE_HEIGHT_MODES:
        raise InputError(f"{where}: wpml:heightMode: {mode!r:.40} is not a template height "
                         f"mode (DJI allows {', '.join(TEMPLATE_HEIGHT_MODES)}; WGS84 is a "
                         "waylines executeHeightMode only)")
    heights = []
    for k, pm in enumerate(folder.findall(f"{{{KML_NS}}}Placemark")):
        if pm.find(f"{{{KML_NS}}}Point") is None:
            continue  # an area template's polygon
        h = _opt_num(pm, "height", f"{where}: Placemark[{k}]", -2_000, 10_000)
        if h is not None:
            heights.append(h)
    param = folder.find(f"{{{WPML_NS}}}payloadParam")
    fmt = None if param is None else _opt_text(param, "imageFormat")
    return Template(mode, tuple(heights), None if fmt is None else fmt[:40])

