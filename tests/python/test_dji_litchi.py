"""Issue 55: the survey's flights for the aircraft field teams fly. A three-flight plan over
the shared laser DEM (raster and orbit scans on the ridges) built as `.plan`, DJI WPML
`.kmz` and Litchi `.csv`: the KMZ holds DJI's two files in DJI's namespace with the element
set of DJI's own exports, its heights clear the DEM when taken back to AMSL by PROJ alone,
and every format reads back as the `.plan` flies (path and heights within 0.1 m, photo
spacing, gimbal pitch and heading); Litchi's file read by an independent reader
(litchi-wp). DJI's own KMZs are read; bad files are refused naming the file."""

from __future__ import annotations

import itertools
import json
import math
import re
import subprocess
import sys
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from pyproj.transformer import TransformerGroup
from scipy.ndimage import maximum_filter
from test_terrain_flight import TO_TM, clearance_along, sites_doc

from mound import native
from mound.errors import InputError
from mound.flightplan import terrain
from mound.formats.sites import Sites
from mound.geometry.dem import use_proj_grids
from mound.geometry.flight import scan_for_site
from mound.geometry.geodesy import Origin, geodetic_to_enu
from mound.paths import REPO_ROOT
from mound.uav import dji, dji_read, litchi, mission_items
from mound.uav import files as mission_files
from mound.uav.filetypes import dji_kmz
from mound.uav.route import Route, RoutePoint, items_route, mission_route

DJI_NS = "{" + dji.WPML_NS + "}"


def mound(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mound", *args], capture_output=True,
                          text=True, cwd=REPO_ROOT, check=False, timeout=300)


@pytest.fixture(scope="module")
def three(raw, dem_path, tmp_path_factory) -> dict[str, Any]:
    """Ten ridge sites scanned with the raster and the orbit, planned in three flights
    over the DEM, and built in every format."""
    tmp = tmp_path_factory.mktemp("dji")
    doc = sites_doc(raw, 4500.0)
    scan = scan_for_site(60.0, "both")
    doc["scan"] = scan.to_doc()
    origin = Origin.from_doc(doc["origin"])
    spec = terrain.ClearanceSpec()
    sites = tmp / "sites.json"
    sites.write_text(json.dumps(terrain.attach(Sites.from_doc(doc, "test"), str(dem_path), spec,
                                              "egm96", origin).to_doc()))
    plan_file = tmp / "plan.json"
    native.run_tool("mound_plan", [str(sites), "--flights", "3", "--out", str(plan_file)])
    plan = json.loads(plan_file.read_text())
    flights = [f["flight"] for f in plan["flights"] if len(f["tour"]) > 2]
    assert len(flights) == 3
    r = mound("mission", "build", str(plan_file), "--out", str(tmp / "m.plan"), "--dji-kmz",
              str(tmp / "m.kmz"), "--aircraft", "m3e", "--litchi", str(tmp / "m.csv"),
              "--dem", str(dem_path), "--dem-vertical", "egm96")
    assert r.returncode == 0, r.stderr
    return {"tmp": tmp, "plan": plan_file, "flights": flights, "spec": spec}


def _plan_route(path: Path) -> Route:
    items, _, _ = mission_files.read_mission(path)
    return items_route(items)


def _dji_element_set() -> set[str]:
    names: set[str] = set()
    for kmz in sorted((REPO_ROOT.parent / "shared" / "data" / "dji").glob("*.kmz")):
        with zipfile.ZipFile(kmz) as z:
            for name in z.namelist():
                names |= set(re.findall(r"<wpml:(\w+)", z.read(name).decode()))
    return names


