"""Regression tests for the fuzzer's findings on the Python readers (issue 14): every
malformed input is answered with exit 2 and one line on stderr naming the file and field
(never a traceback, never exit 1, never the file's contents echoed), and a command that
fails leaves no output behind."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest

from mound.classify import statlog
from mound.cli import main as mound_main
from mound.errors import InputError
from mound.geometry.geodesy import Origin
from mound.jsonio import parse_json, read_text
from mound.uav import files as mission_files

ORIGIN = Origin(38.5705, 27.9862, 95.0)
HOME = "0\t1\t0\t16\t0\t0\t0\t0\t38.5705\t27.9862\t95\t1\n"


def small_plan() -> dict[str, Any]:
    wps = [{"id": "home", "x_m": 0.0, "y_m": 0.0, "kind": "home"},
           {"id": "a", "x_m": 300.0, "y_m": 0.0, "kind": "site", "scan_cost_m": 400.0},
           {"id": "b", "x_m": 300.0, "y_m": 300.0, "kind": "site", "scan_cost_m": 400.0}]
    return {"schema": "mound.plan", "version": 1, "tour": ["home", "a", "b", "home"],
            "waypoints": wps, "closed": True, "budget_m": 1e7, "origin": ORIGIN.to_doc()}


def expect_one_line_exit_2(code: int, err: str, must_name: str) -> None:
    assert code == 2, err
    assert err.count("\n") == 1, err
    assert must_name in err, err
    assert "Traceback" not in err and "internal error" not in err, err


def build(tmp_path: Path, text: str | bytes,
          capsys: pytest.CaptureFixture[str]) -> tuple[int, str, Path]:
    plan = tmp_path / "plan.json"
    if isinstance(text, bytes):
        plan.write_bytes(text)
    else:
        plan.write_text(text)
    out = tmp_path / "m.plan"
    code = mound_main(["mission", "build", str(plan), "--out", str(out), "--wpl",
                       str(tmp_path / "m.waypoints")])
    assert not out.exists() and not (tmp_path / "m.waypoints").exists()
    return code, capsys.readouterr().err, plan


def edited(edit: Any) -> str:
    doc = small_plan()
    edit(doc)
    return json.dumps(doc)


@pytest.mark.parametrize("name, text, must_name", [
    ("non-UTF-8 byte", json.dumps(small_plan()).encode().replace(b'"a"', b'"\xff"', 1),
     "not UTF-8 text (byte 0xff"),
    ("nested 10,000 deep", "[" * 10000 + "]" * 10000, "nested too deeply"),
    ("list as a waypoint id", edited(lambda d: d["waypoints"][1].update(id=["a"])),
     "waypoints[1].id"),
    ("list in the tour", edited(lambda d: d["tour"].insert(1, {"x": 1})), "tour[1]"),
    ("scan_cost_m abc", edited(lambda d: d["waypoints"][1].update(scan_cost_m="abc")),
     "waypoints[1].scan_cost_m"),
    ("10^400 in origin.lat", json.dumps(small_plan()).replace("38.5705", "1" + "0" * 400),
     "integer of 401 digits"),
    ("5,000-digit integer", json.dumps(small_plan()).replace("1e7", "9" * 5000)
     .replace("10000000.0", "9" * 5000), "integer of 5000 digits"),
    ("1e400", json.dumps(small_plan()).replace("300.0", "1e400", 1), "beyond double precision"),
    ("Infinity", json.dumps(small_plan()).replace("300.0", "Infinity", 1), "Infinity"),
    ("huge coordinate", edited(lambda d: d["waypoints"][2].update(y_m=1e20)),
     "waypoints[2].y_m"),
    ("latitude 1e20", edited(lambda d: d["origin"].update(lat=1e20)), "origin.lat"),
    ("bool as budget", edited(lambda d: d.update(budget_m=True)), "plan.budget_m"),
    ("closed as a string", edited(lambda d: d.update(closed="yes")), "plan.closed"),
    ("flights not a list", edited(lambda d: d.update(flights={"tour": d["tour"]})), "flights"),
    ("a flight without a tour", edited(lambda d: d.update(flights=[
        {"tour": d["tour"], "reward": 1, "cost_m": 1, "budget_left_m": 1}, {"x": 1}])),
     "flights[1]"),
    ("a flight's reward abc", edited(lambda d: d.update(flights=[
        {"tour": d["tour"], "reward": 1, "cost_m": 1, "budget_left_m": 1},
        {"tour": d["tour"], "reward": "abc", "cost_m": 1, "budget_left_m": 1}])),
     "flights[1].reward"),
])
def test_mission_build_refuses_hostile_plans(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                             name: str, text: str | bytes,
                                             must_name: str) -> None:
    code, err, plan = build(tmp_path, text, capsys)
    expect_one_line_exit_2(code, err, must_name)
    assert len(err) < 400, err  # the file is never echoed


def test_mission_build_writes_all_its_files_or_none(tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    """--geojson naming a folder failed after the .plan and .waypoints were written."""
    plan = tmp_path / "plan.json"
    plan.write_text(json.dumps(small_plan()))
    (tmp_path / "a_folder").mkdir()
    args = ["mission", "build", str(plan), "--out", str(tmp_path / "m.plan"), "--wpl",
            str(tmp_path / "m.waypoints"), "--geojson", str(tmp_path / "a_folder")]
    expect_one_line_exit_2(mound_main(args), capsys.readouterr().err, "a_folder")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_folder", "plan.json"]
    args[-1] = str(tmp_path / "m.geojson")
    assert mound_main(args) == 0
    assert {"m.plan", "m.waypoints", "m.geojson"} <= {p.name for p in tmp_path.iterdir()}
    assert not [p for p in tmp_path.iterdir() if ".tmp." in p.name]


def plan_file(items: list[dict[str, Any]], home: list[Any] | None = None) -> str:
    return json.dumps({"fileType": "Plan", "version": 1, "mission": {
        "version": 2, "plannedHomePosition": home or [38.5705, 27.9862, 95], "items": items}},
        allow_nan=True)


def item(params: list[Any], **kw: Any) -> dict[str, Any]:
    return {"type": "SimpleItem", "command": 16, "frame": 3, "params": params, **kw}


GOOD = [0, 0, 0, None, 38.571, 27.987, 40]


@pytest.mark.parametrize("name, text, must_name", [
    (".plan param 1e400", plan_file([item([1e400, *GOOD[1:]])]).replace("Infinity", "1e400"),
     "beyond double precision"),
    (".plan param Infinity", plan_file([item([math.inf, *GOOD[1:]])]), "Infinity"),
    (".plan param 1e300", plan_file([item([1e300, *GOOD[1:]])]), "params[0]"),
    (".plan latitude 1e20", plan_file([item([*GOOD[:4], 1e20, 27.9, 40])]), "params[4]"),
    (".plan home latitude 1e20", plan_file([item(GOOD)], [1e20, 27.9, 95]),
     "plannedHomePosition[0]"),
    (".plan command as a list", plan_file([item(GOOD, command=[16])]), "items[0].command"),
    (".plan frame 10^30", plan_file([item(GOOD, frame=10**30)]), "items[0].frame"),
    ("WPL latitude inf", "QGC WPL 110\n" + HOME + "1\t0\t3\t16\t0\t0\t0\t0\tinf\t27.9\t40\t1\n",
     ":3: field[4] (latitude)"),
    ("WPL latitude nan", "QGC WPL 110\n" + HOME + "1\t0\t3\t16\t0\t0\t0\t0\tnan\t27.9\t40\t1\n",
     ":3: field[4] (latitude)"),
    ("WPL latitude 1e20", "QGC WPL 110\n" + HOME + "1\t0\t3\t16\t0\t0\t0\t0\t1e20\t27.9\t40\t1\n",
     ":3: field[4] (latitude)"),
    ("WPL param 1e300", "QGC WPL 110\n" + HOME + "1\t0\t3\t16\t1e300\t0\t0\t0\t38.6\t27.9\t40\t1\n",
     ":3: field[0]"),
    ("WPL 5,000-digit seq",
     "QGC WPL 110\n" + HOME + "9" * 5000 + "\t0\t3\t16\t0\t0\t0\t0\t38\t27\t4\t1\n",
     ":3: seq, frame"),
    ("WPL home nan", "QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\tnan\t27.9\t95\t1\n", ":2:"),
    ("non-UTF-8 WPL", "QGC WPL 110\n\udcff\n", "not UTF-8"),
])
def test_mission_readers_refuse_hostile_files(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                              name: str, text: str, must_name: str) -> None:
    path = tmp_path / "bad.mission"
    path.write_bytes(text.encode("utf-8", "surrogateescape"))
    with pytest.raises(InputError, match=None) as e:
        mission_files.read_mission(path)
    assert must_name in str(e.value), str(e.value)
    # The upload command reads the file before it looks for a vehicle.
    code = mound_main(["mission", "upload", str(path), "--connect", "udpout:127.0.0.1:9",
                       "--heartbeat-timeout", "0.2"])
    expect_one_line_exit_2(code, capsys.readouterr().err, must_name)


def test_well_formed_mission_files_still_parse(tmp_path: Path) -> None:
    path = tmp_path / "ok.plan"
    path.write_text(plan_file([item(GOOD), item([5, 0, 0, None, 0, 0, 0], command=178)]))
    items, home, firmware = mission_files.read_mission(path)
    assert len(items) == 2 and home.lat_deg == 38.5705 and firmware == "px4"
    assert math.isnan(items[0].params[3])
    wpl = tmp_path / "ok.waypoints"
    wpl.write_text("QGC WPL 110\n" + HOME + "1\t0\t3\t16\t0\t0\t0\tnan\t38.6\t27.9\t40\t1\n")
    items, home, firmware = mission_files.read_mission(wpl)
    assert len(items) == 1 and firmware == "ardupilot"


@pytest.mark.parametrize("value, message", [
    ("--5", "non-numeric value '--5'"),
    ("12345678901234567890", "outside the 8-bit range"),
    ("-3", "non-numeric value '-3'"),
    ("256", "outside the 8-bit range"),
])
def test_statlog_loader_refuses_bad_values(value: str, message: str) -> None:
    row = ["100"] * 36 + ["1"]
    row[5] = value
    with pytest.raises(InputError, match=message):
        statlog.parse(" ".join(row) + "\n", "sat.trn")
    row = ["100"] * 36 + ["1" * 20]
    with pytest.raises(InputError, match="unknown class"):
        statlog.parse(" ".join(row) + "\n", "sat.trn")


def test_json_reader_bounds(tmp_path: Path) -> None:
    assert parse_json('{"a": [1, 2.5, -3e2]}', "x.json") == {"a": [1, 2.5, -300.0]}
    for text, message in [("NaN", "NaN is not valid JSON"), ("-Infinity", "Infinity"),
                          ("[1e999]", "beyond double precision"),
                          ("[" + "7" * 65 + "]", "65 digits"),
                          ("[" * 100000, "nested too deeply"), ("{", "not valid JSON")]:
        with pytest.raises(InputError, match=message):
            parse_json(text, "x.json")
    big = tmp_path / "big.json"
    big.write_bytes(b" " * 2048)
    with pytest.raises(InputError, match="larger than 1024 bytes"):
        read_text(big, max_bytes=1024)
    with pytest.raises(InputError, match="larger than 1024 bytes"):
        read_text("/dev/zero", max_bytes=1024)  # an endless file


def test_sim_site_leaves_no_folder_when_it_refuses(tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    """A raster altitude below the mound's top is refused after the terrain is built; the
    --out folder used to be created (and left empty) before that check."""
    out = tmp_path / "site"
    code = mound_main(["sim", "site", "--mound", "tumulus", "--height", "12", "--altitude",
                       "5", "--size", "64", "48", "--out", str(out)])
    expect_one_line_exit_2(code, capsys.readouterr().err, "ground")
    assert not out.exists()


def _render_job(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> dict[str, Any]:
    site = tmp_path / "site"
    assert mound_main(["sim", "site", "--mound", "none", "--size", "64", "48", "--out",
                       str(site)]) == 0
    capsys.readouterr()
    return json.loads((site / "render.json").read_text())


@pytest.mark.slow
def test_mound_render_is_all_or_nothing(tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    """Two images with one name raced on one temporary file (3 failures in 5 under
    --threads 2) and a failing image left the earlier ones behind."""
    from mound import native
    from mound.errors import ToolInputError

    job = _render_job(tmp_path, capsys)
    site = tmp_path / "site"
    dup = dict(job, images=[*job["images"][:3], dict(job["images"][1])])
    (site / "dup.json").write_text(json.dumps(dup))
    out = tmp_path / "out"
    with pytest.raises(ToolInputError, match=r"images\[3\].file: 'images/0001.png' is the same "
                       r"output as images\[1\]"):
        native.run_tool("mound_render", [str(site / "dup.json"), "--out", str(out),
                                         "--threads", "2"])
    assert not out.exists()
    # A later image that cannot be written: nothing of this run is left in --out.
    (out / "images" / "0005.png").mkdir(parents=True)
    (out / "keep.txt").write_text("an earlier file")
    with pytest.raises(ToolInputError, match=r"images\[5\].file: .*0005.png is a folder"):
        native.run_tool("mound_render", [str(site / "render.json"), "--out", str(out),
                                         "--threads", "2"])
    assert sorted(p.relative_to(out).as_posix() for p in out.rglob("*")) == [
        "images", "images/0005.png", "keep.txt"]
    # The same job into a clean folder, twice at once with two threads each: every image
    # whole, no temporary file left.
    (out / "images" / "0005.png").rmdir()
    import subprocess

    tool = str(native.tool_path("mound_render"))
    procs = [subprocess.Popen([tool, str(site / "render.json"), "--out", str(out), "--threads",
                               "2"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
             for _ in range(2)]
    assert all(p.wait(timeout=300) == 0 for p in procs)
    names = sorted(p.name for p in (out / "images").iterdir())
    assert names == [f"{k:04d}.png" for k in range(len(job["images"]))]
    assert not [p for p in out.rglob("*") if ".tmp." in p.name or ".mound_render" in p.name]


@pytest.mark.slow
def test_mound_render_refuses_an_endless_npy(tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    """A render job whose .npy was an endless file (/dev/zero) read until memory ran out
    (exit 1); a device, a pipe or a folder is now refused before it is read."""
    from mound import native
    from mound.errors import ToolInputError

    job = _render_job(tmp_path, capsys)
    site = tmp_path / "site"
    for name, bad in (("zero", "/dev/zero"), ("folder", str(site))):
        edited = dict(job, heightfield=dict(job["heightfield"], npy=bad))
        (site / f"{name}.json").write_text(json.dumps(edited))
        with pytest.raises(ToolInputError, match=r"heightfield.npy: .*not a regular file"):
            native.run_tool("mound_render", [str(site / f"{name}.json"), "--out",
                                             str(tmp_path / name)], timeout_s=60)
        assert not (tmp_path / name).exists()
