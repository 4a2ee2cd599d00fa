"""python/mission.py --scene: the whole survey on two real Kazanlak IKONOS stamps (the
scene model learned from the field-checked inventory, candidates from p(mound), the tour,
the mission, each visited site's simulated flight and 3-D verdict, the report)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import rasterio
from pyproj import Transformer

from mound.paths import REPO_ROOT

MISSION_PY = REPO_ROOT / "python" / "mission.py"


@pytest.mark.slow
def test_survey_on_two_kazanlak_stamps(tmp_path: Path, shared_data: Path) -> None:
    k = shared_data / "kazanlak"
    out = tmp_path / "run"
    args = [sys.executable, str(MISSION_PY), "--out", str(out), "--scene",
            str(k / "stamps" / "3257.tif"), str(k / "stamps" / "3259.tif"),
            "--labels", str(k / "mounds.geojson"), "--band-names", "blue,green,red,nir",
            "--home", "42.6895,25.3510", "--candidates", "4", "--budget", "3000",
            "--image-size", "320", "240", "--dense-size", "0", "--no-progress"]
    r = subprocess.run(args, capture_output=True, text=True, timeout=900, cwd=REPO_ROOT)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    model = json.loads((out / "scene_model.json").read_text())
    assert model["schema"] == "mound.scene_model" and len(model["training"]["scenes"]) == 2
    for d in ("00_3257", "01_3259"):
        with rasterio.open(out / "scene" / d / "p_mound.tif") as ds:
            assert ds.crs.to_epsg() == 32635
    sites = json.loads((out / "sites.json").read_text())
    summary = json.loads((out / "summary.json").read_text())
    assert len(sites["sites"]) == 4 and sites["origin"]["lat"] == pytest.approx(42.6895)
    # Truth from the inventory: a candidate within 15 m of a known mound is a mound (with
    # its height), the others unknown, flown over flat ground and left out of eps_MD/FA.
    inv = json.loads((k / "mounds.geojson").read_text())["features"]
    to_utm = Transformer.from_crs("EPSG:4326", "EPSG:32635", always_xy=True)
    mx, my = to_utm.transform([f["geometry"]["coordinates"][0] for f in inv],
                              [f["geometry"]["coordinates"][1] for f in inv])
    known = 0
    for s in sites["sites"]:
        d = np.min(np.hypot(np.asarray(mx) - s["scene"]["x"], np.asarray(my) - s["scene"]["y"]))
        if "truth" in s:
            known += 1
            assert s["truth"]["mound"] and d <= 15.0 and s["truth"]["height_m"] > 0
        else:
            assert d > 15.0 and s["simulate"] == "flat"
    assert known >= 1
    rows = {r["id"]: r for r in summary["sites"]}
    assert summary["metrics"]["verdicts_with_truth"] == sum(
        1 for s in sites["sites"] if "truth" in s and rows[s["id"]]["visited"])
    for s in sites["sites"]:
        if rows[s["id"]]["visited"]:
            res = json.loads((out / "sites" / s["id"] / "site_result.json").read_text())
            assert res["simulated"]["truth"] == ("known" if "truth" in s else "unknown")
            if "truth" in s:
                assert res["simulated"]["height_m"] == pytest.approx(s["truth"]["height_m"])
    html = (out / "report.html").read_text()
    assert "report/scene.png" in html and (out / "report" / "scene.png").stat().st_size > 5000
    # The map carries each scene's p(mound) where its GeoTIFF lies (WGS84, to 1 m).
    from rasterio.warp import transform_bounds

    js = (out / "map" / "survey.js").read_text()
    data = json.loads(js[js.index("=") + 1:].strip().rstrip(";"))
    scenes = [o for o in data["overlays"] if o["name"] == "scene_p_mound"]
    tifs = sorted(out.glob("scene/*/p_mound.tif"))
    assert len(scenes) == len(tifs) > 0
    for o in scenes:
        with rasterio.open(out / o["tif"]) as src:
            west, south, east, north = transform_bounds(src.crs, "EPSG:4326", *src.bounds)
        (s_, w_), (n_, e_) = o["bounds"]
        m = 111_320.0
        c = m * np.cos(np.radians(south))
        assert max(abs(s_ - south) * m, abs(n_ - north) * m,
                   abs(w_ - west) * c, abs(e_ - east) * c) < 1.0
        assert (out / o["png"]).stat().st_size > 1000