def test_the_kmz_is_dji_wpml(three) -> None:
    """Exactly DJI's two files, DJI's namespace, only elements DJI's own exports use, the
    aircraft's enum values from the table."""
    known = _dji_element_set()
    assert {"missionConfig", "executeHeight", "actionGroup"} <= known
    for f in three["flights"]:
        path = three["tmp"] / f"m_{f}.kmz"
        with zipfile.ZipFile(path) as z:
            assert sorted(z.namelist()) == [dji.TEMPLATE, dji.WAYLINES]
            for name in z.namelist():
                text = z.read(name).decode()
                assert f'xmlns:wpml="{dji.WPML_NS}"' in text
                ours = set(re.findall(r"<wpml:(\w+)", text))
                assert ours <= known, ours - known
                for el in ("missionConfig", "droneEnumValue", "payloadEnumValue",
                           "finishAction", "executeRCLostAction", "takeOffSecurityHeight",
                           "globalRTHHeight", "waypointSpeed", "actionTriggerType"):
                    assert f"<wpml:{el}>" in text, (name, el)
            assert "<wpml:takeOffRefPoint>" in z.read(dji.TEMPLATE).decode()
        k = dji_read.read_kmz(path)
        craft = dji.AIRCRAFT["m3e"]
        assert (k.drone_enum, k.drone_sub_enum, k.payload_enum) == (
            craft.drone_enum, craft.drone_sub_enum, craft.payload_enum)
        assert [w.height_mode for w in k.waylines] == ["relativeToStartPoint"]
        assert k.finish_action == "autoLand"  # over a DEM: the flight lands over home


def _egm96_minus_ellipsoid(lon: np.ndarray, lat: np.ndarray) -> np.ndarray:
    """The geoid separation N by PROJ alone (EGM96 heights + N = ellipsoidal)."""
    use_proj_grids()
    g = TransformerGroup("EPSG:4979", "EPSG:4326+5773", always_xy=True)
    assert g.best_available
    _, _, h = g.transformers[0].transform(lon, lat, np.zeros(len(lon)))
    return -np.asarray(h)


def test_the_kmz_heights_clear_the_dem(three, raw, dem_path) -> None:
    """Every leg of every flight, its heights taken back to AMSL from the file alone
    (takeOffRefPoint's ellipsoidal height less PROJ's geoid there, plus the relative
    heights), clears the highest terrain within the footprint by the scan clearance."""
    spec = three["spec"]
    highest = maximum_filter(raw[0], size=2 * int(np.ceil(spec.footprint_m)) + 1,
                             mode="nearest")
    for f in three["flights"]:
        k = dji_read.read_kmz(three["tmp"] / f"m_{f}.kmz")
        lat0, lon0, ell0 = k.takeoff_ref
        home_amsl = ell0 - _egm96_minus_ellipsoid(np.array([lon0]), np.array([lat0]))[0]
        pts = []
        for p in k.waylines[0].points:
            x, y = TO_TM.transform(p.lon_deg, p.lat_deg)
            pts.append((x, y, home_amsl + p.height_m))
        pts = np.array(pts)
        level = [(a, b) for a, b in itertools.pairwise(pts[1:])
                 if np.hypot(*(b[:2] - a[:2])) >= 0.5]
        lowest = min(clearance_along(raw, a, b, spec.footprint_m, highest) for a, b in level)
        assert lowest >= spec.scan_clearance_m - 0.05, (f, lowest)


