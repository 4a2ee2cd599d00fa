"""UAV mission: geodesy, the mission builder, ground-station files, and the MAVLink mission
protocol against a real, independently written vehicle (MAVSDK as an autopilot with its
MissionRawServer), directly, over TCP, and through a lossy loopback relay."""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from mound.cli import main as mound_main
from mound.errors import InputError
from mound.formats.plan import Plan
from mound.geometry.flight import scan_for_site
from mound.geometry.geodesy import Origin, enu_to_geodetic, geodetic_to_enu
from mound.sim import site as sim
from mound.uav import files as mission_files
from mound.uav import mission, mission_items
from mound.uav.mavlink import link as mavlink_link
from mound.uav.mavlink import transfer
from mound.uav.mavlink.peer import MavsdkVehicle, free_port
from mound.uav.mavlink.relay import LossyRelay


def build_mission(plan: dict, *args: Any) -> Any:
    """mission.build of a plan document (the tests keep their plans as dicts)."""
    return mission.build(Plan.from_doc(plan, "test plan"), *args)


ORIGIN = Origin(38.5705, 27.9862, 95.0)


def grid_plan(n_sites: int, spacing: float = 300.0, closed: bool = True) -> dict:
    side = math.ceil(math.sqrt(n_sites))
    wps = [{"id": "home", "x_m": 0.0, "y_m": 0.0, "kind": "home"}]
    for k in range(n_sites):
        wps.append({"id": f"s{k}", "x_m": spacing * (1 + k % side),
                    "y_m": spacing * (1 + k // side), "kind": "site", "scan_cost_m": 400.0})
    tour = [w["id"] for w in wps]
    if closed:
        tour.append("home")
    else:
        wps.append({"id": "end", "x_m": -200.0, "y_m": 50.0, "kind": "end"})
        tour.append("end")
    return {"schema": "mound.plan", "version": 1, "tour": tour, "waypoints": wps,
            "closed": closed, "budget_m": 1e7, "origin": ORIGIN.to_doc()}


def items_of(n: int) -> list[mission_items.MissionItem]:
    m = build_mission(grid_plan(max(2, n // 9 + 1)), ORIGIN, mission_items.MissionSpec())
    assert len(m.items) >= n
    return m.items[:n]


# --- geodesy -------------------------------------------------------------------------

def test_enu_geodetic_agrees_with_proj_to_a_millimetre_at_30_km() -> None:
    from pyproj import Transformer

    rng = np.random.default_rng(0)
    enu = np.column_stack([rng.uniform(-30e3, 30e3, (500, 2)), rng.uniform(-50, 800, 500)])
    llh = enu_to_geodetic(ORIGIN, enu)
    np.testing.assert_allclose(geodetic_to_enu(ORIGIN, llh), enu, atol=1e-6)
    # Independent reference: PROJ's geodetic -> geocentric (EPSG:4979 -> EPSG:4978), then
    # the ENU rotation written out here from its definition.
    to_ecef = Transformer.from_crs("EPSG:4979", "EPSG:4978", always_xy=True)
    x, y, z = to_ecef.transform(llh[:, 1], llh[:, 0], llh[:, 2])
    x0, y0, z0 = to_ecef.transform(ORIGIN.lon_deg, ORIGIN.lat_deg, ORIGIN.alt_m)
    lat, lon = np.radians(ORIGIN.lat_deg), np.radians(ORIGIN.lon_deg)
    d = np.column_stack([x - x0, y - y0, z - z0])
    east = -np.sin(lon) * d[:, 0] + np.cos(lon) * d[:, 1]
    north = (-np.sin(lat) * np.cos(lon) * d[:, 0] - np.sin(lat) * np.sin(lon) * d[:, 1]
             + np.cos(lat) * d[:, 2])
    up = (np.cos(lat) * np.cos(lon) * d[:, 0] + np.cos(lat) * np.sin(lon) * d[:, 1]
          + np.sin(lat) * d[:, 2])
    np.testing.assert_allclose(np.column_stack([east, north, up]), enu, atol=1e-3)
    # A flat-earth shortcut would be off by metres here: check that we are not one.
    flat_north = np.radians(llh[:, 0] - ORIGIN.lat_deg) * 6378137.0
    assert np.abs(flat_north - enu[:, 1]).max() > 10


@pytest.mark.parametrize("text", ["38.5", "a,b", "91,0", "10,200", "1,2,3,4"])
def test_bad_origin_is_rejected(text: str) -> None:
    with pytest.raises(InputError, match="origin|latitude|longitude"):
        Origin.parse(text)


# --- mission builder -----------------------------------------------------------------

def test_mission_flies_the_simulators_camera_positions() -> None:
    plan = grid_plan(2)
    spec = mission_items.MissionSpec(scan=scan_for_site(pattern="both"))
    m = build_mission(plan, ORIGIN, spec)
    cmds = [it.command for it in m.items]
    assert cmds[0] == mission_items.NAV_TAKEOFF and cmds[-1] == mission_items.NAV_RETURN_TO_LAUNCH
    assert cmds.count(mission_items.DO_SET_CAM_TRIGG_DIST) == 2 * 2 * 2  # on + off per pattern
    roi_on, roi_off = mission_items.DO_SET_ROI_LOCATION, mission_items.DO_SET_ROI_NONE
    assert cmds.count(roi_on) == 2 == cmds.count(roi_off)
    trig = [it for it in m.items if it.command == mission_items.DO_SET_CAM_TRIGG_DIST]
    assert [it.params[0] > 0 for it in trig] == [True, False] * 4
    nav = [it for it in m.items if it.command == mission_items.NAV_WAYPOINT
           and it.frame == mission_items.FRAME_GLOBAL_RELATIVE_ALT_INT]
    enu = geodetic_to_enu(ORIGIN, np.array([[it.lat_deg, it.lon_deg, ORIGIN.alt_m + it.z]
                                            for it in nav]))
    # Every orbit camera position of the simulator (its default 60 m tumulus), moved to the
    # first site, is a waypoint (to the centimetre: 1e-7 degrees of latitude is 1.1 cm).
    shots = sim.shots(sim.SimSpec(pattern="both"))
    site = np.array([plan["waypoints"][1]["x_m"], plan["waypoints"][1]["y_m"], 0.0])
    for pattern, shot in shots:
        if pattern == "orbit":
            assert np.min(np.linalg.norm(enu - (site + shot.pose.centre), axis=1)) < 0.02
    # The raster's line ends are waypoints; the trigger distance is the simulator's spacing.
    raster = [s for p, s in shots if p == "raster"]
    assert np.min(np.linalg.norm(enu - (site + raster[0].pose.centre), axis=1)) < 0.02
    spacing = np.linalg.norm(raster[1].pose.centre - raster[0].pose.centre)
    assert trig[0].params[0] == pytest.approx(spacing, rel=1e-6)
    assert m.sites[0].images == len(shots)


def test_path_plan_lands_at_the_end_node_and_distance_is_checked() -> None:
    m = build_mission(grid_plan(3, closed=False), ORIGIN)
    assert m.items[-1].command == mission_items.NAV_LAND
    end = geodetic_to_enu(ORIGIN, np.array([[m.items[-1].lat_deg, m.items[-1].lon_deg,
                                             ORIGIN.alt_m]]))[0]
    np.testing.assert_allclose(end[:2], [-200.0, 50.0], atol=0.02)
    # The flight distance is the 3-D path length; a budget just below it is refused.
    plan = grid_plan(3)
    d = build_mission(plan, ORIGIN).flight_distance_m
    plan["budget_m"] = d - 1.0
    with pytest.raises(InputError, match="exceeds the plan's budget_m"):
        build_mission(plan, ORIGIN)
    plan["budget_m"] = d + 1.0
    assert build_mission(plan, ORIGIN).flight_distance_m == pytest.approx(d)


@pytest.mark.parametrize("edit, message", [
    (lambda p: p.update(tour=["home", "home"]), "visits no site"),
    (lambda p: p["tour"].insert(1, "ghost"), "'ghost' has no coordinates"),
    (lambda p: p["waypoints"][1].pop("x_m"), "x_m"),
    (lambda p: p.pop("waypoints"), "waypoints"),
    (lambda p: p.update(budget_m=float("nan")), "budget_m"),
])
def test_bad_plans_are_rejected(edit, message: str) -> None:
    plan = grid_plan(2)
    edit(plan)
    with pytest.raises(InputError, match=message):
        build_mission(plan, ORIGIN)


def test_plan_and_wpl_files_parse_back_to_the_same_items(tmp_path: Path) -> None:
    both = mission_items.MissionSpec(scan=scan_for_site(pattern="both"))
    m = build_mission(grid_plan(3), ORIGIN, both)
    mission_files.write_plan(tmp_path / "m.plan", m)
    mission_files.write_wpl(tmp_path / "m.waypoints", m)
    mission_files.write_geojson(tmp_path / "m.geojson", m)
    for name in ("m.plan", "m.waypoints"):
        items, home, firmware = mission_files.read_mission(tmp_path / name)
        assert firmware == ("px4" if name == "m.plan" else "ardupilot")
        assert transfer.first_difference(m.items, items) is None
        assert (home.lat_deg, home.lon_deg) == (ORIGIN.lat_deg, ORIGIN.lon_deg)
    doc = json.loads((tmp_path / "m.plan").read_text())
    assert doc["fileType"] == "Plan" and doc["mission"]["items"][0]["params"][3] is None
    assert doc["mission"]["items"][0]["frame"] == 3  # QGC's non-INT frame in files
    geo = json.loads((tmp_path / "m.geojson").read_text())
    kinds = [f["properties"]["kind"] for f in geo["features"]]
    assert kinds.count("site") == 3 and kinds.count("flight_path") == 1
    assert kinds.count("image_footprint") == 3 * len(both.scan.shots())
    lon, lat = geo["features"][0]["geometry"]["coordinates"][0][:2]
    assert lon == pytest.approx(27.9862) and lat == pytest.approx(38.5705)  # lon, lat order
    for f in geo["features"]:
        if f["geometry"]["type"] == "Polygon":
            ring = f["geometry"]["coordinates"][0]
            assert ring[0] == ring[-1] and len(ring) == 5


HOME_LINE = "0\t1\t0\t16\t0\t0\t0\t0\t38.5\t27.9\t95\t1\n"


@pytest.mark.parametrize("text, message", [
    ("QGC WPL 110\n" + HOME_LINE + "2\t0\t3\t16\t0\t0\t0\t0\t1\t2\t3\t1\n",
     "sequence number 2"),
    ("QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t38.5\t27.9\t95\n", "12 fields"),
    ("QGC WPL 110\n0\t1\t0\t16\tx\t0\t0\t0\t38.5\t27.9\t95\t1\n", "non-numeric"),
    ("WPL 100\n", "not a 'QGC WPL 110'"),
    ('{"fileType": "Plan", "mission": {"items": [], "plannedHomePosition": [1, 2]}}',
     "plannedHomePosition"),
    ('{"fileType": "Plan", "mission": {"items": [{"type": "ComplexItem"}], '
     '"plannedHomePosition": [1, 2, 3]}}', "SimpleItem"),
])
def test_bad_mission_files_are_rejected(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "bad.mission"
    path.write_text(text)
    with pytest.raises(InputError, match=message):
        mission_files.read_mission(path)


# --- MAVLink mission protocol against MAVSDK -----------------------------------------

@pytest.fixture(scope="module")
def vehicle() -> MavsdkVehicle:
    with MavsdkVehicle("udpin") as v:
        yield v


def upload_via(connect: str, items: list[mission_items.MissionItem], **kw: object
               ) -> transfer.TransferStats:
    """Connects, uploads (read-back verified unless verify=False) and closes."""
    lk = mavlink_link.connect(connect, timeout_s=5)
    try:
        return transfer.upload_verified(lk, items, **kw)  # type: ignore[arg-type]
    finally:
        lk.close()


def received_equal(vehicle_items: list, sent: list[mission_items.MissionItem]) -> bool:
    got = [mission_items.MissionItem(i.command, i.frame, (i.param1, i.param2, i.param3, i.param4),
                               i.x, i.y, i.z, i.autocontinue) for i in vehicle_items]
    return transfer.first_difference(sent, got) is None


@pytest.mark.slow
@pytest.mark.parametrize("n", [20, 200, 1000])
def test_upload_and_read_back_on_a_clean_link(vehicle: MavsdkVehicle, n: int) -> None:
    items = items_of(n)
    before = len(vehicle.missions)
    stats = upload_via(vehicle.connect_string, items)
    assert stats.verified and not stats.ack_lost
    assert received_equal(vehicle.wait_for_mission(before + 1), items)


@pytest.mark.slow
def test_upload_over_tcp() -> None:
    items = items_of(200)
    with MavsdkVehicle("tcpin") as v:
        assert upload_via(v.connect_string, items).verified
        assert received_equal(v.wait_for_mission(), items)


def test_upload_over_a_serial_line() -> None:
    """Two pseudo-terminals joined back to back stand for the radio's serial line: our
    client opens one as a serial device (pyserial), MAVSDK the other."""
    import os
    import select
    import threading
    import tty

    m1, s1 = os.openpty()
    m2, s2 = os.openpty()
    for fd in (s1, s2):
        tty.setraw(fd)
    stop = threading.Event()

    def bridge() -> None:
        while not stop.is_set():
            ready, _, _ = select.select([m1, m2], [], [], 0.05)
            for fd in ready:
                os.write(m2 if fd == m1 else m1, os.read(fd, 4096))

    thread = threading.Thread(target=bridge, daemon=True)
    thread.start()
    items = items_of(50)
    try:
        with MavsdkVehicle("serial", serial_device=os.ttyname(s2)) as v:
            assert upload_via(os.ttyname(s1), items).verified  # pymavlink's default 57600
            assert received_equal(v.wait_for_mission(), items)
    finally:
        stop.set()
        thread.join(timeout=2)
        for fd in (m1, s1, m2, s2):
            os.close(fd)


@pytest.mark.slow
# 1,000 items through a 5 %-lossy link take 90 s: tools/bench/bench_mission.py flies them.
@pytest.mark.parametrize("n, loss", [(20, 0.1), (200, 0.06)])
def test_upload_through_a_lossy_link(vehicle: MavsdkVehicle, n: int, loss: float) -> None:
    items = items_of(n)
    before = len(vehicle.missions)
    with LossyRelay(vehicle.port, loss, seed=n) as relay:
        stats = upload_via(f"udpout:127.0.0.1:{relay.port}", items)
        assert sum(relay.dropped) > 0
    assert stats.verified
    assert received_equal(vehicle.wait_for_mission(before + 1), items)


@pytest.mark.slow
def test_a_lost_final_ack_is_not_a_failure_when_the_read_back_matches(
        vehicle: MavsdkVehicle) -> None:
    items = items_of(20)
    with LossyRelay(vehicle.port, 0.0, drop_down_msgids=frozenset({47})) as relay:
        stats = upload_via(f"udpout:127.0.0.1:{relay.port}", items, verify=False,
                           timeout_s=0.3, retries=2)
    assert stats.ack_lost and stats.verified
    assert "read-back matches" in stats.notes[-1]


@pytest.mark.slow
def test_an_unreachable_vehicle_times_out_with_a_clear_message(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    port = free_port()
    start = time.monotonic()
    with pytest.raises(mavlink_link.LinkError, match=f"no heartbeat .* udpout:127.0.0.1:{port}"):
        mavlink_link.connect(f"udpout:127.0.0.1:{port}", timeout_s=1.0)
    assert time.monotonic() - start < 3
    m = build_mission(grid_plan(2), ORIGIN)
    mission_files.write_plan(tmp_path / "m.plan", m)
    code = mound_main(["mission", "upload", str(tmp_path / "m.plan"), "--connect",
                       f"udpout:127.0.0.1:{port}", "--heartbeat-timeout", "1"])
    assert code == 2 and "no heartbeat from a vehicle" in capsys.readouterr().err


@pytest.mark.slow
def test_cli_builds_and_uploads_a_plan(vehicle: MavsdkVehicle, tmp_path: Path,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "plan.json").write_text(json.dumps(grid_plan(3)))
    assert mound_main(["mission", "build", str(tmp_path / "plan.json"), "--out",
                       str(tmp_path / "m.plan"), "--wpl", str(tmp_path / "m.waypoints"),
                       "--geojson", str(tmp_path / "m.geojson"), "--pattern", "orbit",
                       "--firmware", "ardupilot"]) == 0
    before = len(vehicle.missions)
    key = "ab" * 32  # signed outgoing; MAVSDK does not sign, so accept its unsigned answers
    assert mound_main(["mission", "upload", str(tmp_path / "m.plan"), "--connect",
                       vehicle.connect_string, "--verify", "--signing-key", key,
                       "--accept-unsigned"]) == 0
    assert "read back and identical" in capsys.readouterr().out
    items, home = mission_files.read_plan(tmp_path / "m.plan")
    with_home = [mission_items.home_item(home), *items]
    assert received_equal(vehicle.wait_for_mission(before + 1), with_home)
    # The WPL file (ArduPilot's format: home on line 0) uploads the same mission.
    assert mound_main(["mission", "upload", str(tmp_path / "m.waypoints"), "--connect",
                       vehicle.connect_string]) == 0
    assert received_equal(vehicle.wait_for_mission(before + 2), with_home)


def test_cli_refuses_a_mission_over_budget(tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    plan = grid_plan(3)
    plan["budget_m"] = 500.0
    (tmp_path / "plan.json").write_text(json.dumps(plan))
    assert mound_main(["mission", "build", str(tmp_path / "plan.json"), "--out",
                       str(tmp_path / "m.plan")]) == 2
    assert "exceeds the plan's budget_m 500" in capsys.readouterr().err
    assert not (tmp_path / "m.plan").exists()


# --- signing ---------------------------------------------------------------------------

def _verifying_endpoint(port: int, key: bytes):
    """A pymavlink endpoint that signs and accepts only correctly signed packets."""
    conn = mavlink_link.open_conn(f"udpin:127.0.0.1:{port}", None, source_system=1)
    conn.setup_signing(key, sign_outgoing=True, allow_unsigned_callback=None)
    return conn


def _exchange(sender_key: bytes | None, receiver_key: bytes) -> tuple[bool, object]:
    port = free_port()
    rx = _verifying_endpoint(port, receiver_key)
    tx = mavlink_link.open_conn(f"udpout:127.0.0.1:{port}", sender_key)
    try:
        got = None
        for _ in range(10):
            tx.mav.heartbeat_send(6, 8, 0, 0, 0)
            got = rx.recv_match(type="HEARTBEAT", blocking=True, timeout=0.1) or got
        return got is not None, rx.mav.signing
    finally:
        tx.close()
        rx.close()


@pytest.mark.slow
def test_signing_accepts_the_right_key_and_rejects_wrong_or_unsigned_packets() -> None:
    key = mavlink_link.signing_key(passphrase="bin tepe")
    assert key is not None and len(key) == 32
    ok, signing = _exchange(key, key)
    assert ok and signing.goodsig_count > 0 and signing.badsig_count == 0
    wrong = mavlink_link.signing_key("11" * 32)
    ok, signing = _exchange(wrong, key)
    assert not ok and signing.badsig_count > 0 and signing.goodsig_count == 0
    ok, signing = _exchange(None, key)
    assert not ok and signing.sig_count == 0  # unsigned: nothing accepted


@pytest.mark.slow
def test_our_signed_link_rejects_unsigned_answers() -> None:
    """Without --accept-unsigned, a signed link ignores an unsigned vehicle: the MAVSDK
    peer does not sign, so no heartbeat gets through."""
    with MavsdkVehicle("udpin") as v:
        with pytest.raises(mavlink_link.LinkError, match="signing key"):
            mavlink_link.connect(v.connect_string, mavlink_link.signing_key("22" * 32),
                                 timeout_s=1.5)
        lk = mavlink_link.connect(v.connect_string, mavlink_link.signing_key("22" * 32),
                                  accept_unsigned=True, timeout_s=5)
        lk.close()


@pytest.mark.parametrize("hex_key", ["abc", "zz" * 32, "00" * 31])
def test_bad_signing_keys_are_rejected(hex_key: str) -> None:
    with pytest.raises(InputError, match="--signing-key"):
        mavlink_link.signing_key(hex_key)
