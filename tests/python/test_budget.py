"""One budget: a plan that fits its budget is a mission that fits it.

Random fields (closed tours and start -> end paths, every scan pattern, several site
diameters and heights) are planned by the real mound_plan with the scan costs that
mound.geometry.flight.ScanSpec derives, and turned into MAVLink missions by
mound.uav.mission_items, which measures the 3-D flight (climbs included): it is never
longer than the plan's cost, so the mission never exceeds the budget the plan kept.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from mound import native
from mound.cli import main as mound_main
from mound.errors import InputError
from mound.formats.plan import Plan
from mound.geometry.flight import scan_for_site
from mound.geometry.geodesy import Origin
from mound.uav import mission


def build_mission(plan: dict, *args: Any) -> Any:
    """mission.build of a plan document (the tests keep their plans as dicts)."""
    return mission.build(Plan.from_doc(plan, "test plan"), *args)


ORIGIN = Origin(38.5705, 27.9862, 95.0)


def random_sites(rng: np.random.Generator, closed: bool) -> tuple[dict, float]:
    scan = scan_for_site(
        site_diameter_m=float(rng.uniform(15, 90)),
        pattern=str(rng.choice(["raster", "orbit", "both"])),
        raster_altitude_m=None if rng.random() < 0.5 else float(rng.uniform(30, 120)),
        transit_altitude_m=None if rng.random() < 0.5 else float(rng.uniform(60, 150)))
    n = int(rng.integers(4, 25))
    extent = float(rng.uniform(500, 4000))
    xy = rng.uniform(-extent, extent, size=(n, 2))
    cost = scan.site_cost_m()
    doc = {"schema": "mound.sites", "version": 1, "origin": ORIGIN.to_doc(),
           "home": {"id": "home", "x_m": 0.0, "y_m": 0.0},
           "scan": scan.to_doc(), "takeoff_landing_m": scan.takeoff_landing_m(),
           "sites": [{"id": f"s{k}", "x_m": float(x), "y_m": float(y),
                      "reward": float(rng.uniform(0.1, 1.0)), "scan_cost_m": cost}
                     for k, (x, y) in enumerate(xy)]}
    if not closed:
        doc["end"] = {"id": "end", "x_m": float(rng.uniform(-extent, extent)),
                      "y_m": float(rng.uniform(-extent, extent))}
    # A budget that reaches some but not all sites: from the cheapest visit of one site to
    # a good part of the whole field.
    far = float(np.max(np.linalg.norm(xy, axis=1)))
    doc["budget_m"] = scan.takeoff_landing_m() + float(rng.uniform(2.2, 6.0)) * far + 3 * cost
    return doc, cost


@pytest.mark.parametrize("seed", range(12))
def test_plans_within_budget_fly_within_budget(tmp_path: Path, mound_plan: Path,
                                                seed: int) -> None:
    rng = np.random.default_rng(seed)
    doc, _ = random_sites(rng, closed=seed % 3 != 0)
    sites_path = tmp_path / "sites.json"
    sites_path.write_text(json.dumps(doc))
    visited = 0
    for algo in ("newalg", "newalg-ls", "greedy"):
        plan = native.run_json("mound_plan", [str(sites_path), "--algo", algo])
        assert plan["scan"] == doc["scan"]  # carried along for the mission
        assert plan["takeoff_landing_m"] == doc["takeoff_landing_m"]
        assert plan["cost_m"] <= doc["budget_m"] + 1e-6
        if len(plan["tour"]) <= 2 + (plan["tour"][0] != plan["tour"][-1]) - 1:
            continue  # nothing visited: nothing to fly
        m = build_mission(plan, ORIGIN)  # the plan's own scan; raises past the budget
        visited += len(m.sites)
        assert m.flight_distance_m <= plan["cost_m"] + 1e-6
        # The bound is not loose: the climbs and the scans are most of what it adds.
        assert m.flight_distance_m >= 0.7 * plan["cost_m"]
    assert visited > 0


def test_the_climbs_are_what_the_takeoff_landing_cost_pays_for(tmp_path: Path,
                                                                mound_plan: Path) -> None:
    """One site straight east of home, scanned by an orbit that starts and ends on the far
    side: the flight is the planar trip plus the scan plus the two climbs, all but exactly.
    With the climbs in the planner's costs a budget of exactly the plan's cost flies; left
    out, the same budget minus the climbs still admits the tour on paper, and the mission
    refuses it."""
    scan = scan_for_site(site_diameter_m=40.0, pattern="orbit")
    doc = {"schema": "mound.sites", "version": 1, "origin": ORIGIN.to_doc(),
           "home": {"id": "home", "x_m": 0.0, "y_m": 0.0},
           "scan": scan.to_doc(), "takeoff_landing_m": scan.takeoff_landing_m(),
           "budget_m": 1e5,
           "sites": [{"id": "s0", "x_m": 1000.0, "y_m": 0.0, "reward": 1.0,
                      "scan_cost_m": scan.site_cost_m()}]}
    plan = native.run_json("mound_plan", [str(write(tmp_path / "a.json", doc))])
    m = build_mission(plan, ORIGIN)
    assert m.flight_distance_m == pytest.approx(plan["cost_m"], rel=0.01)
    doc["budget_m"] = plan["cost_m"]
    build_mission(native.run_json("mound_plan", [str(write(tmp_path / "b.json", doc))]),
                        ORIGIN)
    doc["budget_m"] = plan["cost_m"] - doc.pop("takeoff_landing_m") + 1e-3
    plan = native.run_json("mound_plan", [str(write(tmp_path / "c.json", doc))])
    assert plan["tour"] == ["home", "s0", "home"]
    with pytest.raises(InputError, match="exceeds the plan's budget_m"):
        build_mission(plan, ORIGIN)


def write(path: Path, doc: dict) -> Path:
    path.write_text(json.dumps(doc))
    return path


@pytest.mark.slow
def test_field_make_scan_pattern_to_mission_without_tuning(tmp_path: Path,
                                                            mound_plan: Path) -> None:
    """The demo's chain with no hand-tuned numbers: the scan cost comes from the pattern,
    the budget from the aircraft's range, and the mission passes its check."""
    sites = tmp_path / "sites.json"
    assert mound_main(["field", "make", "--seed", "0", "--spacing", "250", "--scan-pattern",
                       "raster", "--out", str(sites)]) == 0
    doc = json.loads(sites.read_text())
    scan_cost = doc["sites"][0]["scan_cost_m"]
    assert 100 < scan_cost < 1000 and doc["takeoff_landing_m"] == pytest.approx(120.0)
    assert doc["budget_m"] == pytest.approx(14400.0)
    plan_path = tmp_path / "plan.json"
    native.run_tool("mound_plan", [str(sites), "--out", str(plan_path)])
    assert mound_main(["mission", "build", str(plan_path), "--out",
                       str(tmp_path / "m.plan")]) == 0
    # Scan options that contradict the plan's scan (a bigger site) are flown as asked and
    # checked against the budget: refused when the plan's costs no longer cover them.
    assert mound_main(["field", "make", "--seed", "0", "--spacing", "250", "--scan-cost", "1",
                       "--scan-pattern", "raster", "--out", str(tmp_path / "x.json")]) == 2