def test_every_format_reads_back_as_the_plan_flies(three) -> None:
    """The KMZ (the project's reader), the Litchi CSV (litchi-wp's reader and the
    project's) against the .plan of the same flight: path and heights within 0.1 m,
    speeds, photo spacing, gimbal pitch, the orbit's headings."""
    from litchi_wp.waypoint import Waypoint

    craft = dji.AIRCRAFT["m3e"]
    for f in three["flights"]:
        tmp = three["tmp"]
        plan = _plan_route(tmp / f"m_{f}.plan")
        assert any(p.heading_deg is not None for p in plan.points)  # the orbits
        assert any(p.photo_every_m > 0 for p in plan.points)
        want = dji.prepare(plan, craft)
        got = dji_read.read_kmz(tmp / f"m_{f}.kmz").route()
        got = Route(plan.home_lat_deg, plan.home_lon_deg, got.points, got.end)
        assert got.differs_from(want) is None, got.differs_from(want)
        # the path itself is the .plan's: prepare() only merged waypoints closer than 0.5 m
        kept = want.enu()
        assert all(np.min(np.linalg.norm(kept - e, axis=1)) < 0.5 for e in plan.enu())
        parts = litchi.prepare(plan)
        assert len(parts) == 1 and len(parts[0].points) <= litchi.MAX_WAYPOINTS
        theirs = Waypoint.from_file(str(tmp / f"m_{f}.csv"))
        ours = litchi.read_litchi(tmp / f"m_{f}.csv")
        assert len(theirs) == len(ours) == len(parts[0].points)
        for p, t, o in zip(parts[0].points, theirs, ours, strict=True):
            assert o.close_to(RoutePoint(**{**p.__dict__, "heading_deg": (
                o.heading_deg if p.heading_deg is None else p.heading_deg)}),
                plan.origin()) is None
            assert (t.lat, t.lon) == pytest.approx((p.lat_deg, p.lon_deg), abs=1e-8)
            assert t.altitude.value == pytest.approx(p.height_m, abs=0.01)
            assert t.altitude.mode.value == 0  # above the take-off point
            assert t.gimbal.mode.value == litchi.GIMBAL_INTERPOLATE
            assert t.gimbal.pitchangle == pytest.approx(p.gimbal_pitch_deg, abs=0.01)
            assert t.speed == pytest.approx(p.speed_m_s, abs=0.01)
            assert t.photo.distance_interval == pytest.approx(
                p.photo_every_m if p.photo_every_m > 0 else -1, abs=0.01)
            if p.heading_deg is not None:
                assert math.isclose((t.heading - p.heading_deg + 180) % 360, 180, abs_tol=0.01)


def test_wgs84_heights_are_egm96_plus_the_geoid_by_proj(three, dem_path) -> None:
    """--dji-heights wgs84: each waypoint's ellipsoidal height, less PROJ's geoid there,
    is the relative file's height plus home's ground (within 0.1 m)."""
    tmp = three["tmp"]
    r = mound("mission", "build", str(three["plan"]), "--dji-kmz", str(tmp / "w.kmz"),
              "--dji-heights", "wgs84", "--dem", str(dem_path), "--dem-vertical", "egm96",
              "--flight", str(three["flights"][0]))
    assert r.returncode == 0, r.stderr
    w = dji_read.read_kmz(tmp / "w.kmz")
    rel = dji_read.read_kmz(tmp / f"m_{three['flights'][0]}.kmz")
    assert w.waylines[0].height_mode == "WGS84"
    lat0, lon0, ell0 = rel.takeoff_ref
    home_amsl = ell0 - _egm96_minus_ellipsoid(np.array([lon0]), np.array([lat0]))[0]
    pw, pr = w.waylines[0].points, rel.waylines[0].points
    n = _egm96_minus_ellipsoid(np.array([p.lon_deg for p in pw]),
                               np.array([p.lat_deg for p in pw]))
    assert 40 < float(np.mean(n)) < 55  # the geoid in Slovenia, not PROJ's silent zero
    amsl = np.array([p.height_m for p in pw]) - n
    np.testing.assert_allclose(amsl, home_amsl + np.array([p.height_m for p in pr]),
                               atol=0.1)


def test_djis_own_kmz_files_are_read(capsys) -> None:
    from mound.cli import main

    for name, enum, frames, waylines in (("waypoint_m3e.kmz", 77, {"relativeToStartPoint"}, 1),
                                         ("mapping3d_m30.kmz", 67, {"WGS84"}, 5)):
        path = REPO_ROOT.parent / "shared" / "data" / "dji" / name
        k = dji_read.read_kmz(path)
        assert k.drone_enum == enum and {w.height_mode for w in k.waylines} == frames
        assert len(k.waylines) == waylines and all(len(w.points) >= 2 for w in k.waylines)
        assert main(["mission", "show", str(path)]) == 0
        out = capsys.readouterr().out
        assert f"aircraft enum {enum}" in out and "waypoints" in out


