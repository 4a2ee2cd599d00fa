"""The 3-D site viewer (site3d.html) in headless Chromium on a constructed cloud: flat
ground with two points raised 3 m above it, a known 22.56 m apart. The page loads from
file:// with no console error, draws (non-blank pixels), and its measuring tool, clicked on
the two points where the camera shows them, gives their distance to 1 % and their height
above the ground fit."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from pages import CHROMIUM, body_data

from mound.formats.verdict import Rise
from mound.survey import webmap

pytestmark = [
    pytest.mark.skipif(CHROMIUM is None, reason="Debian chromium not installed (tools/setup.sh)"),
    pytest.mark.skipif(not webmap.web_libraries_available(),
                       reason="the report's JavaScript is not installed (tools/setup.sh)"),
]


def load(page: Path, fragment: str, profile: Path) -> dict[str, str]:
    return body_data(page.resolve().as_uri() + "#" + fragment, profile)


def test_site_viewer_draws_and_measures_a_known_distance(tmp_path: Path) -> None:
    # Ground sloping 2 % to the east around an ENU centre far from the origin, 0.5 m grid.
    centre = np.array([1000.0, -2000.0])
    g = np.arange(-30, 30.01, 0.5)
    gx, gy = np.meshgrid(g, g)
    ground = [50.0, 0.02, 0.0, 0.0, 0.0, 0.0]  # z = 50 + 0.02 x (x, y from the centre)
    xyz = np.column_stack([gx.ravel() + centre[0], gy.ravel() + centre[1],
                           50 + 0.02 * gx.ravel()])
    a, b = np.array([-10.0, 0.0]), np.array([12.0, 5.0])
    raised = np.array([[*(centre + a), 50 + 0.02 * a[0] + 3.0],
                       [*(centre + b), 50 + 0.02 * b[0] + 3.0]])
    xyz = np.vstack([xyz, raised])
    rgb = np.full((len(xyz), 3), 120, np.uint8)
    doc = webmap.viewer_doc("test", xyz, rgb, centre, ground, 30.0,
                            rise=Rise.from_doc({
                                "centre_enu_m": list(centre), "height_m": 2.0,
                                "base_diameter_m": 20.0,
                                # a rise measured over a curved ground (a hill's top)
                                "ground_plane": [50.0, 0.02, 0.0],
                                "ground_curvature": [-0.002, 0.0, -0.001]}, "rise"))
    assert doc["rise"]["plane"][1:] == [0.02, 0.0]
    assert doc["rise"]["curvature"] == [-0.002, 0.0, -0.001]
    assert doc["points"] == len(xyz)  # below the viewer's maximum: nothing dropped
    doc["test_pick"] = [len(xyz) - 2, len(xyz) - 1]
    out = webmap.copy_web_files(tmp_path)
    webmap.write_viewer_data(out, doc)
    got = load(tmp_path / "site3d.html", "test/selftest", tmp_path / "profile")
    assert json.loads(got["errors"]) == []
    assert int(got["points"]) == len(xyz)
    assert int(got["nonblank"]) > 10_000
    truth = float(np.linalg.norm(raised[1] - raised[0]))
    assert math.isclose(truth, 22.56, rel_tol=1e-3)
    assert abs(float(got["measured"]) - truth) < 0.01 * truth
    assert abs(float(got["above"]) - 3.0) < 0.03


def test_viewer_refuses_a_bad_address(tmp_path: Path) -> None:
    webmap.copy_web_files(tmp_path)
    got = load(tmp_path / "site3d.html", "../../etc", tmp_path / "profile")
    assert "no site" in got["errors"]
    got = load(tmp_path / "site3d.html", "nosuchsite", tmp_path / "profile2")
    assert "did not load" in got["errors"]
