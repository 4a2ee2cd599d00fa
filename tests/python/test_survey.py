"""python/mission.py, the end-to-end survey: the whole driver on a small field (2 visited
sites, 320 x 240 images), interrupted with Ctrl-C and resumed, its artefacts checked with
their real readers (mound.sites / mound.plan / the mission file reader / the PLY reader,
MAVSDK as the vehicle that receives the mission, headless Chromium for the report), a
failing site with photos that allow no reconstruction (on a Dask cluster started
separately), and bad --sites files that stop the run before anything is planned."""

from __future__ import annotations

import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rasterio
from pages import body_data
from PIL import Image

from mound.classify.metrics import detection_error_rates, says_mound
from mound.classify.reward import binary_entropy_bits
from mound.cli import main as cli_main
from mound.formats.plan import Plan
from mound.formats.site_row import SecondLookRecord, SiteRow
from mound.formats.sites import Site, Truth, load_user_sites
from mound.formats.verdict import SecondLookAdvice, Verdict
from mound.geometry.flight import scan_for_site
from mound.geometry.geodesy import Origin, enu_to_geodetic
from mound.jsonio import write_json
from mound.paths import REPO_ROOT
from mound.plan import sites as op_sites
from mound.ply import read_ply
from mound.recon.tool_options import DensifyOptions
from mound.survey import driver
from mound.survey.context import Context
from mound.survey.ledger import Ledger
from mound.survey.stages import sites3d
from mound.survey.tree import RunTree
from mound.uav import files as mission_files
from mound.uav import mission_items
from mound.uav.mavlink.peer import MavsdkVehicle

MISSION_PY = REPO_ROOT / "python" / "mission.py"
SMALL = ["--budget", "3000", "--image-size", "320", "240", "--no-progress"]
CHROMIUM = shutil.which("chromium")


def system_python() -> str:
    """A python3 other than the venv's, to check that mission.py re-executes itself."""
    venv_bin = str(REPO_ROOT / ".venv" / "bin")
    path = os.pathsep.join(p for p in os.environ.get("PATH", "").split(os.pathsep)
                           if p != venv_bin)
    return shutil.which("python3", path=path) or sys.executable


def run_driver(args: list[str], timeout_s: float = 600) -> subprocess.CompletedProcess[str]:
    return subprocess.run([system_python(), str(MISSION_PY), *args], capture_output=True,
                          text=True, timeout=timeout_s, cwd=REPO_ROOT)


def tool_processes(marker: str) -> list[str]:
    """Command lines of running processes that mention `marker` (the run directory)."""
    found = []
    for p in Path("/proc").iterdir():
        if not p.name.isdigit():
            continue
        try:
            cmd = (p / "cmdline").read_bytes().replace(b"\0", b" ").decode()
        except OSError:
            continue
        if marker in cmd and ("mound_recon" in cmd or "mound_render" in cmd):
            found.append(cmd)
    return found


@pytest.fixture(scope="module")
def vehicle() -> Iterator[MavsdkVehicle]:
    with MavsdkVehicle("udpin") as v:
        yield v


