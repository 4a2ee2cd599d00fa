"""Real terrain under the flight (issue 27, part 1), on the 1 m laser DEM of ../shared/data/dem
(1 km², 70 m of relief, EPSG:3794): home in the valley, ten sites on the ridges around it.

Every check of the flown heights samples the DEM independently of the mission code:
rasterio's raw array, pyproj from the mission file's latitudes and longitudes to the DEM's
CRS, and the footprint as a box of raw pixels."""

from __future__ import annotations

import itertools
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rasterio
from pyproj import Transformer
from scipy.ndimage import maximum_filter

from mound import native
from mound.errors import InputError
from mound.flightplan import terrain
from mound.formats.plan import Plan
from mound.formats.site_row import SecondLookRecord, SiteRow
from mound.formats.sites import Sites
from mound.geometry.dem import Dem
from mound.geometry.flight import scan_for_site
from mound.geometry.geodesy import Origin, geodetic_to_enu
from mound.paths import REPO_ROOT
from mound.uav import files as mission_files
from mound.uav import mission, mission_items


def build_mission(plan: dict, *args: Any) -> Any:
    """mission.build of a plan document (the tests keep their plans as dicts)."""
    return mission.build(Plan.from_doc(plan, "test plan"), *args)


TO_LL = Transformer.from_crs("EPSG:3794", "EPSG:4326", always_xy=True)
TO_TM = Transformer.from_crs("EPSG:4326", "EPSG:3794", always_xy=True)
HOME_TM = (564550.0, 146250.0)  # the valley floor, 258 m


