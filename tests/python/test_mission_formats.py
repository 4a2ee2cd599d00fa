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