@pytest.fixture(scope="module")
def survey(tmp_path_factory: pytest.TempPathFactory, vehicle: MavsdkVehicle
           ) -> dict[str, Any]:
    """Runs the driver once, interrupts it (SIGINT to its process group, as a terminal's
    Ctrl-C) after the first site is done, then reruns it to the end and a third time."""
    os.environ.setdefault("MOUND_DATA", str(REPO_ROOT.parent / "shared" / "data"))
    out = tmp_path_factory.mktemp("survey") / "run"
    args = ["--out", str(out), *SMALL, "--workers", "1", "--connect",
            vehicle.connect_string]
    # SIGINT restored to its default in the driver: a run of the tests started in the
    # background (`make test &`) would otherwise pass on an ignored SIGINT.
    proc = subprocess.Popen([system_python(), str(MISSION_PY), *args], cwd=REPO_ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 300
    first = None
    while time.monotonic() < deadline and proc.poll() is None:
        done = list(out.glob("sites/*/site_result.json"))
        if done:
            first = done[0]
            break
        time.sleep(0.2)
    assert first is not None, "no site finished before the deadline"
    os.killpg(proc.pid, signal.SIGINT)
    interrupted_out, _ = proc.communicate(timeout=60)
    time.sleep(0.5)
    # After the interrupted run has ended: a Dask task whose worker was stopped before the
    # client took its row may have run again and rewritten the same result meanwhile.
    first_mtime = first.stat().st_mtime_ns
    leftovers = tool_processes(str(out))
    second = run_driver(args)
    third = run_driver(args)
    return {"out": out, "interrupted_rc": proc.returncode, "interrupted": interrupted_out,
            "leftovers": leftovers, "first": first, "first_mtime": first_mtime,
            "second": second, "third": third, "vehicle": vehicle}


@pytest.mark.slow
def test_interrupt_ends_the_tools_and_the_rerun_resumes(survey: dict[str, Any]) -> None:
    assert survey["interrupted_rc"] == 130, survey["interrupted"]
    assert "run the same command again to resume" in survey["interrupted"]
    assert survey["leftovers"] == [], "tools outlived the interrupted driver"
    second = survey["second"]
    assert second.returncode == 0, second.stdout + second.stderr
    for stage in ("classify", "field", "plan", "mission"):
        assert f"[{stage}] skipped, unchanged" in second.stdout, second.stdout
    assert "1 of 2 visited sites to process (1 done before)" in second.stdout
    # The finished site was not redone.
    assert survey["first"].stat().st_mtime_ns == survey["first_mtime"]
    third = survey["third"]
    assert third.returncode == 0, third.stdout + third.stderr
    for stage in ("classify", "field", "plan", "mission", "sites3d"):
        assert f"[{stage}] skipped, unchanged" in third.stdout, third.stdout


@pytest.mark.slow
def test_every_artefact_of_the_run(survey: dict[str, Any]) -> None:
    out: Path = survey["out"]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["schema"] == "mound.survey" and summary["version"] == 1
    assert summary["status"] == "ok"
    # The plan is feasible: its tour's cost recomputed from the sites file is within the
    # budget, and its reward is the sum of the visited sites' rewards.
    sites_doc = json.loads((out / "sites.json").read_text())
    plan = json.loads((out / "plan.json").read_text())
    prob = op_sites.from_document(sites_doc)
    index = {sid: k for k, sid in enumerate(prob.ids)}
    route = [index[sid] for sid in plan["tour"]]
    assert prob.route_cost(route) <= prob.budget + 1e-6
    assert prob.route_cost(route) == pytest.approx(plan["cost_m"], rel=1e-9)
    visited = set(plan["tour"]) - {"home"}
    assert len(visited) == 2
    assert float(prob.reward[route].sum()) == pytest.approx(plan["reward"], rel=1e-9)
    # The mission file parses, and the vehicle (MAVSDK) received it.
    items, home, firmware = mission_files.read_mission(out / "mission.plan")
    mission = json.loads((out / "mission.json").read_text())
    assert len(items) == mission["items"] and firmware == "px4"
    assert home.lat_deg == pytest.approx(sites_doc["origin"]["lat"])
    assert mission["upload"]["verified"] is True
    assert len(survey["vehicle"].wait_for_mission(1)) == len(items)
    assert mission_files.read_mission(out / "mission.waypoints")[0]
    # Each visited site has a cloud and a verdict; simulated truth decides the verdict here.
    rows = {r["id"]: r for r in summary["sites"]}
    for sid in visited:
        row = rows[sid]
        assert row["visited"] and row["verdict"] in ("mound", "no_mound")
        xyz, _ = read_ply(out / "sites" / sid / "recon" / "points.ply")
        assert len(xyz) > 1000 and np.isfinite(xyz).all()
        verdict = json.loads((out / "sites" / sid / "recon" / "verdict.json").read_text())
        assert verdict["schema"] == "mound.verdict" and verdict["label"] == row["verdict"]
        assert row["verdict"] == ("mound" if row["truth"] else "no_mound")
        # the calibrated p of the learned verdict travels into the summary
        assert row["verdict_p_mound"] == verdict["p_mound"]
        assert (row["verdict_p_mound"] >= verdict["model"]["threshold"]) == (
            row["verdict"] == "mound")
        # judged on the site's dense cloud, by the model learned on dense clouds
        assert row["verdict_cloud"] == "dense" and verdict["cloud"].endswith("dense/dense.ply")
        assert verdict["model"]["trained"]["cloud"] == "dense"
        for key in ("thumbnails", "cloud", "relief", "terrain"):
            assert (out / row["files"][key]).is_file()
        # The dense cloud and the site's GeoTIFFs from it: UTM zone 35 north at Bin Tepe,
        # 0.5 m cells; a simulated tumulus (4-12 m) stands out in the local relief model,
        # flat ground does not; the orthophoto covers the site.
        dense, _ = read_ply(out / row["files"]["dense"] / "dense.ply")
        result = json.loads((out / "sites" / sid / "site_result.json").read_text())
        assert len(dense) > 20 * len(xyz) and result["rasters"]["cloud"] == "dense"
        with rasterio.open(out / row["files"]["rasters"] / "lrm.tif") as ds:
            assert ds.crs.to_epsg() == 32635 and ds.res == (0.5, 0.5)
            relief = np.percentile(ds.read(1, masked=True).compressed(), 99)
        assert relief > 2.0 if row["truth"] else relief < 1.0, (sid, relief)
        with rasterio.open(out / row["files"]["rasters"] / "orthophoto.tif") as ds:
            assert ds.count == 4 and (ds.read(4) == 255).mean() > 0.5
    assert {r["id"] for r in summary["sites"] if r["visited"]} == visited
    assert len(summary["sites"]) == 100
    # The metrics recompute from the rows.
    for r in summary["sites"]:
        expect = r["verdict"] if r["visited"] and r["verdict"] != "failed" else (
            "mound" if says_mound(r["p_mound"]) else "no_mound")
        assert r["final_label"] == expect
    truth = [r["truth"] for r in summary["sites"]]
    md, fa = detection_error_rates([r["final_label"] == "mound" for r in summary["sites"]], truth)
    m = summary["metrics"]
    assert (m["eps_md"], m["eps_fa"]) == (md, fa)
    cmd, cfa = detection_error_rates([says_mound(r["p_mound"]) for r in summary["sites"]], truth)
    assert (m["classifier_only"]["eps_md"], m["classifier_only"]["eps_fa"]) == (cmd, cfa)
    assert m["reward"] == plan["reward"] and m["cost_m"] == plan["cost_m"]
    assert m["budget_m"] == 3000.0
    names = [s["name"] for s in summary["stages"]]
    assert names == ["classify", "field", "plan", "mission", "photos", "sites3d"]
    assert (out / "report.md").read_text().startswith("# Survey report")


@pytest.mark.slow
@pytest.mark.skipif(CHROMIUM is None, reason="Debian chromium not installed (tools/setup.sh)")
def test_report_renders_in_headless_chromium(survey: dict[str, Any], tmp_path: Path) -> None:
    out: Path = survey["out"]
    url = (out / "report.html").resolve().as_uri()
    base = [str(CHROMIUM), "--headless", "--no-sandbox", "--disable-gpu",
            "--hide-scrollbars", f"--user-data-dir={tmp_path / 'profile'}"]
    dom = subprocess.run([*base, "--virtual-time-budget=10000", "--dump-dom", url],
                         capture_output=True, text=True, timeout=120)
    assert dom.returncode == 0, dom.stderr[-2000:]
    html = (out / "report.html").read_text()
    n_img = html.count("<img ")
    assert n_img >= 2 + 3 * 2  # field, mission, and three pictures per visited site
    # The page's own check, run by the browser after loading: every image decoded.
    assert f'data-images="{n_img}"' in dom.stdout, dom.stdout[:500]
    assert 'data-broken=""' in dom.stdout
    shot = tmp_path / "report.png"
    r = subprocess.run([*base, "--window-size=1280,2400", f"--screenshot={shot}", url],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and shot.is_file(), r.stderr[-2000:]
    pixels = np.asarray(Image.open(shot).convert("RGB"), dtype=float)
    assert pixels.shape[:2] == (2400, 1280)
    assert pixels.std() > 20  # not blank
    assert len(np.unique(pixels.reshape(-1, 3)[::97], axis=0)) > 200  # pictures, not text


@pytest.mark.slow
@pytest.mark.skipif(CHROMIUM is None, reason="Debian chromium not installed (tools/setup.sh)")
def test_map_page_in_headless_chromium(survey: dict[str, Any], tmp_path: Path) -> None:
    """map.html from file:// (no server, no network): no console error, one marker per
    site, one path per flight, each overlay where its GeoTIFF lies in WGS84 (to 1 m), and a
    click on the first visited site opens its card with its verdict."""
    from rasterio.warp import transform_bounds

    out: Path = survey["out"]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["map"] == "map.html"
    assert 'href="map.html"' in (out / "report.html").read_text()
    url = (out / "map.html").resolve().as_uri() + "#selftest"
    data = body_data(url, tmp_path / "profile")

    def attr(name: str) -> str:
        assert name in data, (name, sorted(data))
        return data[name]

    assert json.loads(attr("errors")) == []
    sites = json.loads((out / "sites.json").read_text())["sites"]
    assert int(attr("markers")) == len(sites)
    plan = json.loads((out / "plan.json").read_text())
    assert int(attr("paths")) == len(plan.get("flights") or [plan])
    footprints = sum(f["properties"].get("kind") == "image_footprint"
                     for gj in out.glob("mission*.geojson")
                     for f in json.loads(gj.read_text())["features"])
    assert int(attr("footprints")) == footprints > 0
    # every mission file of every readable format (.plan, WPL, DJI .kmz, Litchi .csv, ...)
    # drawn from its own reader's path, the same number of waypoints as the reader finds
    from mound.uav import mission_format

    readable = [f for f in mission_format.registry() if f.readable]
    files = [p for f in readable for p in sorted(out.glob(f"mission*{f.suffix}"))]
    assert {p.suffix for p in files} == {f.suffix for f in readable}
    want = [len(r.points) for p in files for r in mission_format.read_any(p)[1]]
    assert json.loads(attr("mission-files")) == want
    overlays = json.loads(attr("overlays"))
    visited = [r for r in summary["sites"] if r["visited"] and r.get("files", {}).get("rasters")]
    assert len(overlays) == 2 * len(visited) > 0  # orthophoto and relief model per site
    for o in overlays:
        row = next(r for r in visited if r["id"] == o["site"])
        with rasterio.open(out / row["files"]["rasters"] / f"{o['name']}.tif") as src:
            west, south, east, north = transform_bounds(src.crs, "EPSG:4326", *src.bounds)
        (s, w), (n, e) = o["bounds"]
        m_per_deg = 111_320.0
        lat_scale = m_per_deg * np.cos(np.radians(0.5 * (south + north)))
        assert abs(s - south) * m_per_deg < 1 and abs(n - north) * m_per_deg < 1
        assert abs(w - west) * lat_scale < 1 and abs(e - east) * lat_scale < 1
    first = next(r for r in summary["sites"] if r["visited"])
    assert attr("card-site") == first["id"]
    assert attr("card-verdict") == first.get("verdict", "")
    # The first visited site in 3-D: its cloud, drawn without error.
    viewer = body_data((out / "site3d.html").resolve().as_uri() + "#" + first["id"],
                       tmp_path / "profile3d")
    assert json.loads(viewer["errors"]) == []
    assert int(viewer["nonblank"]) > 50_000, viewer["nonblank"]
    # Firefox, which the tests can only photograph: the page's own check (markers, paths,
    # the clicked card, no error) paints a green square, else a red one.
    firefox = shutil.which("firefox")
    if firefox:
        profile = tmp_path / "firefox"
        profile.mkdir()
        shot = tmp_path / "firefox.png"
        r = subprocess.run([firefox, "--headless", "--no-remote", "-profile", str(profile),
                            "--window-size=1200,800", "--screenshot", str(shot), url],
                           capture_output=True, text=True, timeout=120)
        assert r.returncode == 0 and shot.is_file(), r.stderr[-2000:]
        pixel = np.asarray(Image.open(shot).convert("RGB"))[60, 60]
        assert tuple(pixel) == (0, 255, 0), pixel
    # Shipped with the page: nothing loads from the network.
    page = (out / "map.html").read_text() + (out / "map" / "webmap.js").read_text()
    assert "http://" not in page.replace("http://www.w3.org", "") and "https://" not in page


def test_error_rates_on_a_constructed_case() -> None:
    # 4 true mounds (one missed), 6 others (two false alarms), 2 unknown (ignored).
    labels = [True, True, True, False, True, True, False, False, False, False, True, False]
    truth: list[bool | None] = [True] * 4 + [False] * 6 + [None] * 2
    assert detection_error_rates(labels, truth) == (0.25, 2 / 6)
    assert detection_error_rates([True], [None]) == (None, None)


def free_tcp_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.mark.slow
def test_a_failing_site_is_reported_and_the_run_finishes(
        survey: dict[str, Any], tmp_path: Path) -> None:
    """The UAV's photos (--images-root) of the two visited sites: the first run's simulated
    images for one, eight featureless grey frames for the other (mound_recon exits 3). The
    per-site work runs on a Dask scheduler and two workers started separately."""
    out: Path = survey["out"]
    summary = json.loads((out / "summary.json").read_text())
    visited = sorted(r["id"] for r in summary["sites"] if r["visited"])
    good, bad = visited
    photos = tmp_path / "photos"
    sim = out / "sites" / good / "sim"
    (photos / good).mkdir(parents=True)
    for f in sorted((sim / "images").iterdir()):
        (photos / good / f.name).symlink_to(f)
    for name in ("camera.json", "poses.json"):
        (photos / good / name).symlink_to(sim / name)
    (photos / bad).mkdir()
    for k in range(8):
        Image.new("RGB", (320, 240), (128, 128, 128)).save(photos / bad / f"{k:04d}.png")
    shutil.copy(sim / "camera.json", photos / bad / "camera.json")
    poses = json.loads((sim / "poses.json").read_text())
    poses["images"] = poses["images"][:8]  # GPS of the eight frames
    (photos / bad / "poses.json").write_text(json.dumps(poses))

    port = free_tcp_port()
    venv_bin = REPO_ROOT / ".venv" / "bin"
    address = f"tcp://127.0.0.1:{port}"
    cluster = [subprocess.Popen([str(venv_bin / "dask"), "scheduler", "--host", "127.0.0.1",
                                 "--port", str(port), "--no-dashboard"],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                start_new_session=True)]
    try:
        cluster.append(subprocess.Popen(
            [str(venv_bin / "dask"), "worker", address, "--nworkers", "2", "--nthreads", "1",
             "--no-dashboard"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            start_new_session=True, cwd=tmp_path))
        run = tmp_path / "run"
        r = run_driver(["--out", str(run), *SMALL, "--images-root", str(photos),
                        "--scheduler", address])
        assert r.returncode == 0, r.stdout + r.stderr
        assert "2 workers" in r.stdout
        s = json.loads((run / "summary.json").read_text())
        rows = {x["id"]: x for x in s["sites"]}
        assert s["status"] == "partial"
        assert rows[good]["verdict"] == ("mound" if rows[good]["truth"] else "no_mound")
        assert rows[bad]["verdict"] == "failed"
        assert "no image pair with enough matches" in rows[bad]["failure"]
        assert rows[bad]["final_label"] == ("mound" if says_mound(rows[bad]["p_mound"])
                                            else "no_mound")
        assert s["metrics"]["failed"] == 1 and s["metrics"]["judged"] == 1
        result = json.loads((run / "sites" / bad / "site_result.json").read_text())
        assert result["status"] == "failed" and result["retry"] is False
        assert "failed:" in (run / "report.html").read_text()
        # A failure the input explains is not retried: a rerun skips the whole stage.
        again = run_driver(["--out", str(run), *SMALL, "--images-root", str(photos),
                            "--scheduler", address])
        assert "[sites3d] skipped, unchanged" in again.stdout, again.stdout
    finally:
        for p in reversed(cluster):
            os.killpg(p.pid, signal.SIGTERM)
            p.wait(timeout=30)


# --- bad input stops the run before anything is planned ------------------------------

def good_sites() -> dict[str, Any]:
    return {"schema": "mound.sites", "version": 1,
            "origin": {"lat": 38.5705, "lon": 27.9862, "alt_m": 95.0},
            "home": {"id": "home", "x_m": 0.0, "y_m": 0.0}, "budget_m": 5000.0,
            "sites": [{"id": "a", "x_m": 300.0, "y_m": 0.0, "p_mound": 0.4, "truth": True},
                      {"id": "b", "x_m": 0.0, "y_m": 400.0, "p_mound": 0.1,
                       "truth": {"mound": False}}]}


def broken(change: Any) -> dict[str, Any]:
    doc = good_sites()
    change(doc)
    return doc


BAD_SITES = [
    (lambda d: d["sites"][1].pop("p_mound"), "sites[1].p_mound: missing"),
    (lambda d: d["sites"][0].update(p_mound=1.5), "sites[0].p_mound: must be in [0, 1]"),
    (lambda d: d["sites"][0].update(x_m="far"), "sites[0].x_m: expected a finite number"),
    (lambda d: d["sites"][1].update(id="a"), "sites[1].id: 'a' is not unique"),
    (lambda d: d.pop("origin"), "origin: missing"),
    (lambda d: d["sites"][0].pop("truth"), "sites[0].truth: missing"),
    (lambda d: d["sites"][0].update(truth="yes"), "sites[0].truth: expected true/false"),
    (lambda d: d.update(sites=[]), "sites: expected a non-empty list"),
    (lambda d: d.update(version=7), "version: unsupported"),
]


@pytest.mark.parametrize(("change", "message"), BAD_SITES)
def test_a_bad_sites_file_stops_the_run_before_planning(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], change: Any, message: str) -> None:
    path = tmp_path / "sites.json"
    path.write_text(json.dumps(broken(change)))
    out = tmp_path / "run"
    code = driver.main(["--sites", str(path), "--out", str(out), "--no-progress"])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1 and message in err and str(path) in err, err
    assert not (out / "sites.json").exists() and not (out / "plan.json").exists()


def test_not_a_sites_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for text, message in (("{\"a\": ", "not valid JSON"), ("[1, 2]", "expected a JSON object"),
                          ("{\"type\": \"Feature\"}", "schema: neither")):
        path = tmp_path / "x.json"
        path.write_text(text)
        assert driver.main(["--sites", str(path), "--out", str(tmp_path / "r")]) == 2
        assert message in capsys.readouterr().err


def test_geojson_sites_are_placed_in_the_home_frame(tmp_path: Path) -> None:
    home = Origin(38.5705, 27.9862, 95.0)
    enu = np.array([[500.0, 0.0, 0.0], [0.0, -700.0, 0.0], [250.0, 250.0, 0.0]])
    llh = enu_to_geodetic(home, enu)
    features = [{"type": "Feature", "properties": {"kind": "home", "alt_m": 95.0},
                 "geometry": {"type": "Point", "coordinates": [home.lon_deg, home.lat_deg]}}]
    for k, (lat, lon, _) in enumerate(llh):
        features.append({"type": "Feature", "id": f"g{k}",
                         "properties": {"p_mound": 0.2 * (k + 1), "truth": k == 1},
                         "geometry": {"type": "Point", "coordinates": [lon, lat]}})
    path = tmp_path / "sites.geojson"
    path.write_text(json.dumps({"type": "FeatureCollection", "budget_m": 9000,
                                "features": features}))
    scan = scan_for_site(60.0, "raster")
    doc = load_user_sites(path, scan, None, 14400.0, need_truth=True)
    assert doc.budget_m == 9000 and doc.origin is not None
    assert doc.origin.lat_deg == home.lat_deg
    got = np.array([s.xy for s in doc.sites])
    assert np.abs(got - enu[:, :2]).max() < 1e-3
    assert [s.id for s in doc.sites] == ["g0", "g1", "g2"]
    assert doc.sites[1].truth == Truth(True)
    assert doc.sites[2].reward == pytest.approx(float(binary_entropy_bits(0.6)))
    assert all(s.scan_cost_m == scan.site_cost_m() for s in doc.sites)
    del features[0]
    path.write_text(json.dumps({"type": "FeatureCollection", "features": features}))
    with pytest.raises(ValueError, match="no feature with properties.kind = 'home'"):
        load_user_sites(path, scan, None, 14400.0, need_truth=True)


def test_help_and_usage_errors(capsys: pytest.CaptureFixture[str]) -> None:
    r = run_driver(["--help"], timeout_s=60)
    assert r.returncode == 0
    for option in ("--sites", "--images-root", "--scheduler", "--connect", "--out",
                   "--rerun-from", "--budget", "--field-seed"):
        assert option in r.stdout
    assert driver.main(["--spacing", "-1"]) == 2
    assert "--spacing" in capsys.readouterr().err
    assert driver.main(["--images-root", "/nonexistent/photos"]) == 2
    assert "--images-root" in capsys.readouterr().err
    assert driver.main(["--second-photos", str(REPO_ROOT)]) == 2  # without the first card
    assert "--second-photos goes with --photos" in capsys.readouterr().err
    model = str(REPO_ROOT / "data" / "verdict_model_dense.json")
    for bad in (["--verdict-model", "/nonexistent/model.json"],
                ["--verdict-model", str(REPO_ROOT / "data" / "Makefile_missing.json")],
                ["--verdict-model", str(REPO_ROOT / "pyproject.toml")],
                ["--verdict-model", model, "--dense-size", "0"],
                ["--verdict-model", model, "--reference", model]):
        assert driver.main(bad) == 2
        assert "--verdict-model" in capsys.readouterr().err


@pytest.mark.slow
def test_the_photo_card_gives_the_same_verdicts(survey: dict[str, Any], tmp_path: Path
                                                ) -> None:
    """The survey's flight written as the aircraft's card (mound sim flight: JPEGs with
    EXIF, transit frames), then the survey run on it with --photos: the card is sorted into
    the visited sites and each is reconstructed from its JPEGs with the EXIF's GPS and
    focal length; the verdicts are those of the simulated per-site folders."""
    out: Path = survey["out"]
    card = tmp_path / "card"
    code = cli_main(["sim", "flight", str(out / "plan.json"), "--out", str(card),
                     "--image-size", "320", "240", "--truth", str(tmp_path / "truth.json")])
    assert code == 0
    run = tmp_path / "run"
    # the simulated folders' reconstruction settings (--max-features 4000, which takes
    # SIFT's contrast 0.04 with it), so that the card path is compared with them like for
    # like: a card's photos otherwise get COLMAP's keypoint density (issue 67), which on
    # these 320 x 240 frames bent s023's ground by 0.34 m
    r = run_driver(["--out", str(run), *SMALL, "--photos", str(card), "--dense-size", "0",
                    "--max-features", "4000"])
    assert r.returncode == 0, r.stdout + r.stderr
    first = {x["id"]: x for x in json.loads((out / "summary.json").read_text())["sites"]}
    s = json.loads((run / "summary.json").read_text())
    visited = [x for x in s["sites"] if x["visited"]]
    assert len(visited) == 2
    for x in visited:
        assert x["source"] == "photos", x["id"]
        recon = json.loads((run / "sites" / x["id"] / "recon" / "recon.json").read_text())
        assert recon["inputs"]["gps_source"] == "exif"
        assert recon["inputs"]["camera_source"] == "exif (focal_plane)"
        # the lens refined about EXIF's values: a nadir block's free self-calibration bent
        # the model (issue 26: a bare site read as a 1.2 m x 132 m dome, its ground sagging
        # 0.6 m, and its focal length drifted by up to 8 x on the verdict's card grid)
        assert recon["inputs"]["lens"] == "prior"
        v = json.loads((run / "sites" / x["id"] / "recon" / "verdict.json").read_text())
        assert abs(v["measurements"]["ground_sag_m"]) < 0.3, x["id"]
        assert x["verdict"] == first[x["id"]]["verdict"], x["id"]
        # no dense cloud (--dense-size 0): the sparse cloud, by the sparse cloud's model
        assert x["verdict_cloud"] == "sparse" and v["cloud"].endswith("recon/points.ply")
        assert v["model"]["trained"]["cloud"] == "sparse"
    truth = json.loads((tmp_path / "truth.json").read_text())
    card_doc = json.loads((run / "photos" / "photos.json").read_text())
    assert {f["file"]: (f["site"], f["reason"]) for f in truth["files"]} == {
        f["file"]: (f["site"], f["reason"]) for f in card_doc["photos"]}
    assert s["photos"]["counts"]["transit"] > 0
    html = (run / "report.html").read_text()
    assert "Photo card" in html and "transit" in html
    # --learn re-plans the flights one after another; with the photos of one card it is
    # refused before anything runs.
    bad = run_driver(["--out", str(tmp_path / "x"), "--photos", str(card), "--learn"])
    assert bad.returncode == 2 and "--learn" in bad.stderr and not (tmp_path / "x").exists()


@pytest.fixture(scope="module")
def learned(survey: dict[str, Any], tmp_path_factory: pytest.TempPathFactory) -> Path:
    """--flights 2 --learn --learn-weight 30 on field 0 (the survey's judged sites reused)."""
    run = tmp_path_factory.mktemp("learn") / "run"
    shutil.copytree(survey["out"] / "sites", run / "sites")  # sites already judged
    r = run_driver(["--out", str(run), "--budget", "2000", "--flights", "2", "--learn",
                    "--learn-weight", "30", "--image-size", "320", "240", "--dense-size", "0",
                    "--no-progress"])
    assert r.returncode == 0, r.stdout + r.stderr
    return run


@pytest.mark.slow
def test_each_flight_teaches_the_next(learned: Path) -> None:
    """--flights 2 --learn on field 0: flight 2 is re-planned over the sites flight 1 did not
    fly, after the classifier was refitted with flight 1's verdicts (weighted by their
    confidence); every figure of learn.json recomputes from the run's own files, the
    held-out AUC on sat.tst without the field's rows."""
    from mound.classify import coarse, metrics, statlog
    from mound.classify.model import Model

    run = learned
    learn = json.loads((run / "learn" / "learn.json").read_text())
    assert learn["schema"] == "mound.learn" and len(learn["flights"]) == 2
    f1, f2 = learn["flights"]
    assert f1["sites"] and f2["sites"] and not set(f1["sites"]) & set(f2["sites"])
    assert f1["first_plan_sites"] == f1["sites"]  # nothing learned before flight 1
    sites0 = json.loads((run / "sites.json").read_text())
    left = json.loads((run / "learn" / "flight_2" / "sites.json").read_text())
    assert {x["id"] for x in left["sites"]} == {x["id"] for x in sites0["sites"]} - set(
        f1["sites"])
    # The model after flight 1: sat.trn plus flight 1's verdicts, weight confidence x 30.
    train, test = statlog.load("sat.trn"), statlog.load("sat.tst")
    base = Model.from_doc(json.loads((run / "model.json").read_text()), "model.json")
    rows0 = {x["id"]: x for x in sites0["sites"]}
    ex = f1["examples"]
    assert [e["id"] for e in ex] == f1["sites"]
    extra = (test.x[[rows0[e["id"]]["truth"]["statlog_row"] for e in ex]],
             np.array([1.0 if e["verdict"] == "mound" else -1.0 for e in ex]),
             np.array([30 * e["confidence"] for e in ex]))
    again = coarse.train(train, base.band, l2=base.l2, extra=extra)
    m1 = Model.from_doc(json.loads((run / "learn" / "flight_1" / "model.json").read_text()),
                        "m1")
    assert np.allclose(again.w, m1.w)
    # Flight 2 was planned on m1's rewards.
    for x in left["sites"]:
        p = float(m1.predict(test.x[[x["truth"]["statlog_row"]]])[0])
        assert x["p_mound"] == pytest.approx(p, abs=1e-12)
    # Held-out AUC: sat.tst without the field's 100 rows.
    keep = np.ones(len(test.cls), dtype=bool)
    keep[[x["truth"]["statlog_row"] for x in sites0["sites"]]] = False
    assert f1["held_out_auc"] == pytest.approx(
        metrics.roc_auc(m1.predict(test.x[keep]), test.y[keep]), abs=1e-12)
    assert learn["held_out_rows"] == int(keep.sum())
    # The final labels of the sites not flown come from the last model.
    m2 = Model.from_doc(json.loads((run / "learn" / "flight_2" / "model.json").read_text()),
                        "m2")
    s = json.loads((run / "summary.json").read_text())
    flown = set(f1["sites"]) | set(f2["sites"])
    assert {x["id"] for x in s["sites"] if x["visited"]} == flown
    for x in s["sites"]:
        p = float(m2.predict(test.x[[rows0[x["id"]]["truth"]["statlog_row"]]])[0])
        assert x["p_mound"] == pytest.approx(p, abs=1e-12)
    for k in (1, 2):
        plan = json.loads((run / "learn" / f"flight_{k}" / "plan.json").read_text())
        assert plan["cost_m"] <= plan["budget_m"] + 1e-6
        items, _, _ = mission_files.read_mission(run / "learn" / f"flight_{k}" / "mission.plan")
        assert items[0].command == mission_items.NAV_TAKEOFF
        assert items[-1].command == mission_items.NAV_RETURN_TO_LAUNCH
    assert "Learning between flights" in (run / "report.html").read_text()


@pytest.mark.slow
def test_learning_stops_when_no_flight_is_left(learned: Path, tmp_path: Path) -> None:
    """A budget that lets flight 1 reach one site and no later flight any other: the run
    ends after flight 1, saying why, with the labels of the first flight's learning."""
    run = tmp_path / "run"
    shutil.copytree(learned / "sites", run / "sites")
    r = run_driver(["--out", str(run), "--budget", "1500", "--flights", "2", "--learn",
                    "--image-size", "320", "240", "--dense-size", "0", "--no-progress"])
    assert r.returncode == 0, r.stdout + r.stderr
    learn = json.loads((run / "learn" / "learn.json").read_text())
    assert len(learn["flights"]) == 1 and "too small to leave home" in learn["stopped"]
    s = json.loads((run / "summary.json").read_text())
    assert s["metrics"]["visited"] == len(learn["flights"][0]["sites"]) == 1


@pytest.mark.slow
def test_two_flights_over_the_dem(tmp_path: Path) -> None:
    """The survey with --flights 2 on standard field 0 placed on the laser DEM: two
    missions (mission_1.plan, mission_2.plan, read back by the mission reader), each
    within the budget and clear of the terrain by the clearance (the mission's own
    account; tests/python/test_terrain_flight.py checks it independently), every visited
    site of both flights judged, the report showing both flights."""
    os.environ.setdefault("MOUND_DATA", str(REPO_ROOT.parent / "shared" / "data"))
    dem = REPO_ROOT.parent / "shared" / "data" / "dem" / "TM1_564_146.tif"
    out = tmp_path / "run"
    r = run_driver(["--out", str(out), "--budget", "1100", "--flights", "2", "--spacing", "80",
                    "--home", "46.451176,15.833860", "--dem", str(dem), "--dem-vertical",
                    "egm96", "--dense-size", "0", "--image-size", "320", "240",
                    "--no-progress"])
    assert r.returncode == 0, r.stdout + r.stderr
    plan = json.loads((out / "plan.json").read_text())
    flights = [f for f in plan["flights"] if len(f["tour"]) > 2]
    assert len(flights) == 2
    visited = set()
    from mound.uav import dji, dji_read, litchi
    from mound.uav.route import items_route

    for f in flights:
        items, _, _ = mission_files.read_mission(out / f"mission_{f['flight']}.plan")
        assert items[-1].command == mission_items.NAV_LAND
        assert f["cost_m"] <= plan["budget_m"] + 1e-6
        visited |= set(f["tour"][1:-1])
        # the same flight for DJI Pilot 2 and for Litchi, read back as the .plan flies
        route = items_route(items)
        kmz = dji_read.read_kmz(out / f"mission_{f['flight']}.kmz").route()
        want = dji.prepare(route, dji.AIRCRAFT["m3e"])
        assert want.differs_from(type(want)(want.home_lat_deg, want.home_lon_deg, kmz.points,
                                            kmz.end)) is None
        csv_points = litchi.read_litchi(out / f"mission_{f['flight']}.csv")
        assert [(p.lat_deg, p.lon_deg) for p in csv_points] == pytest.approx(
            [(p.lat_deg, p.lon_deg) for p in litchi.prepare(route)[0].points], abs=1e-8)
    summary = json.loads((out / "summary.json").read_text())
    assert {s["id"] for s in summary["sites"] if s["visited"]} == visited
    assert all(s["verdict"] != "failed" for s in summary["sites"] if s["visited"])
    m = summary["mission"]["flights"]
    assert len(m) == 2
    assert all(f["energy_m"] <= plan["budget_m"] + 1e-6 and f["lowest_clearance_m"] >= 30 - 1e-6
               for f in m)
    html = (out / "report.html").read_text()
    assert "mission map, flight 2" in html and "transit legs over the DEM, flight 1" in html


@pytest.mark.slow
def test_a_dense_cloud_that_allows_no_verdict_leaves_it_to_the_sparse_one(
        tmp_path: Path, mound_recon: Path, mound_render: Path) -> None:
    """A site's work judges its dense cloud; when that cloud allows no verdict (here
    densify's voxels 50 m wide leave a handful of points), the sparse cloud is judged and
    the row says why the dense one was not."""
    from mound.sim import site as sim
    from mound.sim import terrain
    from mound.survey.site_work import SiteJob, process_site

    spec = sim.SimSpec(terrain=terrain.preset("bin_tepe", resolution_m=0.5, diameter_m=30.0,
                                              height_m=4.0),
                       width_px=320, height_px=240, pattern="raster", scan_diameter_m=60.0,
                       seed=3, texel_m=0.1)
    sim.simulate(spec, tmp_path / "sim", threads=2)
    photos = tmp_path / "sim" / "images"  # the photos, with their camera and poses
    for name in ("camera.json", "poses.json"):
        shutil.copy(tmp_path / "sim" / name, photos / name)
    job = SiteJob(site=Site("s1", 0.0, 0.0, 0.0), index=0,
                  run_root=str(tmp_path / "run"), origin=Origin(38.57, 27.99, 95.0),
                  key="k", images_dir=str(photos), threads=2, figures=False,
                  dense=DensifyOptions(320, 50.0))
    row = process_site(job).to_doc()
    assert row["status"] == "ok", row.get("reason")
    assert row["dense"]["points"] < 100
    # a cloud of 50 m voxels is not one the dense model learned: refused (issue 67), and
    # the sparse cloud judged
    assert row["verdict_cloud"] == "sparse", row
    assert "resolution_m is 50" in row["dense_verdict_error"], row["dense_verdict_error"]
    assert row["verdict"] == "mound", row["reason"]
    v = json.loads((tmp_path / "run" / "sites" / "s1" / "recon" / "verdict.json").read_text())
    assert v["cloud"].endswith("recon/points.ply") and v["model"]["trained"]["cloud"] == "sparse"


@pytest.mark.slow
def test_the_second_looks_advised_become_a_mission_in_the_report(
        survey: dict[str, Any], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The sites whose verdict advised a second look get a mission of their own
    (DIR/second_look/: the wider scan over them within the budget, read back with the
    mission reader), and the report says so; a rerun in which no verdict advises one leaves
    no stale mission behind."""
    from mound.survey import report

    run = tmp_path / "run"
    shutil.copytree(survey["out"], run)
    args = driver.SurveyOptions.from_namespace(driver.build_parser().parse_args(
        ["--out", str(run), *SMALL]))
    ctx = Context(args, RunTree(run), Ledger(run / "stages.json"))
    plan = json.loads((run / "plan.json").read_text())
    visited = sorted(Plan.from_doc(plan, "plan.json").visited())
    rows = [SiteRow(s, "k", second_look=SecondLookRecord(True, 2.0))
            for s in visited]
    made, note = sites3d.second_look_missions(ctx, rows, run / "plan.json", run / "sites.json")
    assert "second_look/mission.json" in made and all((run / f).is_file() for f in made)
    doc = json.loads((run / "second_look" / "mission.json").read_text())
    sl = doc["second_look"]
    assert sl["sites"] and sorted(sl["flown"] + [r["id"] for r in sl["refused"]]) == visited
    assert sl["site_diameter_m"] == 2 * plan["scan"]["site_diameter_m"]
    # the small budget (3,000 m) takes one flight per wide scan; each within it
    assert doc["flights"] and all(f["flight_distance_m"] <= doc["budget_m"]
                                  for f in doc["flights"])
    for f in doc["flights"]:
        assert f"second_look/{f['file']}" in made
        items, home, _ = mission_files.read_mission(run / "second_look" / f["file"])
        assert abs(home.lat_deg - plan["origin"]["lat"]) < 1e-6
        assert sum(1 for it in items if it.command == mission_items.DO_SET_CAM_TRIGG_DIST
                   and it.params[0] > 0) >= len(f["sites"])
    assert f"second looks advised for {len(visited)} sites" in note
    print(f"[second look] {note.removeprefix('; ')}")
    summary = report.build_summary(ctx.tree, args, [], time.time())
    text = report.render_html(ctx.tree, summary)
    png = next(f for f in made if f.endswith(".png"))
    assert "Second looks advised for" in text and png in text
    assert "Second looks advised for" in report.render_md(summary)
    if CHROMIUM is not None:  # the map draws them: one dashed path per flight, no error
        # the map's cards come from the sites' rows (site_result.json): a second look flown
        # from photos at one, and one still waiting for its card at the other
        from mound.survey.tree import SiteTree

        looks = [SecondLookRecord(True, 2.0, True, 120.0, "photos", p_mound=0.9),
                 SecondLookRecord(True, 2.0, False,
                                  reason="a second card of the site is needed")]
        for sid, look in zip(visited[:2], looks, strict=True):
            path = SiteTree(ctx.tree.site_dir(sid)).result
            write_json(path, replace(SiteRow.read(path), second_look=look).to_doc())
        report.write_reports(ctx.tree, report.build_summary(ctx.tree, args, [], time.time()))
        js = (run / "map" / "survey.js").read_text()
        assert "flown (photos, a 120 m scan): p(mound) 0.900 after both flights" in js
        assert "advised, not flown: a second card of the site is needed" in js
        data = body_data((run / "map.html").resolve().as_uri() + "#selftest",
                         tmp_path / "profile")
        assert json.loads(data["errors"]) == []
        assert int(data["second-looks"]) == len(doc["flights"]) > 0
        assert int(data["paths"]) == len(plan.get("flights") or [plan])
    # their card (mound sim flight --scan-factor: the wider flights, transit frames between)
    # sorts exactly into the second looks' sites by second_look/plan.json's wide scan
    from mound.photos.sort import SortSpec, sort_card

    card = tmp_path / "card2"
    assert cli_main(["sim", "flight", str(run / "second_look" / "plan.json"), "--sites",
                     str(run / "sites.json"), "--out", str(card), "--image-size", "320", "240",
                     "--scan-factor", "2", "--truth", str(tmp_path / "truth2.json")]) == 0
    truth = json.loads((tmp_path / "truth2.json").read_text())
    assert {f["site"] for f in truth["files"] if f["site"]} == set(sl["flown"])
    sorted_card = sort_card(str(card), str(run / "second_look" / "plan.json"),
                            str(run / "photos_second"), SortSpec())
    assert {f["file"]: (f["site"], f["reason"]) for f in truth["files"]} == {
        f["file"]: (f["site"], f["reason"]) for f in sorted_card.doc["photos"]}
    assert all(v.status == "ok" for v in sorted_card.sites.values())
    jobs = sites3d.site_jobs(Context(driver.SurveyOptions.from_namespace(
        driver.build_parser().parse_args(["--out", str(run), *SMALL, "--photos", str(card),
                                          "--second-photos", str(card)])),
        RunTree(run), Ledger(run / "stages.json")))
    assert {j.site.id for j in jobs if j.second_images_dir} == set(sl["flown"])
    # another verdict model (--verdict-model) is another site: its key and its first
    # look's change, and the dense cloud's verdicts read it
    model = REPO_ROOT / "data" / "verdict_model_dense.json"
    other = sites3d.site_jobs(Context(driver.SurveyOptions.from_namespace(
        driver.build_parser().parse_args(["--out", str(run), *SMALL, "--photos", str(card),
                                          "--second-photos", str(card), "--verdict-model",
                                          str(model)])),
        RunTree(run), Ledger(run / "stages.json")))
    assert [j.site.id for j in other] == [j.site.id for j in jobs]
    for a, b in zip(jobs, other, strict=True):
        assert a.key != b.key and a.first_key != b.first_key
        assert a.dense_model is None and b.dense_model == str(model.resolve())
    made, note = sites3d.second_look_missions(ctx, [SiteRow(visited[0], "k")],
                                             run / "plan.json", run / "sites.json")
    assert made == [] and note == "" and not (run / "second_look").exists()
    # a second card with no second looks to sort it by: exit 2, naming the option
    assert driver.main(["--out", str(run), *SMALL, "--photos", str(card), "--second-photos",
                        str(card), "--dense-size", "0"]) == 2
    assert "--second-photos: no second looks" in capsys.readouterr().err


@pytest.mark.slow
def test_a_site_the_first_flight_leaves_undecided_is_flown_again_wider(
        tmp_path: Path, mound_recon: Path, mound_render: Path) -> None:
    """The second look (issue 26): a site whose verdict advises it is flown again with a scan
    twice as wide (the same simulated site), reconstructed, densified and judged with
    `verdict --second-look`, which then decides the site; the first verdict stays in the
    row. Photos cannot be flown again: the row says a second card is needed."""
    from mound.survey.site_work import SiteJob, _second_look

    # the built-in dense model asks for no second look (its out-of-fold gain did not hold,
    # docs/verdict.md); a model remade with one (--verdict-model) does
    job = _dense_site_job(tmp_path, {"second_look": {
        "p_low": 0.3, "threshold": 0.8, "scan_factor": 2.0,
        "combine": {"first": 0.7, "second": 0.45, "bias": -0.25}}})
    model_file = Path(str(job.dense_model))
    # what the first flight's verdict left (its p in the band)
    job.tree.verdict.parent.mkdir(parents=True)
    job.tree.verdict.write_text(json.dumps({
        "schema": "mound.verdict", "version": 1, "status": "ok", "look": "first",
        "method": "reference_free_model", "p_mound": 0.6, "label": "no_mound"}))
    first = Verdict("no_mound", "no_mound", "", "first", p_mound=0.6)
    typed = SiteRow("s1", "k", status="ok", verdict=first)
    _second_look(job, typed, SecondLookAdvice(True, 2.0, {"message": "undecided"}), True)
    row = typed.to_doc()
    look = row["second_look"]
    assert look["flown"], look.get("reason")
    assert look["site_diameter_m"] == 2 * job.site_diameter_m
    assert row["first_look"] == {"verdict": "no_mound", "answer": "no_mound",
                                 "verdict_p_mound": 0.6, "reason": "first"}
    v = json.loads((tmp_path / "run" / look["verdict_file"]).read_text())
    assert v["look"] == "second" and v["cloud"].endswith("second/dense/dense.ply")
    assert row["verdict_p_mound"] == v["p_mound"] == look["p_mound"]
    assert row["verdict"] == v["label"]
    assert "second look" in v["reason"] and v["first_look_p_mound"] == 0.6
    assert 0 <= v["model_p_mound"] <= 1
    assert v["model"]["file"] == str(model_file)  # the run's model, not the built-in one
    photos = SiteJob(site=job.site, index=0, run_root=str(tmp_path / "run2"),
                     origin=job.origin, key="k", images_dir=str(tmp_path))
    typed = SiteRow("s1", "k", status="ok", verdict=Verdict("no_mound", "no_mound", ""))
    _second_look(photos, typed, SecondLookAdvice(True, 2.0, {"message": "undecided"}), True)
    row = typed.to_doc()
    assert not row["second_look"]["flown"] and "--second-photos" in row["second_look"]["reason"]
    assert row["verdict"] == "no_mound" and "first_look" not in row
    # The second card (--second-photos): the same wider flight as the aircraft writes it,
    # JPEGs whose EXIF carries the GPS and the focal length (no poses or camera file),
    # sorted into the site's folder: reconstructed from them and judged as the second look.
    from datetime import datetime

    from mound.sim.card import site_jpegs

    shutil.copytree(job.tree.second.sim, tmp_path / "wide")
    site_jpegs(tmp_path / "wide", datetime(2026, 6, 1, 10, 0, 0))
    card = tmp_path / "second_card"
    card.mkdir()
    for f in (tmp_path / "wide" / "images").glob("*.jpg"):
        shutil.copy(f, card / f.name)
    job2 = SiteJob(site=job.site, index=0, run_root=str(tmp_path / "run3"), origin=job.origin,
                   key="k", images_dir=str(tmp_path), second_images_dir=str(card),
                   image_size=(320, 240), threads=2, figures=False, dense=job.dense,
                   dense_model=job.dense_model)
    job2.tree.verdict.parent.mkdir(parents=True)
    shutil.copy(job.tree.verdict, job2.tree.verdict)
    typed = SiteRow("s1", "k", status="ok", verdict=first)
    _second_look(job2, typed, SecondLookAdvice(True, 2.0, {"message": "undecided"}), True)
    row = typed.to_doc()
    look = row["second_look"]
    assert look["flown"] and look["source"] == "photos", look.get("reason")
    recon = json.loads((job2.tree.second.recon / "recon.json").read_text())
    assert recon["inputs"]["gps_source"] == "exif" and recon["status"] == "ok"
    v = json.loads((tmp_path / "run3" / look["verdict_file"]).read_text())
    assert v["look"] == "second" and v["first_look_p_mound"] == 0.6
    assert row["verdict_p_mound"] == v["p_mound"] and row["first_look"]["reason"] == "first"
    # The second card given to a run whose first look is done: the site's key changes, its
    # first look's (first_key) does not, so only the second look is flown; the first
    # look's reconstruction, dense cloud, verdict and files stay as they were.
    from dataclasses import replace

    from mound.survey.site_work import process_site

    job3 = replace(job2, run_root=str(tmp_path / "run4"), key="k2", first_key="f1")
    t3 = job3.tree
    t3.verdict.parent.mkdir(parents=True)
    first = {"schema": "mound.verdict", "version": 1, "status": "ok", "look": "first",
             "method": "reference_free_model", "p_mound": 0.6, "label": "no_mound",
             "reason": "first", "second_look": {"advised": True, "scan_factor": 2.0,
                                                "message": "undecided"}}
    t3.verdict.write_text(json.dumps(first))
    before = {"schema": "mound.survey_site", "version": 1, "id": "s1", "key": "k1",
              "first_key": "f1", "status": "ok", "verdict_cloud": "dense",
              "recon": {"status": "ok", "registered": 25}, "verdict": "mound",
              "verdict_p_mound": 0.9, "second_look": {"flown": True, "p_mound": 0.9},
              "files": {"images": "photos/s1", "recon": "sites/s1/recon",
                        "verdict": "sites/s1/verdict.json"}}
    t3.result.write_text(json.dumps(before))
    row = process_site(job3).to_doc()
    assert row["status"] == "ok" and row["first_look_reused"], row
    assert row["second_look"]["flown"] and row["second_look"]["source"] == "photos"
    assert row["first_look"]["verdict_p_mound"] == 0.6  # the first verdict's, not 0.9
    assert row["verdict_p_mound"] == row["second_look"]["p_mound"] != 0.9
    assert row["recon"] == before["recon"] and row["files"]["recon"] == "sites/s1/recon"
    # the first look was not reconstructed or densified again
    assert not (t3.recon / "recon.json").exists() and not t3.dense.exists()
    assert set(row["timings_s"]) == {"second_look", "total"}
    assert json.loads(t3.result.read_text()) == row and row["key"] == "k2"
    # another first look (another first card, here an empty one): the whole site again
    row = process_site(replace(job3, first_key="f2")).to_doc()
    assert row["status"] == "failed" and row["reason"].startswith("images:")
    assert "first_look_reused" not in row


@pytest.mark.slow
def test_an_undecided_site_is_flown_again_and_what_stays_undecided_goes_to_the_field_team(
        tmp_path: Path) -> None:
    """Issue 56: with a model whose undecided band holds the site's p, the first verdict
    says undecided and advises a second look; the survey flies it (the wider scan,
    simulated), and a second look that cannot decide it (its combination keeps the first
    p) leaves it undecided: the row keeps both answers, the reasons, and the summary lists
    it for the field team beside the counts of decided and undecided sites. The paper's
    two answers (row["verdict"]) stay what the threshold says."""
    from mound.formats.site_row import SiteRow
    from mound.formats.sites import Site, Truth
    from mound.formats.survey import SurveySite
    from mound.formats.verdict import Verdict
    from mound.survey import report
    from mound.survey.site_work import process_site

    job = _dense_site_job(tmp_path, {
        "undecided": {"p_low": 1e-6, "p_high": 1 - 1e-6},
        "second_look": {"p_low": 0.01, "threshold": 0.5, "scan_factor": 2.0,
                        "combine": {"first": 1.0, "second": 1e-6, "bias": 0.0}}})
    row = process_site(job).to_doc()
    assert row["status"] == "ok", row.get("reason")
    first = json.loads(job.tree.verdict.read_text())
    assert first["label"] == "undecided" and first["second_look"]["advised"]
    assert first["undecided"]["next"] == "second_look"
    look = row["second_look"]
    assert look["flown"], look.get("reason")
    assert row["first_look"]["answer"] == "undecided"
    assert row["answer"] == "undecided" and row["undecided"]["next"] == "field_team"
    assert row["undecided"]["reasons"] and all(r["text"] for r in row["undecided"]["reasons"])
    second = json.loads((tmp_path / "run" / look["verdict_file"]).read_text())
    assert row["verdict"] == second["two_answer"]["label"]
    assert row["verdict"] == ("mound" if second["p_mound"] >= 0.5 else "no_mound")
    judged = SiteRow.from_doc(row, "row")
    rows = [SurveySite(Site("s1", 0.0, 0.0, 1.0, p_mound=0.5, truth=Truth(True)), True, judged),
            SurveySite(Site("s2", 9.0, 9.0, 1.0, p_mound=0.2, truth=Truth(False)), True,
                       SiteRow("s2", "k", status="ok",
                               verdict=Verdict("no_mound", "no_mound", "m")))]
    team = [t.to_doc() for t in report.field_team(rows)]
    assert [t["id"] for t in team] == ["s1"] and team[0]["second_look_flown"]
    assert team[0]["why"] and team[0]["reasons"] == [
        r["code"] for r in row["undecided"]["reasons"]]
    m = report.three_answer_metrics(rows).to_doc()
    assert m["decided"] == 1 and m["undecided"] == 1
    assert m["selective"] == {"eps_md": None, "eps_fa": 0.0, "decided_with_truth": 1}


def _dense_site_job(tmp_path: Path, model_fields: dict[str, Any]) -> Any:
    """A simulated survey site judged on its dense cloud by the built-in dense model with
    `model_fields` added (--verdict-model)."""
    from mound.survey.site_work import SiteJob

    model = json.loads((REPO_ROOT / "data" / "verdict_model_dense.json").read_text())
    model.update(model_fields)
    model_file = tmp_path / "model.json"
    model_file.write_text(json.dumps(model))
    return SiteJob(site=Site("s1", 0.0, 0.0, 0.0, truth=Truth(True)),
                   index=0, run_root=str(tmp_path / "run"),
                   origin=Origin(38.57, 27.99, 95.0), key="k",
                   image_size=(320, 240), threads=2, figures=False,
                   dense=DensifyOptions(320, 0.25),
                   dense_model=str(model_file))


def test_a_bug_in_a_site_s_work_ends_the_survey_with_exit_1_not_a_partial_survey(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A site whose work raises an error that is neither bad input nor a tool's failure (a
    bug) keeps the other sites going, leaves its traceback in the site's log.txt, and the
    stage then raises (the survey's main answers exit 1) instead of reporting "partial"."""
    import contextlib

    from mound.survey import cluster, site_work
    from mound.survey.site_work import SiteJob, process_site

    def broken(job: SiteJob, row: dict[str, Any]) -> Any:
        raise ZeroDivisionError("a bug")

    monkeypatch.setattr(site_work, "_simulate", broken)
    job = SiteJob(site=Site("s1", 0.0, 0.0, 0.0, truth=Truth(True)),
                  index=0, run_root=str(tmp_path / "run"),
                  origin=Origin(38.57, 27.99, 95.0), key="k", figures=False)
    row = process_site(job).to_doc()
    assert row["status"] == "failed" and row["internal_error"] is True and row["retry"]
    assert "ZeroDivisionError" in row["reason"]
    log = (tmp_path / "run" / "sites" / "s1" / "log.txt").read_text()
    assert "Traceback" in log and "ZeroDivisionError: a bug" in log

    # the stage: every row is kept (a rerun resumes), then the survey stops as on a bug
    monkeypatch.setattr(cluster, "client_for", lambda *a: contextlib.nullcontext(None))
    monkeypatch.setattr(cluster, "describe", lambda client: "in-process")
    monkeypatch.setattr(cluster, "run_sites", lambda client, jobs, run_id, on_row, progress:
                        [on_row(process_site(j)) for j in jobs])
    args = driver.SurveyOptions.from_namespace(driver.build_parser().parse_args(
        ["--out", str(tmp_path / "run"), "--no-progress"]))
    ctx = Context(args, RunTree(tmp_path / "run"),
                         Ledger(tmp_path / "run" / "stages.json"))
    with pytest.raises(sites3d.SiteBugError, match="s1"):
        sites3d.run_jobs(ctx, [job])
    assert json.loads(job.tree.result.read_text())["internal_error"] is True