def raw_height(raw: tuple[np.ndarray, object], x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Bilinear height at DEM-CRS points, straight from the array."""
    z, tf = raw
    col, row = ~tf @ (np.asarray(x), np.asarray(y))
    col, row = np.asarray(col) - 0.5, np.asarray(row) - 0.5
    c0, r0 = np.floor(col).astype(int), np.floor(row).astype(int)
    fc, fr = col - c0, row - r0
    return ((z[r0, c0] * (1 - fc) + z[r0, c0 + 1] * fc) * (1 - fr)
            + (z[r0 + 1, c0] * (1 - fc) + z[r0 + 1, c0 + 1] * fc) * fr)


def home_origin(raw: tuple[np.ndarray, object]) -> Origin:
    lon, lat = TO_LL.transform(*HOME_TM)
    return Origin(lat, lon, float(raw_height(raw, HOME_TM[0], HOME_TM[1])))


def ridge_sites(raw: tuple[np.ndarray, object], n: int = 10) -> list[tuple[float, float]]:
    """n points of high ground (above 285 m, 27 m over home) spread by farthest-point order
    from the highest one, kept 150 m inside the DEM, in the DEM's CRS (>= 94 m apart)."""
    z, tf = raw
    grid = z[150:-150:10, 150:-150:10]
    rows, cols = np.nonzero(grid > 285)
    xs, ys = tf @ ((cols * 10 + 150 + 0.5), (rows * 10 + 150 + 0.5))
    pts = np.column_stack([xs, ys])
    chosen = [int(np.argmax(grid[rows, cols]))]
    gap = np.linalg.norm(pts - pts[chosen[0]], axis=1)
    while len(chosen) < n:
        k = int(np.argmax(gap))
        chosen.append(k)
        gap = np.minimum(gap, np.linalg.norm(pts - pts[k], axis=1))
    return [(float(pts[k, 0]), float(pts[k, 1])) for k in chosen]


def sites_doc(raw: tuple[np.ndarray, object], budget: float) -> dict:
    origin = home_origin(raw)
    scan = scan_for_site(60.0, "raster")
    sites = []
    for k, (x, y) in enumerate(ridge_sites(raw)):
        lon, lat = TO_LL.transform(x, y)
        e, nn, _ = geodetic_to_enu(origin, np.array([[lat, lon, 0.0]]))[0]
        sites.append({"id": f"r{k:02d}", "x_m": float(e), "y_m": float(nn),
                      "reward": 1.0 + 0.1 * k, "scan_cost_m": scan.site_cost_m()})
    return {"schema": "mound.sites", "version": 1, "origin": origin.to_doc(),
            "home": {"id": "home", "x_m": 0.0, "y_m": 0.0}, "end": {"id": "home"},
            "budget_m": budget, "scan": scan.to_doc(),
            "takeoff_landing_m": scan.takeoff_landing_m(), "sites": sites}


def attach(doc: dict, *args: object) -> dict:
    """terrain.attach on a sites document (the tests keep theirs as dicts)."""
    return terrain.attach(Sites.from_doc(doc, "test sites"), *args).to_doc()  # type: ignore[arg-type]


def typed(doc: dict) -> Sites:
    return Sites.from_doc(doc, "test sites")


def plan(doc: dict, tmp: Path, name: str, *args: str) -> dict:
    path = tmp / f"{name}.json"
    path.write_text(json.dumps(doc))
    return native.run_json("mound_plan", [str(path), *args])


def flown_points(mission_path: Path) -> tuple[np.ndarray, float]:
    """The navigation items of a mission file as DEM-CRS x, y and AMSL z (home's AMSL from
    the file), in flight order, starting on the ground at home."""
    items, home, _ = mission_files.read_mission(mission_path)
    pts = [(*TO_TM.transform(home.lon_deg, home.lat_deg), home.alt_m)]
    for it in items:
        if it.command in mission_items.NAV_COMMANDS:
            x, y = TO_TM.transform(it.lon_deg, it.lat_deg)
            pts.append((x, y, it.z + home.alt_m))
    return np.array(pts), home.alt_m


def clearance_along(raw: tuple[np.ndarray, object], a: np.ndarray, b: np.ndarray,
                    footprint_m: float, highest: np.ndarray) -> float:
    """Lowest height above the highest terrain within the footprint (a box of raw pixels)
    along the segment a -> b sampled every 0.25 m."""
    _, tf = raw
    n = max(2, int(np.hypot(*(b[:2] - a[:2])) / 0.25) + 2)
    t = np.linspace(0, 1, n)
    p = a[None] + (b - a)[None] * t[:, None]
    col, row = ~tf @ (p[:, 0], p[:, 1])
    col = np.floor(np.asarray(col)).astype(int)
    row = np.floor(np.asarray(row)).astype(int)
    return float(np.min(p[:, 2] - highest[row, col]))


def energy_and_clearance(raw: tuple[np.ndarray, object], mission_file: Path, spec: Any,
                         highest: np.ndarray) -> tuple[float, float]:
    """A mission file's energy (horizontal metres plus the climb and descent factors times
    the metres climbed and descended, home to home), recomputed from its items, and the
    lowest clearance of its level legs over the highest terrain within the footprint."""
    pts, _ = flown_points(mission_file)
    pts = np.vstack([pts, pts[:1]])
    d = np.diff(pts, axis=0)
    energy = float(np.hypot(d[:, 0], d[:, 1]).sum()
                   + spec.climb_factor * np.clip(d[:, 2], 0, None).sum()
                   + spec.descent_factor * np.clip(-d[:, 2], 0, None).sum())
    level = [(a, b) for a, b in itertools.pairwise(pts[1:-1])
             if np.hypot(*(b[:2] - a[:2])) >= 0.5]
    return energy, min(clearance_along(raw, a, b, spec.footprint_m, highest)
                       for a, b in level)


@pytest.fixture(scope="module")
def flown(raw, dem_path, tmp_path_factory) -> dict:
    """Sites with the terrain attached, the plan (mound_plan, default ALNS), the mission
    built over the DEM and written as a .plan file."""
    tmp = tmp_path_factory.mktemp("terrain")
    doc = sites_doc(raw, 5000.0)
    spec = terrain.ClearanceSpec()
    with_terrain = attach(doc, str(dem_path), spec, "egm96",
                                  Origin.from_doc(doc["origin"]))
    p = plan(with_terrain, tmp, "sites_dem")
    m = build_mission(p, Origin.from_doc(doc["origin"]), None,
                            mission_items.TerrainInput(str(dem_path), "egm96", spec))
    out = tmp / "mission.plan"
    mission_files.write_plan(out, m)
    return {"doc": doc, "terrain_doc": with_terrain, "plan": p, "mission": m, "file": out,
            "spec": spec, "tmp": tmp}


def test_dem_heights_match_the_raw_array(raw, dem_path) -> None:
    origin = home_origin(raw)
    dem = Dem.open(str(dem_path), origin, "egm96")
    rng = np.random.default_rng(0)
    tm = np.column_stack([rng.uniform(564010, 564990, 50), rng.uniform(146010, 146990, 50)])
    lon, lat = TO_LL.transform(tm[:, 0], tm[:, 1])
    enu = geodetic_to_enu(origin, np.column_stack([lat, lon, np.zeros(50)]))
    # PROJ takes the file's WKT one way and EPSG:3794 the other: millimetres apart.
    assert np.allclose(dem.height(enu[:, :2]), raw_height(raw, tm[:, 0], tm[:, 1]), atol=0.02)
    assert dem.pixel_m == pytest.approx((1.0, 1.0), abs=1e-3)


def test_dem_refusals(raw, dem_path, tmp_path) -> None:
    origin = home_origin(raw)
    with pytest.raises(InputError, match="--dem-vertical"):
        Dem.open(str(dem_path), origin)  # the file states no vertical datum
    # EGM2008's grid is not installed (Debian's proj-data has EGM96's only): refused, never
    # a zero geoid height
    with pytest.raises(InputError, match="geoid grid.*egm08.*projsync"):
        Dem.open(str(dem_path), origin, "egm2008")
    dem = Dem.open(str(dem_path), origin, "egm96")
    with pytest.raises(InputError, match="off the DEM"):
        dem.height(np.array([[5000.0, 0.0]]))
    with rasterio.open(dem_path) as ds:
        profile = ds.profile
        z = ds.read(1)
    two = tmp_path / "two.tif"
    with rasterio.open(two, "w", **{**profile, "count": 2}) as ds:
        ds.write(np.stack([z, z]))
    with pytest.raises(InputError, match="one band"):
        Dem.open(str(two), origin, "egm96")
    holes = tmp_path / "holes.tif"
    z2 = z.copy()
    z2[700:760, 520:580] = -9999  # around home
    with rasterio.open(holes, "w", **{**profile, "nodata": -9999}) as ds:
        ds.write(z2, 1)
    with pytest.raises(InputError, match="nodata"):
        Dem.open(str(holes), origin, "egm96").height(np.array([[0.0, 0.0]]))
    (tmp_path / "junk.tif").write_bytes(b"II*\x00junk")
    with pytest.raises(InputError, match="not a readable DEM"):
        Dem.open(str(tmp_path / "junk.tif"), origin, "egm96")


def test_every_leg_clears_the_terrain_by_the_clearance(flown, raw) -> None:
    spec = flown["spec"]
    m = flown["mission"]
    pts, home_amsl = flown_points(flown["file"])
    assert home_amsl == pytest.approx(float(raw_height(raw, *HOME_TM)), abs=0.01)
    fp = int(np.ceil(spec.footprint_m))
    highest = maximum_filter(raw[0], size=2 * fp + 1, mode="nearest")
    centres = []
    for s in m.sites:
        lat, lon, _ = mission_items.enu_to_geodetic(m.origin, np.array([[s.x_m, s.y_m,
                                                                         0.0]]))[0]
        centres.append(TO_TM.transform(float(lon), float(lat)))
    centres = np.array(centres)

    def site_of(p: np.ndarray) -> int:
        d = np.hypot(centres[:, 0] - p[0], centres[:, 1] - p[1])
        return int(np.argmin(d)) if d.min() <= 47 else -1  # scans reach 46 m

    n_transit = 0
    worst_transit = worst_scan = np.inf
    for a, b in itertools.pairwise(pts):
        if np.hypot(*(b[:2] - a[:2])) < 0.5:
            continue  # climbs and descents in place (checked as the ends of level legs)
        gap = clearance_along(raw, a, b, spec.footprint_m, highest)
        if site_of(a) >= 0 and site_of(a) == site_of(b):  # within one site's scan
            worst_scan = min(worst_scan, gap)
        else:  # between sites, or from or to home
            n_transit += 1
            worst_transit = min(worst_transit, gap)
    assert n_transit == len(m.terrain.legs) == len(m.sites) + 1
    # float32 altitudes on the link: a few centimetres
    print(f"[terrain] {len(m.sites)} ridge sites: lowest transit clearance {worst_transit:.2f} m "
          f"(asked {spec.clearance_m:g}), lowest scan clearance {worst_scan:.2f} m "
          f"(asked {spec.scan_clearance_m:g}), energy {m.terrain.energy_m:.0f} m, plan cost "
          f"{flown['plan']['cost_m']:.0f} m, budget {flown['plan']['budget_m']:.0f} m, climbed "
          f"{m.terrain.climbed_m:.0f} m")
    assert worst_transit >= spec.clearance_m - 0.05
    assert worst_scan >= spec.scan_clearance_m - 0.05
    assert min(leg.clearance_m for leg in m.terrain.legs) >= spec.clearance_m - 1e-9


def test_scan_heights_above_each_sites_ground(flown, raw) -> None:
    m = flown["mission"]
    origin = m.origin
    scan = m.spec.scan
    want = float(scan.legs()[0].points_enu[0, 2])
    # The scan waypoints: the navigation items while the camera triggers.
    items, home, _ = mission_files.read_mission(flown["file"])
    scans: list[list[tuple[float, float, float]]] = []
    on = False
    for it in items:
        if it.command == mission_items.DO_SET_CAM_TRIGG_DIST:
            on = it.params[0] > 0
            if on:
                scans.append([])
        elif on and it.command in mission_items.NAV_COMMANDS:
            scans[-1].append((*TO_TM.transform(it.lon_deg, it.lat_deg), it.z + home.alt_m))
    assert len(scans) == len(m.sites)
    worst = 0.0
    for s, pts in zip(m.sites, scans, strict=True):
        # The site's ground independently: the median of the ring D/2..D, on a polar grid.
        lat, lon, _ = mission_items.enu_to_geodetic(origin, np.array([[s.x_m, s.y_m,
                                                                       0.0]]))[0]
        cx, cy = TO_TM.transform(float(lon), float(lat))
        r, a = np.meshgrid(np.linspace(30, 60, 31), np.linspace(0, 2 * np.pi, 360,
                                                                 endpoint=False))
        ground = float(np.median(raw_height(raw, cx + r * np.cos(a), cy + r * np.sin(a))))
        p = np.array(pts)
        assert np.all(np.hypot(p[:, 0] - cx, p[:, 1] - cy) <= 47), s.id
        assert np.all(np.abs(p[:, 2] - (ground + want)) <= 1.0), (s.id, p[:, 2] - ground)
        worst = max(worst, float(np.abs(p[:, 2] - (ground + want)).max()))
    print(f"[terrain] scan heights above each site's own ground: largest error {worst:.3f} m")


def test_climbs_are_counted_and_the_flight_fits_the_plan(flown, raw) -> None:
    spec = flown["spec"]
    m = flown["mission"]
    p = flown["plan"]
    pts, _ = flown_points(flown["file"])
    pts = np.vstack([pts, pts[:1]])  # lands at home (NAV_LAND's own point is on the ground)
    d = np.diff(pts, axis=0)
    horizontal = float(np.hypot(d[:, 0], d[:, 1]).sum())
    up = float(np.clip(d[:, 2], 0, None).sum())
    down = float(np.clip(-d[:, 2], 0, None).sum())
    energy = horizontal + spec.climb_factor * up + spec.descent_factor * down
    assert up > 50  # the ridges are climbed
    assert energy == pytest.approx(m.terrain.energy_m, rel=1e-3)
    assert energy <= p["cost_m"] + 0.5 <= p["budget_m"] + 0.5
    # The plan's cost, recomputed from the sites document: planar + scans + the climbs.
    doc = flown["terrain_doc"]
    ids = [n["id"] for n in doc["terrain"]["nodes"]]
    xy = {"home": (0.0, 0.0), **{s["id"]: (s["x_m"], s["y_m"]) for s in doc["sites"]}}
    scan_cost = {"home": 0.0, **{s["id"]: s["scan_cost_m"] for s in doc["sites"]}}
    extra = np.array(doc["terrain"]["extra_m"])
    cost = 0.0
    for a, b in zip(p["tour"][:-1], p["tour"][1:], strict=True):
        cost += (np.hypot(xy[a][0] - xy[b][0], xy[a][1] - xy[b][1])
                 + (scan_cost[a] + scan_cost[b]) / 2 + extra[ids.index(a), ids.index(b)])
    assert cost == pytest.approx(p["cost_m"], abs=1e-3)
    assert m.items[-1].command == mission_items.NAV_LAND  # no RTL at an unknown height


def flat_clearance(doc: dict, raw, tmp_path: Path, name: str) -> tuple[float, list]:
    """Lowest height over the ground of the mission planned and flown as before (heights
    above home, home in the valley), and its items."""
    p = plan(doc, tmp_path, name)
    m = build_mission(p, Origin.from_doc(doc["origin"]))
    assert m.summary().terrain_doc()["checked"] is False
    out = tmp_path / f"{name}.plan"
    mission_files.write_plan(out, m)
    items, home, _ = mission_files.read_mission(out)
    pts, _ = flown_points(out)
    pts[:, 2] += float(raw_height(raw, *HOME_TM)) - home.alt_m  # as flown from the valley
    flown_part = pts[1:-1]  # from the take-off height to the last waypoint (then RTL)
    worst = min(clearance_along(raw, a, b, 0, raw[0])
                for a, b in itertools.pairwise(flown_part))
    return worst, items


def test_todays_mission_without_the_dem_flies_into_the_ridges(flown, raw, tmp_path) -> None:
    """The same sites planned and flown as before (heights above home): at the default
    60 m the raster passes a few metres over the highest site, far inside the clearance;
    at 40 m (a sharper scan) it flies into the ridge. It says the terrain was not checked."""
    worst, items = flat_clearance(flown["doc"], raw, tmp_path, "flat60")
    assert 0 < worst < 10, worst
    assert items[-1].command == mission_items.NAV_RETURN_TO_LAUNCH
    low = {**flown["doc"], "scan": scan_for_site(60.0, "raster", 40.0).to_doc()}
    worst40, _ = flat_clearance(low, raw, tmp_path, "flat40")
    print(f"[terrain] without the DEM: lowest height over the ground {worst:.1f} m (scan at "
          f"60 m above home), {worst40:.1f} m (at 40 m)")
    assert worst40 < -10, worst40


@pytest.mark.slow
def test_a_plan_through_the_ridges_without_the_terrain_is_refused(flown, dem_path,
                                                                 tmp_path) -> None:
    """Planned without the DEM to the last metre of its budget: over the DEM, with a
    clearance of 120 m (a ridge the aircraft must climb far above), its climbs do not fit,
    and the mission is refused naming the leg and the terrain point; nothing is written."""
    doc = dict(flown["doc"])
    flat = plan(doc, tmp_path, "flat")
    doc["budget_m"] = flat["cost_m"] + 1.0
    tight = plan(doc, tmp_path, "tight")
    with pytest.raises(InputError, match=r"leg \S+ -> \S+ climbs to .* terrain at ENU"):
        build_mission(tight, Origin.from_doc(doc["origin"]), None,
                            mission_items.TerrainInput(str(dem_path), "egm96",
                                                       terrain.ClearanceSpec(clearance_m=120)))
    plan_file = tmp_path / "tight_plan.json"
    plan_file.write_text(json.dumps(tight))
    out = tmp_path / "m.plan"
    r = subprocess.run([sys.executable, "-m", "mound", "mission", "build", str(plan_file),
                        "--out", str(out), "--dem", str(dem_path), "--dem-vertical", "egm96",
                        "--clearance-m", "120"],
                       capture_output=True, text=True, cwd=REPO_ROOT, check=False)
    assert r.returncode == 2, r.stderr
    assert "terrain at ENU" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert not out.exists()


def test_zero_climbs_leave_the_plan_unchanged(flown, tmp_path) -> None:
    doc = flown["doc"]
    base = plan(doc, tmp_path, "base")
    nodes, _ = terrain.sites_nodes(typed(doc))
    flat = {**doc, "terrain": {"version": 1, "nodes": [{"id": n.id} for n in nodes],
                               "extra_m": np.zeros((len(nodes), len(nodes))).tolist()}}
    same = plan(flat, tmp_path, "zero")
    assert same["tour"] == base["tour"] and same["cost_m"] == pytest.approx(base["cost_m"])


def test_scan_too_close_to_the_ground_is_refused(flown, dem_path) -> None:
    doc = flown["doc"]
    low = {**doc, "scan": scan_for_site(60.0, "raster", 8.0).to_doc()}
    with pytest.raises(InputError, match=r"site r\d\d: its scan .* scan clearance"):
        attach(low, str(dem_path), terrain.ClearanceSpec(), "egm96",
                       Origin.from_doc(doc["origin"]))


def test_the_simulator_flies_the_missions_heights_over_the_same_terrain(flown, raw,
                                                                       dem_path) -> None:
    """A visited site on a slope, as the survey simulates it: the DEM patch around it with
    z = 0 at the mission's ground of the site, so the scan (the same ScanSpec, heights above
    z = 0) is at the mission's heights; the patch is the DEM's own relief."""
    from mound.geometry.dem import lonlat_to_crs
    from mound.sim import terrain as sim_terrain

    m = flown["mission"]
    nodes = {n["id"]: n for n in flown["terrain_doc"]["terrain"]["nodes"]}
    # the most sloped visited site: the largest spread of the ring's heights
    slope = {}
    for s in m.sites:
        lat, lon, _ = mission_items.enu_to_geodetic(m.origin, np.array([[s.x_m, s.y_m,
                                                                         0.0]]))[0]
        x, y = lonlat_to_crs(str(dem_path), float(lon), float(lat))
        a = np.linspace(0, 2 * np.pi, 72, endpoint=False)
        ring = raw_height(raw, x + 45 * np.cos(a), y + 45 * np.sin(a))
        slope[s.id] = (float(ring.max() - ring.min()), x, y, s)
    spread, x, y, s = max(slope.values(), key=lambda v: v[0])
    assert spread > 5  # a site on a slope
    g = nodes[s.id]["ground_amsl_m"]
    assert g == pytest.approx(s.ground_amsl_m)
    spec = sim_terrain.preset("bin_tepe", mound=False, size_m=160.0, dem_path=str(dem_path),
                              dem_x_m=x, dem_y_m=y, dem_ground_m=g, dem_vertical="egm96")
    hf = sim_terrain.build(spec)
    xs = np.array([30.0, -41.0, 12.0])
    ys = np.array([-22.0, 17.0, 50.0])
    assert np.allclose(hf.height_at(xs, ys), raw_height(raw, x + xs, y + ys) - g, atol=0.05)
    want = [float(leg.points_enu[0, 2]) for leg in m.spec.scan.legs()]
    assert list(s.scan_height_above_ground_m or ()) == want  # the mission flies these above g
    for p in np.vstack([leg.points_enu for leg in m.spec.scan.legs()]):
        assert p[2] - float(hf.height_at(np.array([p[0]]), np.array([p[1]]))[0]) >= 10


@pytest.mark.slow
def test_three_flights_each_clear_of_the_terrain_and_under_budget(flown, raw, dem_path,
                                                                 tmp_path) -> None:
    """mound_plan --flights 3 over the ridge sites, then mound mission build: one mission
    file per flight, each within the budget (energy by an independent recomputation),
    clear of the terrain by the clearance, no site in two flights; --flight picks one."""
    doc = {**flown["terrain_doc"], "budget_m": 2500.0}
    path = tmp_path / "sites3.json"
    path.write_text(json.dumps(doc))
    plan_file = tmp_path / "plan3.json"
    native.run_tool("mound_plan", [str(path), "--flights", "3", "--out", str(plan_file)])
    p = json.loads(plan_file.read_text())
    flights = [f for f in p["flights"] if len(f["tour"]) > 2]
    assert len(flights) == 3
    out = tmp_path / "m.plan"
    r = subprocess.run([sys.executable, "-m", "mound", "mission", "build", str(plan_file),
                        "--out", str(out), "--dem", str(dem_path), "--dem-vertical", "egm96"],
                       capture_output=True, text=True, cwd=REPO_ROOT, check=False)
    assert r.returncode == 0, r.stderr
    spec = flown["spec"]
    fp = int(np.ceil(spec.footprint_m))
    highest = maximum_filter(raw[0], size=2 * fp + 1, mode="nearest")
    seen: set[str] = set()
    for f in flights:
        energy, clearance = energy_and_clearance(raw, tmp_path / f"m_{f['flight']}.plan",
                                                 spec, highest)
        assert energy <= f["cost_m"] + 0.5 <= p["budget_m"] + 0.5
        assert clearance >= spec.scan_clearance_m - 0.05
        ids = set(f["tour"][1:-1])
        assert not ids & seen
        seen |= ids
    assert p["flights"][0]["reward"] >= p["flights"][1]["reward"] >= p["flights"][2]["reward"]
    one = tmp_path / "only2.plan"
    r = subprocess.run([sys.executable, "-m", "mound", "mission", "build", str(plan_file),
                        "--out", str(one), "--flight", "2", "--dem", str(dem_path),
                        "--dem-vertical", "egm96"],
                       capture_output=True, text=True, cwd=REPO_ROOT, check=False)
    assert r.returncode == 0 and one.exists() and not (tmp_path / "only2_2.plan").exists()


def test_a_dem_in_geographic_coordinates_reads_alike(raw, dem_path, tmp_path) -> None:
    """Any CRS: the laser DEM warped to WGS84 longitude/latitude (degrees, EPSG:4326) gives
    the same heights at the same places (within the resampling), and the same ground and
    corridor maxima to a metre; PROJ takes the points there from the file's CRS."""
    from rasterio.warp import Resampling, calculate_default_transform, reproject

    with rasterio.open(dem_path) as src:
        tf, w, h = calculate_default_transform(src.crs, "EPSG:4326", src.width, src.height,
                                               *src.bounds)
        profile = {**src.profile, "crs": "EPSG:4326", "transform": tf, "width": w, "height": h,
                   "nodata": -9999.0}
        geo = tmp_path / "dem_wgs84.tif"
        with rasterio.open(geo, "w", **profile) as dst:
            reproject(rasterio.band(src, 1), rasterio.band(dst, 1), src_transform=src.transform,
                      src_crs=src.crs, dst_transform=tf, dst_crs="EPSG:4326",
                      resampling=Resampling.bilinear, dst_nodata=-9999.0)
    origin = home_origin(raw)
    a = Dem.open(str(dem_path), origin, "egm96")
    b = Dem.open(str(geo), origin, "egm96")
    assert b.crs_name.startswith("WGS 84") and 0.5 < b.pixel_m[0] < 1.5
    rng = np.random.default_rng(3)
    xy = np.column_stack([rng.uniform(-400, 350, 40), rng.uniform(-150, 600, 40)])
    assert np.abs(a.height(xy) - b.height(xy)).max() < 1.0
    ends = xy[:10], xy[10:20]
    ta, _ = a.corridor_max(*ends, 10.0)
    tb, _ = b.corridor_max(*ends, 10.0)
    assert np.abs(ta - tb).max() < 1.5
    from mound.flightplan.terrain import site_grounds

    ids = [f"p{k}" for k in range(5)]
    assert np.abs(site_grounds(a, xy[:5], 60.0, ids) - site_grounds(b, xy[:5], 60.0, ids)
                  ).max() < 0.5


def test_plan_wpl_and_geojson_carry_the_same_altitudes(flown, tmp_path) -> None:
    """The .plan, the WPL file and the GeoJSON path: the same heights above home's ground
    (the GeoJSON's within the Earth's curvature over the flight, a few centimetres), and
    home's AMSL height in the .plan's and the WPL's home."""
    m = flown["mission"]
    mission_files.write_wpl(tmp_path / "m.waypoints", m)
    items_plan, home_plan, _ = mission_files.read_mission(flown["file"])
    items_wpl, home_wpl, _ = mission_files.read_mission(tmp_path / "m.waypoints")
    nav = [it for it in items_plan if it.command in mission_items.NAV_COMMANDS]
    assert [it.z for it in items_plan] == [it.z for it in items_wpl]
    assert home_plan.alt_m == pytest.approx(m.terrain.home_amsl_m, abs=1e-3)
    assert home_wpl.alt_m == pytest.approx(m.terrain.home_amsl_m, abs=1e-3)
    doc = mission_files.geojson_document(m)
    path = next(f for f in doc["features"] if f["properties"]["kind"] == "flight_path")
    z = np.array([c[2] for c in path["geometry"]["coordinates"]])
    # the path: the ground at home, then every navigation item (NAV_LAND's own point is on
    # the ground at home, as the item's z = 0 says)
    assert np.abs(z[1:] - np.array([it.z for it in nav])).max() < 0.15
    assert path["properties"]["altitude"] == "metres above home's ground"
    profiles = [f for f in doc["features"] if f["properties"]["kind"] == "leg_profile"]
    assert len(profiles) == len(m.terrain.legs)
    for f in profiles:
        pr = f["properties"]
        assert len(pr["distance_m"]) == len(pr["terrain_amsl_m"])
        assert pr["flight_amsl_m"] - max(pr["terrain_amsl_m"]) >= flown["spec"].clearance_m - 0.5


@pytest.mark.slow
def test_mound_field_make_with_a_dem(raw, dem_path, tmp_path) -> None:
    """`mound field make --dem` (the paper's field placed on the DEM): the sites document
    carries the terrain, mound_plan reads it, and a field off the DEM is refused naming the
    site."""
    from mound.cli import main as mound_main

    origin = home_origin(raw)
    out = tmp_path / "sites.json"
    args = ["field", "make", "--seed", "0", "--spacing", "30", "--scan-pattern", "raster",
            "--origin", f"{origin.lat_deg},{origin.lon_deg}", "--dem", str(dem_path),
            "--dem-vertical", "egm96", "--budget", "3000", "--out", str(out)]
    assert mound_main(args) == 0
    doc = json.loads(out.read_text())
    t = doc["terrain"]
    assert len(t["extra_m"]) == len(doc["sites"]) + 1 and t["vertical"] == "egm96"
    assert doc["takeoff_landing_m"] == 0 and doc["sites"][0]["scan_cost_m"] == t["scan_energy_m"]
    plan_doc = native.run_json("mound_plan", [str(out)])
    assert plan_doc["terrain"]["clearance_m"] == 30 and plan_doc["n_visited"] > 0
    far = [*args[:-1], str(tmp_path / "far.json")]
    far[far.index("--spacing") + 1] = "200"
    assert mound_main(far) == 2
    assert not (tmp_path / "far.json").exists()


@pytest.mark.parametrize("pattern", ["orbit", "both"])
def test_orbit_scans_over_the_terrain(raw, dem_path, tmp_path, pattern: str) -> None:
    """The other scan patterns over the ridges: the flight within the plan's cost, the
    transit legs clear, and the orbit's camera target (DO_SET_ROI_LOCATION) at the site's
    own ground plus the target height, relative to home's ground."""
    doc = sites_doc(raw, 6000.0)
    scan = scan_for_site(60.0, pattern)
    doc["scan"] = scan.to_doc()
    origin = Origin.from_doc(doc["origin"])
    t = attach(doc, str(dem_path), terrain.ClearanceSpec(), "egm96", origin)
    p = plan(t, tmp_path, pattern)
    m = build_mission(p, origin, None,
                            mission_items.TerrainInput(str(dem_path), "egm96"))
    assert m.terrain.energy_m <= p["cost_m"] + 1e-6 <= p["budget_m"] + 1e-6
    assert m.terrain.lowest_clearance_m >= 30 - 1e-9
    rois = [it for it in m.items if it.command == mission_items.DO_SET_ROI_LOCATION]
    assert len(rois) == len(m.sites)
    home = m.terrain.home_amsl_m
    for it, s in zip(rois, m.sites, strict=True):
        assert it.z == pytest.approx(s.ground_amsl_m + scan.target_height_m - home, abs=0.01)


def test_a_plan_made_over_a_dem_is_not_flown_without_it(flown) -> None:
    """Safety: a plan whose costs came from a DEM is refused without --dem (its mission
    would fly heights above home, the terrain unchecked)."""
    with pytest.raises(InputError, match="plan.terrain: .*build its mission with --dem"):
        build_mission(flown["plan"], Origin.from_doc(flown["doc"]["origin"]))


def test_second_looks_are_flown_wider_within_the_budget_and_clear_of_the_terrain(
        flown, raw, dem_path, tmp_path) -> None:
    """The second look's missions (issue 26): the sites a verdict left undecided, flown again
    with a scan twice as wide over the DEM, in the tour's order, as many flights as the
    budget needs; each flight within the budget (its energy recomputed from the written
    file) and clear of the terrain; a budget no wide scan fits refuses every site, naming
    why, and flies nothing lower."""
    from mound.uav.second_look import advised_sites, second_look_flights

    p, spec = flown["plan"], flown["spec"]
    tour = list(p["tour"][1:-1])
    chosen = tour[::2][:4]
    rows = [SiteRow(s, "k", second_look=SecondLookRecord(s in chosen, 2.0)) for s in tour]
    ids, factor = advised_sites(rows)
    assert sorted(ids) == sorted(chosen) and factor == 2.0
    with pytest.raises(InputError, match="r00.second_look.scan_factor"):
        advised_sites([SiteRow("r00", "k", second_look=SecondLookRecord(True, 0.5))])
    row = {**SiteRow("r00", "k").to_doc(), "second_look": {"advised": True, "scan_factor": "2"}}
    with pytest.raises(InputError, match=r"r.json: second_look.scan_factor: expected a number"):
        SiteRow.from_doc(row, "r.json")
    dem = mission_items.TerrainInput(str(dem_path), "egm96", spec)
    fp = int(np.ceil(spec.footprint_m))
    highest = maximum_filter(raw[0], size=2 * fp + 1, mode="nearest")
    for budget in (5000.0, 2500.0):
        doc = {**flown["terrain_doc"], "budget_m": budget}
        flights, refused, wide = second_look_flights(typed(doc), Plan.from_doc(p, "p"), ids,
                                                     factor, dem)
        assert wide.scan.site_diameter_m == 2 * Plan.from_doc(p, "p").scan().site_diameter_m  # type: ignore[union-attr]
        flown_ids = [s.id for m in flights for s in m.sites]
        assert sorted(flown_ids + [r.id for r in refused]) == sorted(chosen)
        assert flown_ids == [s for s in tour if s in flown_ids]  # the tour's order
        for k, m in enumerate(flights):
            assert m.spec.scan.site_diameter_m == wide.scan.site_diameter_m
            out = tmp_path / f"second_{budget:.0f}_{k}.plan"
            mission_files.write_plan(out, m)
            energy, clearance = energy_and_clearance(raw, out, spec, highest)
            assert energy <= budget + 0.5
            assert clearance >= spec.scan_clearance_m - 0.05
        print(f"[second look] budget {budget:.0f} m: {len(flights)} flights "
              f"{[[s.id for s in m.sites] for m in flights]}, energy "
              f"{[round(m.terrain.energy_m) for m in flights]} m, refused "
              f"{[r.id for r in refused]}")
        if budget == 5000.0:  # all four in one flight
            assert not refused and len(flights) == 1
        else:  # a tighter budget: a flight per site, the farthest alone over it
            assert len(flights) > 1 and all("budget" in r.reason for r in refused)
    doc = {**flown["terrain_doc"], "budget_m": 600.0}
    flights, refused, _ = second_look_flights(typed(doc), Plan.from_doc(p, "p"), ids, factor,
                                              dem)
    assert not flights and [r.id for r in refused] == [s for s in tour if s in chosen]
    assert all("budget" in r.reason and "never flown lower" in r.reason for r in refused)
    with pytest.raises(InputError, match="site 'nowhere' is not in the sites document"):
        second_look_flights(typed(doc), Plan.from_doc(p, "p"), [*ids, "nowhere"], factor,
                            dem)