def test_limits_and_aircraft_are_checked_before_anything_is_written(three, dem_path) -> None:
    """A usage error writes nothing (exit 2); a format whose limits refuse the flights is
    refused alone: the .plan is written and records why (exit 3, one line on stderr)."""
    tmp = three["tmp"] / "limits"
    tmp.mkdir()
    base = ["mission", "build", str(three["plan"]), "--dem", str(dem_path), "--dem-vertical",
            "egm96", "--dji-kmz", str(tmp / "x.kmz"), "--out", str(tmp / "x.plan")]
    for extra, must in ((["--aircraft", "mini4pro"], "--litchi"),
                        (["--aircraft", "phantom9"], "--aircraft")):
        r = mound(*base, *extra)
        assert r.returncode == 2 and must in r.stderr and r.stderr.count("\n") == 1, r.stderr
        assert not list(tmp.iterdir())
    r = mound(*base, "--cruise-speed", "18", "--litchi", str(tmp / "x.csv"))
    assert r.returncode == 3 and r.stderr.count("\n") == 1, r.stderr
    assert "flies waypoints at up to 15 m/s" in r.stderr
    written = sorted(p.name for p in tmp.iterdir())
    assert written == [f"x_{f}.plan" for f in sorted(three["flights"])], written
    doc = json.loads((tmp / f"x_{three['flights'][0]}.plan").read_text())
    formats = doc["mound"]["formats"]
    assert "15 m/s" in formats["dji_kmz"]["refused"] and formats["dji_kmz"]["files"] == []
    assert "15 m/s" in formats["litchi_csv"]["refused"] and formats["litchi_csv"]["files"] == []


def _route(n: int, spacing_m: float = 10.0, height: float = 40.0) -> Route:
    origin = Origin(46.45, 15.83)
    from mound.geometry.geodesy import enu_to_geodetic

    pts = []
    for k in range(n):
        lat, lon, _ = enu_to_geodetic(origin, np.array([[k * spacing_m, 0.0, 0.0]]))[0]
        pts.append(RoutePoint(float(lat), float(lon), height, 5.0, 3.0 if k % 2 else 0.0,
                              -90.0, None))
    return Route(origin.lat_deg, origin.lon_deg, tuple(pts), "home")


def test_litchi_splits_a_long_flight_into_parts_and_refuses_heights_beyond_its_range() -> None:
    parts = litchi.prepare(_route(250))
    assert [len(p.points) for p in parts] == [99, 99, 54]
    for a, b in itertools.pairwise(parts):
        assert a.points[-1] == b.points[0] and a.end == "continue"
    assert parts[-1].end == "home"
    assert litchi.prepare(_route(3, height=-5.0))[0].points[0].height_m == -5.0
    with pytest.raises(InputError, match="Litchi: waypoint 0 is -205.0 m above the take-off"):
        litchi.prepare(_route(3, height=-205.0))


def test_dji_splits_legs_longer_than_2000_m_and_merges_duplicates() -> None:
    r = _route(3, spacing_m=4500.0)
    p = dji.prepare(r, dji.AIRCRAFT["m3e"])
    assert len(p.points) == 7 and np.all(p.leg_lengths_m() <= dji.MAX_LEG_M)
    near = _route(2, spacing_m=100.0)
    dup = Route(near.home_lat_deg, near.home_lon_deg,
                (near.points[0], near.points[0], near.points[1]), "home")
    merged = dji.prepare(dup, dji.AIRCRAFT["m3e"])
    assert merged.points == (near.points[0], near.points[1])


