"""In flight on MAVLink (issue 69, item 3): `mound fly` against the MAVSDK stand-in vehicle —
the mission replaced in the air, read back, its current item kept, and a low battery
sending the aircraft home."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mound.classify import coarse, statlog
from mound.cli import main as mound_main
from mound.formats.sites import Sites
from mound.jsonio import load_json, write_json
from mound.plan.field import make_field, sites_document
from mound.recon import visit_value as vv
from mound.survey import fly
from mound.survey.context import scan_spec
from mound.survey.options import SurveyOptions
from mound.uav import mission_items as mi
from mound.uav.mavlink import link as mavlink_link
from mound.uav.mavlink import transfer
from mound.uav.mavlink.peer import MavsdkVehicle

ROOT = Path(__file__).resolve().parents[2]
REPORT = ROOT / "docs/results/verdict_three_answers_kazanlak.json"
RANGE_M = 5000.0


@pytest.fixture(scope="module")
def field_sites() -> Sites:
    test = statlog.load("sat.tst")
    f = make_field(test, 0)
    return sites_document(f, test, coarse.load_model(None), None, RANGE_M, spacing_m=250.0,
                          scan=scan_spec(SurveyOptions()))


def confusion() -> tuple[vv.Confusion, np.ndarray]:
    conf = vv.Confusion.from_report(load_json(REPORT), str(REPORT))
    return conf, conf.tumulus_mean({c: 1.0 for c in conf.tumulus})


def as_items(vehicle_items: list) -> list[mi.MissionItem]:
    return [mi.MissionItem(i.command, i.frame, (i.param1, i.param2, i.param3, i.param4),
                           i.x, i.y, i.z, i.autocontinue) for i in vehicle_items]


def fly_with(sites: Sites, tmp: Path, judge_hook=None) -> tuple[dict, MavsdkVehicle, object,
                                                                fly.InFlight]:
    conf, tum = confusion()
    state = fly.InFlight(sites, conf, tum, fly.FlyOptions(RANGE_M, timeout_s=60), tmp)
    judge = fly.SimulatedJudge(conf, tum, seed=1, delay_s=0.05)
    with MavsdkVehicle() as v:
        o = sites.origin
        assert o is not None
        # 750 m of flight to a second of wall time: the judgments and uploads keep pace with
        # the aircraft when the machine is loaded (at 1,500 m/s under two pytest workers
        # and a build the aircraft once flew past all but two sites before its new mission)
        aircraft = v.fly(o.lat_deg, o.lon_deg, RANGE_M, speed_m_s=750.0)
        lk = mavlink_link.connect(v.connect_string)
        try:
            log = fly.fly(lk, state, (lambda s: judge_hook(aircraft, s) or judge(s))
                          if judge_hook else judge, tmp / "fly.json")
        finally:
            lk.close()
        aircraft.stop()
    return log, v, aircraft, state


def test_the_mission_is_replaced_in_flight_read_back_and_its_current_item_kept(
        field_sites: Sites, tmp_path: Path) -> None:
    log, v, aircraft, state = fly_with(field_sites, tmp_path)
    assert log["status"] == "ok" and aircraft.landed
    assert np.allclose(aircraft.pos, 0.0, atol=1e-6)  # home, on the ground
    replaced = log["uploads"][1:]
    assert len(replaced) >= 2 and all(u.get("verified") for u in replaced)
    assert len(v.missions) == len(log["uploads"])
    # what the vehicle holds at the end is what the ground station last sent
    assert transfer.first_difference(state.items, as_items(v.missions[-1])) is None
    for n, u in enumerate(replaced, start=2):
        old, new = as_items(v.missions[n - 2]), as_items(v.missions[n - 1])
        cur = u["current"]
        # the items up to the current one are those the aircraft was flying ...
        assert transfer.first_difference(old[:cur + 1], new[:cur + 1]) is None
        # ... and it went on from the current item: none before it flown again
        done = [seq for m, seq in aircraft.done if m == n]
        assert done and min(done) >= cur
    # every site scanned was judged once per visit, and its p moved by its answer
    judged = [a["site"] for a in log["answers"]]
    assert sum(log["sites"][s]["visits"] for s in log["sites"]) == len(judged) >= 3
    for a in log["answers"]:
        if a["answer"] == "mound":
            assert a["p_after"] > a["p_before"]
        if a["answer"] == "no_mound":
            assert a["p_after"] < a["p_before"]
    assert json.loads((tmp_path / "fly.json").read_text())["status"] == "ok"


def test_a_low_battery_sends_the_aircraft_home_at_once(field_sites: Sites, tmp_path: Path
                                                       ) -> None:
    def fault(aircraft, _site) -> None:  # a cell fails as the first site is judged: 35 % left
        if not aircraft.drained:
            aircraft.drain(aircraft.charge() - 0.35)

    log, v, aircraft, state = fly_with(field_sites, tmp_path, fault)
    home = [u for u in log["uploads"] if u["why"].startswith("low battery")]
    assert len(home) == 1, log["uploads"]
    cur = home[0]["current"]
    last = as_items(v.missions[-1])
    assert len(last) == cur + 1 and last[cur].command == mi.NAV_RETURN_TO_LAUNCH
    assert aircraft.landed and np.allclose(aircraft.pos, 0.0, atol=1e-6), (
        log, aircraft.pos, aircraft.charge(), aircraft.done[-5:])
    # nothing after the return was flown: only the first site was scanned
    assert [a["site"] for a in log["answers"]] == [log["uploads"][0]["sites"][0]]


def test_mound_fly_command_line(field_sites: Sites, tmp_path: Path,
                                capsys: pytest.CaptureFixture[str]) -> None:
    write_json(tmp_path / "sites.json", field_sites.to_doc())
    args = ["fly", "--sites", str(tmp_path / "sites.json"), "--confusion", str(REPORT),
            "--range-m", str(RANGE_M), "--out", str(tmp_path / "out"), "--timeout", "60"]
    with MavsdkVehicle() as v:
        o = field_sites.origin
        assert o is not None
        v.fly(o.lat_deg, o.lon_deg, RANGE_M, speed_m_s=1500.0)
        assert mound_main([*args, "--connect", v.connect_string]) == 0
    out = capsys.readouterr().out
    assert "replaced in flight" in out
    doc = json.loads((tmp_path / "out" / "fly.json").read_text())
    assert doc["schema"] == "mound.fly" and doc["status"] == "ok"
    # a sites file without truth cannot be judged by the simulated judge: refused by name
    bare = field_sites.with_sites([s.__class__(s.id, s.x_m, s.y_m, s.reward, s.scan_cost_m,
                                               s.p_mound) for s in field_sites.sites])
    write_json(tmp_path / "bare.json", bare.to_doc())
    with MavsdkVehicle() as v:
        code = mound_main(["fly", "--sites", str(tmp_path / "bare.json"), "--confusion",
                           str(REPORT), "--range-m", str(RANGE_M), "--out",
                           str(tmp_path / "o2"), "--connect", v.connect_string])
    assert code == 2
    assert "truth" in capsys.readouterr().err


def test_a_vehicle_position_out_of_range_is_ignored(field_sites: Sites, tmp_path: Path
                                                    ) -> None:
    from types import SimpleNamespace

    conf, tum = confusion()
    state = fly.InFlight(field_sites, conf, tum, fly.FlyOptions(RANGE_M), tmp_path)
    o = field_sites.origin
    assert o is not None
    for lat, lon in ((2**31 - 1, 0), (0, -(2**31)), (900_000_001, 0)):
        state.position(SimpleNamespace(lat=lat, lon=lon, relative_alt=0))
        assert state.aircraft is None
    state.position(SimpleNamespace(lat=round(o.lat_deg * 1e7), lon=round(o.lon_deg * 1e7),
                                   relative_alt=30_000))
    assert state.aircraft is not None and np.allclose(state.aircraft, [0, 0, 30], atol=0.05)
