"""Issue 70: the mission file formats are one registry (mound.uav.mission_format): every
module of mound.uav.filetypes holds one FORMAT, and every format appears wherever the
formats do: an option of `mound mission build` (and `mound mission formats`), its files
and its entry in the .plan's record, `mound mission show` for each one a reader reads;
the survey's folder, its mission.json and the report's map iterate the same registry
(test_survey, test_day)."""

from __future__ import annotations

import importlib
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from test_mission import grid_plan

from mound.paths import REPO_ROOT
from mound.uav import files as mission_files
from mound.uav import filetypes, mission_format
from mound.uav.route import items_route


def mound(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mound", *args], capture_output=True,
                          text=True, cwd=REPO_ROOT, check=False, timeout=300)


def test_the_registry_is_the_filetypes_package() -> None:
    modules = sorted(p.stem for p in Path(filetypes.__file__).parent.glob("*.py")
                     if p.stem != "__init__")
    found = {importlib.import_module(f"mound.uav.filetypes.{m}").FORMAT.name for m in modules}
    reg = mission_format.registry()
    assert {f.name for f in reg} == found and len(reg) == len(modules) >= 5
    assert [f.name for f in reg if f.reference] == ["qgc_plan"]
    assert len({f.suffix for f in reg}) == len({f.option for f in reg}) == len(reg)
    assert all(f.suffix.startswith(".") and f.option.startswith("--") and f.limits
               for f in reg)
    listing = mound("mission", "formats")
    assert listing.returncode == 0
    assert [line.split()[0] for line in listing.stdout.splitlines()] == [f.name for f in reg]


def test_every_format_is_asked_for_written_recorded_and_read_back(tmp_path) -> None:
    """One flight built with every registered format's option: each format's files are
    there, the .plan records each other format's files, and each readable one reads back
    as `mound mission show` shows it, starting at the .plan's take-off and as long."""
    plan = tmp_path / "plan.json"
    plan.write_text(json.dumps(grid_plan(3)))
    help_text = mound("mission", "build", "--help").stdout
    args = []
    for f in mission_format.registry():
        assert f.option in help_text
        args += [f.option, str(tmp_path / f"m{f.suffix}")]
    r = mound("mission", "build", str(plan), *args)
    assert r.returncode == 0, r.stderr
    doc = json.loads((tmp_path / "m.plan").read_text())
    record = doc["mound"]["formats"]
    reference = items_route(mission_files.read_plan(tmp_path / "m.plan")[0])
    for f in mission_format.registry():
        assert (tmp_path / f"m{f.suffix}").is_file(), f.name
        if not f.reference:
            assert record[f.name]["files"] == [f"m{f.suffix}"] and "refused" not in record[f.name]
        if not f.readable:
            shown = mound("mission", "show", str(tmp_path / f"m{f.suffix}"))
            assert shown.returncode == 2 and "not a mission" in shown.stderr
            continue
        shown = mound("mission", "show", str(tmp_path / f"m{f.suffix}"))
        assert shown.returncode == 0 and f"m{f.suffix}:" in shown.stdout, shown.stderr
        _, routes = mission_format.read_any(tmp_path / f"m{f.suffix}")
        r0 = routes[0]
        a, b = r0.points[0], reference.points[0]
        assert abs(a.lat_deg - b.lat_deg) < 1e-6 and abs(a.lon_deg - b.lon_deg) < 1e-6, f.name
        assert abs(a.height_m - b.height_m) < 0.1, f.name
        length = float(np.sum(r0.leg_lengths_m()))
        assert abs(length - float(np.sum(reference.leg_lengths_m()))) < 1.0, f.name


def test_no_output_names_every_formats_option(tmp_path) -> None:
    plan = tmp_path / "plan.json"
    plan.write_text(json.dumps(grid_plan(2)))
    r = mound("mission", "build", str(plan))
    assert r.returncode == 2 and r.stderr.count("\n") == 1
    assert all(f.option in r.stderr for f in mission_format.registry())


# ------------------------------------------ the GPX track for ground crews (filetypes/gpx)

def _flat_mission() -> object:
    from test_mission import ORIGIN

    from mound.formats.plan import Plan
    from mound.uav import mission, mission_items

    return mission.build(Plan.from_doc(grid_plan(3), "test"), ORIGIN,
                         mission_items.MissionSpec())


def test_the_gpx_track_is_the_plans_route_as_gpxpy_reads_it(tmp_path) -> None:
    """gpxpy (an independent reader) finds home and the sites as waypoints and the route's
    every waypoint as a track point, `ele` the origin's altitude plus the height above
    home; our reader gives back the .plan's whole route (speeds, photos, gimbal, end)."""
    import gpxpy

    from mound.uav.filetypes import gpx
    from mound.uav.route import mission_route

    m = _flat_mission()
    path = tmp_path / "m.gpx"
    path.write_text(gpx.gpx_text(m))  # type: ignore[arg-type]
    route = mission_route(m)  # type: ignore[arg-type]
    g = gpxpy.parse(path.read_text())
    assert [w.name for w in g.waypoints] == ["home", "s0", "s1", "s2"]
    assert g.waypoints[0].elevation == pytest.approx(95.0)
    assert len(g.tracks) == 1 and len(g.tracks[0].segments) == 1
    pts = g.tracks[0].segments[0].points
    assert len(pts) == len(route.points) > 10
    for p, q in zip(pts, route.points, strict=True):
        assert (p.latitude, p.longitude) == pytest.approx((q.lat_deg, q.lon_deg), abs=1e-7)
        assert p.elevation == pytest.approx(95.0 + q.height_m, abs=1e-3)
    assert "above mean sea level" in (g.description or "")
    _, back = gpx.read_gpx(path)
    assert back.differs_from(route) is None, back.differs_from(route)
    assert back.end == route.end == "home"


@pytest.mark.parametrize("name,edit,names", [
    ("not_xml", lambda t: "lat,lon\n1,2\n", "not well-formed"),
    ("entity", lambda t: t.replace('<?xml version="1.0" encoding="UTF-8"?>',
                                   '<?xml version="1.0"?><!DOCTYPE gpx [<!ENTITY a "b">]>'),
     "DTD"),
    ("gpx_1_0", lambda t: t.replace("GPX/1/1", "GPX/1/0"), "not GPX 1.1"),
    ("no_track", lambda t: t[:t.index("<trk>")] + "</gpx>\n", "no trk"),
    ("lat", lambda t: t.replace('lat="', 'lat="9', 2), "lat"),
    ("speed", lambda t: t.replace('speed_m_s="', 'speed_m_s="nan', 1), "speed_m_s"),
    ("ele", lambda t: t.replace("<ele>", "<ele>x", 1), "ele"),
])
def test_bad_gpx_files_are_refused_naming_the_file(tmp_path, name: str, edit, names: str
                                                   ) -> None:
    from mound.uav.filetypes import gpx

    path = tmp_path / f"{name}.gpx"
    path.write_text(edit(gpx.gpx_text(_flat_mission())))  # type: ignore[arg-type]
    r = mound("mission", "show", str(path))
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert str(path) in r.stderr and names in r.stderr, r.stderr