@pytest.mark.parametrize("name, data, must", [
    ("not a zip", b"PK\x03\x04 but not really", "not a KMZ"),
    ("no waylines", None, "no wpmz/waylines.wpml"),
    ("billion laughs", "<?xml version='1.0'?><!DOCTYPE kml [<!ENTITY a 'aaaa'>"
     "<!ENTITY b '&a;&a;&a;&a;'>]><kml>&b;</kml>", "without a DTD"),
    ("external entity", "<?xml version='1.0'?><!DOCTYPE kml [<!ENTITY x SYSTEM "
     "'file:///etc/passwd'>]><kml>&x;</kml>", "without a DTD"),
    ("deep nesting", "<a>" * 100_000 + "</a>" * 100_000, "KML"),
    ("bomb", "zeros", "inflates"),
], ids=lambda v: v if isinstance(v, str) and len(v) < 20 else "")
def test_bad_kmz_files_are_refused_naming_the_file(tmp_path, capsys, name: str, data: Any,
                                                   must: str) -> None:
    from mound.cli import main

    path = tmp_path / "bad.kmz"
    if isinstance(data, bytes):
        path.write_bytes(data)
    else:
        with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
            if data == "zeros":
                z.writestr(dji.WAYLINES, b"\0" * (dji_read.MAX_MEMBER_BYTES + 10))
            elif data is not None:
                z.writestr(dji.WAYLINES, data)
            else:
                z.writestr(dji.TEMPLATE, "<kml/>")
    assert main(["mission", "show", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(path) in err and must in err, err


@pytest.mark.parametrize("name, edit, must", [
    ("another header", lambda t: t.replace("latitude", "lat", 1), ":1: not Litchi's"),
    ("45 columns", lambda t: t.replace(",-1\n", "\n", 1), "45 columns"),
    ("nan latitude", lambda t: t.replace("\n46.", "\nnan,", 1).replace("nan,", "nan", 1),
     "latitude"),
    ("a stray carriage return (Hypothesis)", lambda t: "\r" + t[8:], ":1: not Litchi"),
    ("gimbal mode 7", lambda t: t.replace(",0,0,2,", ",0,0,7,", 1), "gimbalmode"),
], ids=lambda v: v if isinstance(v, str) and len(v) < 40 else "")
def test_bad_litchi_files_are_refused_naming_the_line(tmp_path, capsys, name: str, edit: Any,
                                                      must: str) -> None:
    from mound.cli import main

    text = litchi.csv_text(litchi.prepare(_route(5))[0])
    path = tmp_path / "bad.csv"
    path.write_text(edit(text), newline="")
    assert main(["mission", "show", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(path) in err and must in err, err


# ---------------------------------------------------------------- issue 67: DJI's rules

MULTI_LENS = [k for k, a in dji.AIRCRAFT.items() if a.multi_lens]


@pytest.fixture(scope="module")
def built(three, dem_path) -> list[Any]:
    """The three flights built in-process over the DEM, as `mission build` builds them."""
    from mound.formats.plan import Plan
    from mound.uav import mission

    plan = Plan.read(three["plan"])
    spec = mission_items.MissionSpec(scan=plan.scan())
    tin = mission_items.TerrainInput(str(dem_path), "egm96", None)
    return [mission.build(f, plan.origin, spec, tin)
            for _, f in mission_items.flight_plans(plan)]


def _members(data: bytes) -> dict[str, str]:
    import io

    with zipfile.ZipFile(io.BytesIO(data)) as z:
        return {n: z.read(n).decode() for n in z.namelist()}


@pytest.mark.parametrize("frame", ["relative", "wgs84"])
def test_every_kmz_keeps_djis_rules(built, tmp_path, frame: str) -> None:
    """Each aircraft, relative and wgs84 heights: the template's heightMode is one DJI
    allows in a template (never WGS84), the waylines' one it allows there; a multi-lens
    payload names the wide lens in every takePhoto and in the template's imageFormat;
    every aircraft has payloadParam; gimbal yaw about north; only elements DJI's own
    exports use. wgs84: the template's heights read back as EGM96 (the waylines'
    ellipsoidal heights less PROJ's geoid)."""
    known = _dji_element_set()
    m = built[0]
    for key, craft in dji.AIRCRAFT.items():
        data = dji_kmz.kmz(m, craft, frame)
        files = _members(data)
        tpl, wl = files[dji.TEMPLATE], files[dji.WAYLINES]
        modes = re.findall(r"<wpml:heightMode>(\w+)<", tpl)
        assert modes and set(modes) <= set(dji.TEMPLATE_HEIGHT_MODES), (key, modes)
        assert "WGS84" not in modes
        exec_modes = set(re.findall(r"<wpml:executeHeightMode>(\w+)<", wl))
        assert exec_modes <= set(dji.WAYLINE_HEIGHT_MODES)
        assert (modes, exec_modes) == ((["relativeToStartPoint"], {"relativeToStartPoint"})
                                       if frame == "relative" else (["EGM96"], {"WGS84"}))
        assert "<wpml:payloadParam>" in tpl and "<wpml:payloadParam>" not in wl
        assert set(re.findall(r"<wpml:gimbalHeadingYawBase>(\w+)<", tpl + wl)) == {"north"}
        for text in (tpl, wl):
            assert set(re.findall(r"<wpml:(\w+)", text)) <= known, key
            photos = text.count("<wpml:actionActuatorFunc>takePhoto<")
            lenses = re.findall(r"<wpml:payloadLensIndex>([\w,]+)<", text)
            assert photos > 0
            assert lenses == (["wide"] * photos if craft.multi_lens else []), key
        path = tmp_path / f"{key}_{frame}.kmz"
        path.write_bytes(data)
        k = dji_read.read_kmz(path)
        assert k.image_format == ("wide" if craft.multi_lens else None)
        assert k.lenses == (("wide",) * len(k.lenses) if craft.multi_lens else ())
        wl_h = np.array([p.height_m for p in k.waylines[0].points])
        tpl_h = np.array(k.template_heights)
        assert len(tpl_h) == len(wl_h)
        if frame == "relative":
            np.testing.assert_allclose(tpl_h, wl_h, atol=1e-3)
        else:
            pts = k.waylines[0].points
            n = _egm96_minus_ellipsoid(np.array([p.lon_deg for p in pts]),
                                       np.array([p.lat_deg for p in pts]))
            assert 40 < float(np.mean(n)) < 55
            np.testing.assert_allclose(tpl_h, wl_h - n, atol=0.01)  # EGM96 read back
    assert set(MULTI_LENS) == {"m3e", "m3t", "m30", "m4e"}


def test_a_wgs84_template_is_refused_as_dji_refuses_it(tmp_path) -> None:
    """What `--dji-heights wgs84` used to write (template heightMode WGS84) is read as
    DJI Pilot 2 reads it: refused, naming the element and the modes DJI allows."""
    src = REPO_ROOT.parent / "shared" / "data" / "dji" / "waypoint_m3e.kmz"
    with zipfile.ZipFile(src) as z:
        files = {n: z.read(n) for n in z.namelist()}
    files["wpmz/template.kml"] = files["wpmz/template.kml"].replace(
        b"<wpml:heightMode>relativeToStartPoint<", b"<wpml:heightMode>WGS84<")
    bad = tmp_path / "wgs84_template.kmz"
    with zipfile.ZipFile(bad, "w") as z:
        for n, data in files.items():
            z.writestr(n, data)
    with pytest.raises(InputError, match="heightMode: 'WGS84' is not a template height mode"):
        dji_read.read_kmz(bad)
    for name, mode in (("waypoint_m3e.kmz", "relativeToStartPoint"),
                       ("mapping3d_m30.kmz", "EGM96")):
        assert dji_read.read_kmz(src.with_name(name)).template_height_mode == mode


def test_photos_start_at_the_scan_and_climbs_keep_the_aircrafts_limits(built) -> None:
    """No photographed leg is a descent from the transit height (photos start at the
    scan's first waypoint); no DJI or Litchi leg climbs or descends faster than the
    aircraft's vertical limits; the KMZ's duration counts a stop at every waypoint."""
    craft = dji.AIRCRAFT["m30"]
    for m in built:
        route = mission_route(m)
        e = route.enu()
        photographed = [k for k, p in enumerate(route.points[:-1]) if p.photo_every_m > 0]
        assert photographed
        for k in photographed:
            assert abs(e[k + 1, 2] - e[k, 2]) < 0.5, (k, e[k], e[k + 1])
        # the transit legs over the DEM do climb and descend
        assert np.max(np.abs(np.diff(e[:, 2]))) > 10
        for r, up_, down in ((dji.prepare(route, craft), craft.max_ascent_m_s,
                              craft.max_descent_m_s),
                             (litchi.prepare(route)[0], litchi.MAX_ASCENT_M_S,
                              litchi.MAX_DESCENT_M_S)):
            e2 = r.enu()
            d = np.diff(e2, axis=0)
            v = np.array([p.speed_m_s for p in r.points[:-1]])
            vz = v * d[:, 2] / np.linalg.norm(d, axis=1)
            assert np.all(vz <= up_ + 1e-9) and np.all(-vz <= down + 1e-9)
            assert np.max(vz) == pytest.approx(up_)  # the climbs are flown at the limit
        wl = _members(dji_kmz.kmz(m, craft))[dji.WAYLINES]
        duration = float(re.search(r"<wpml:duration>([\d.]+)<", wl).group(1))
        r = dji.prepare(route, craft)
        legs = r.leg_lengths_m()
        v = np.array([p.speed_m_s for p in r.points[:-1]])
        assert duration > float(np.sum(legs / v)) + 0.9 * float(np.sum(
            np.minimum(v / dji.WAYPOINT_ACCEL_M_S2, np.sqrt(legs / dji.WAYPOINT_ACCEL_M_S2))))


def test_flight_seconds_counts_the_stops() -> None:
    # 100 m at 10 m/s with 2 m/s^2: 5 s up, 5 s down over 50 m, 50 m at 10 m/s: 15 s
    assert dji.flight_seconds(np.array([100.0]), np.array([10.0])) == pytest.approx(15.0)
    # 4 m at 10 m/s never reaches it: 2 m up in sqrt(2) s and 2 m down
    assert dji.flight_seconds(np.array([4.0]), np.array([10.0])) == pytest.approx(
        2 * math.sqrt(2.0))


@pytest.mark.parametrize("name, template, must", [
    ("unknown encoding", b"<?xml version='1.0' encoding='x-unknown'?><kml/>", "encoding"),
    ("base64 encoding", b"<?xml version='1.0' encoding='base64'?><kml/>", "encoding"),
    ("corrupt deflate", None, "cannot inflate"),
])
def test_kmz_reader_regressions(tmp_path, capsys, name: str, template: bytes | None,
                                must: str) -> None:
    """Two crashes of `mound mission show` (issue 67): an XML encoding Python does not
    know (LookupError) and a corrupt deflate stream (zlib.error) ended in 'internal error'
    (exit 1); now exit 2 naming the file."""
    from mound.cli import main

    src = REPO_ROOT.parent / "shared" / "data" / "dji" / "waypoint_m3e.kmz"
    path = tmp_path / "bad.kmz"
    with zipfile.ZipFile(src) as z:
        files = {n: z.read(n) for n in z.namelist()}
    if template is not None:
        files[dji.WAYLINES] = template
        with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
            for n, data in files.items():
                z.writestr(n, data)
    else:
        with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
            for n, data in files.items():
                z.writestr(n, data)
        raw = bytearray(path.read_bytes())
        with zipfile.ZipFile(path) as z:
            info = z.getinfo(dji.WAYLINES)
        start = info.header_offset + 30 + len(info.filename.encode()) + len(info.extra)
        for k in range(start + 20, start + 60):
            raw[k] ^= 0xA5  # garble the deflate stream, keep the zip's directory
        path.write_bytes(bytes(raw))
    assert main(["mission", "show", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(path) in err and must in err, err


def test_a_valley_below_a_knoll_is_written_in_every_format(raw, dem_path, tmp_path) -> None:
    """Home on the DEM's knoll (313 m), three sites on the valley floor 50 m below, scanned
    30 m above their ground (`--altitude 30`): the scans are below the take-off point.
    Every format is written (issue 67: Litchi's 0 m floor refused the whole build and no
    file was written); the Litchi CSV and the KMZ carry the negative heights."""
    from test_terrain_flight import TO_LL, raw_height

    z, tf = raw
    grid = z[150:-150:10, 150:-150:10]
    r, c = np.unravel_index(int(np.argmax(grid)), grid.shape)
    home_xy = tf @ (c * 10 + 150 + 0.5, r * 10 + 150 + 0.5)
    lon, lat = TO_LL.transform(*home_xy)
    origin = Origin(lat, lon, float(raw_height(raw, home_xy[0], home_xy[1])))
    rows, cols = np.nonzero(grid < origin.alt_m - 50)
    xs, ys = tf @ (cols * 10 + 150 + 0.5, rows * 10 + 150 + 0.5)
    pts = np.column_stack([xs, ys])
    chosen = [int(np.argmin(np.hypot(*(pts - home_xy).T)))]   # the nearest valley point
    while len(chosen) < 3:
        gap = np.min([np.hypot(*(pts - pts[k]).T) for k in chosen], axis=0)
        gap[np.hypot(*(pts - home_xy).T) > 500] = 0
        chosen.append(int(np.argmax(np.minimum(gap, 150))))
    scan = scan_for_site(60.0, "raster", 30.0)
    sites = []
    for k, j in enumerate(chosen):
        slon, slat = TO_LL.transform(*pts[j])
        e, n, _ = geodetic_to_enu(origin, np.array([[slat, slon, 0.0]]))[0]
        sites.append({"id": f"v{k}", "x_m": float(e), "y_m": float(n), "reward": 1.0,
                      "scan_cost_m": scan.site_cost_m()})
    doc = {"schema": "mound.sites", "version": 1, "origin": origin.to_doc(),
           "home": {"id": "home", "x_m": 0.0, "y_m": 0.0}, "end": {"id": "home"},
           "budget_m": 20_000.0, "scan": scan.to_doc(),
           "takeoff_landing_m": scan.takeoff_landing_m(), "sites": sites}
    spec = terrain.ClearanceSpec()
    sites_file = tmp_path / "sites.json"
    sites_file.write_text(json.dumps(terrain.attach(Sites.from_doc(doc, "test"),
                                                    str(dem_path), spec, "egm96",
                                                    origin).to_doc()))
    plan_file = tmp_path / "plan.json"
    native.run_tool("mound_plan", [str(sites_file), "--out", str(plan_file)])
    r = mound("mission", "build", str(plan_file), "--altitude", "30", "--dem", str(dem_path),
              "--dem-vertical", "egm96", "--out", str(tmp_path / "v.plan"), "--dji-kmz",
              str(tmp_path / "v.kmz"), "--litchi", str(tmp_path / "v.csv"))
    assert r.returncode == 0, r.stderr
    assert "Heading Mode 'Custom'" in r.stdout  # the crew's Litchi setting, said
    plan_route = _plan_route(tmp_path / "v.plan")
    assert len([s for s in json.loads(plan_file.read_text())["flights"][0]["tour"]]) == 5
    lowest = min(p.height_m for p in plan_route.points)
    assert -40 < lowest < -10, lowest
    ours = litchi.read_litchi(tmp_path / "v.csv")
    assert min(p.height_m for p in ours) == pytest.approx(lowest, abs=0.01)
    k = dji_read.read_kmz(tmp_path / "v.kmz")
    assert min(p.height_m for p in k.waylines[0].points) == pytest.approx(lowest, abs=0.01)
    formats = json.loads((tmp_path / "v.plan").read_text())["mound"]["formats"]
    assert formats["dji_kmz"]["files"] == ["v.kmz"] and formats["litchi_csv"]["files"] == ["v.csv"]
