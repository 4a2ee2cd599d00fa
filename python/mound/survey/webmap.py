"""The survey on a map and each site in 3-D, offline: `DIR/map.html` with Leaflet and
`DIR/site3d.html#ID` with three.js (both from npm at set-up, shipped beside the pages in
`DIR/map/`). The map is in WGS84. Candidate sites coloured by p(mound), one path per
flight, home, each visited site's verdict, and its orthophoto and local relief model as
image overlays where they lie (the GeoTIFFs reprojected to WGS84 with rasterio). A click
on a site opens its card. No tiles: the overlays are the basemap (`basemap` adds a tile
layer for users with a tile server).

Everything the page shows is in `DIR/map/survey.js` (a script, not a fetched JSON file:
browsers block fetch() on file://). The page checks itself after loading and writes what
it drew into data attributes of <body> (markers, paths, overlay bounds, errors), which the
tests read from headless Chromium."""

from __future__ import annotations

import json
import shutil
from collections.abc import Mapping
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from mound.errors import InputError
from mound.formats.learn import LearnRecord
from mound.formats.plan import Flight, Plan
from mound.formats.recon import Recon
from mound.formats.sites import Sites
from mound.formats.survey import SurveySite, SurveySummary
from mound.formats.verdict import Measurements, Rise, VerdictFile
from mound.geometry.geodesy import Origin, enu_to_geodetic
from mound.jsonio import JsonObject, JsonValue, load_json, write_atomic
from mound.paths import REPO_ROOT
from mound.survey.tree import RunTree

NODE_MODULES = REPO_ROOT / "tools" / "web" / "node_modules"
LEAFLET_DIR = NODE_MODULES / "leaflet" / "dist"
THREE_JS = NODE_MODULES / "three" / "build" / "three.min.js"
OVERLAY_MAX_PX = 1024  # the longer side of an overlay image
MAX_VIEW_POINTS = 100_000  # the 3-D viewer's cloud, decimated to at most this many points
FRUSTUM_DEPTH_M = 4.0  # how far the cameras' frustums reach in the viewer


def web_libraries_available() -> bool:
    """Leaflet and three.js installed (tools/setup.sh, npm ci in tools/web)."""
    return (LEAFLET_DIR / "leaflet.js").is_file() and THREE_JS.is_file()


def _lat_lon(origin: Origin, x: float, y: float) -> tuple[float, float]:
    llh = enu_to_geodetic(origin, np.array([[x, y, 0.0]]))[0]
    return float(llh[0]), float(llh[1])


def overlay_png(tif: Path, out_png: Path, kind: str) -> list[list[float]] | None:
    """The GeoTIFF reprojected to WGS84 (EPSG:4326) as a PNG with transparency, and its
    bounds [[south, west], [north, east]]; None when the file is missing or has no CRS.
    kind: "rgb" (an orthophoto, its alpha band kept), "relief" (a single band, coloured
    blue-white-red over ±its 98th absolute percentile) or "prob" (p(mound) of a scene,
    the map's colour ramp, more opaque where higher)."""
    import rasterio
    from PIL import Image
    from rasterio.warp import Resampling, calculate_default_transform, reproject

    if not tif.is_file():
        return None
    with rasterio.open(tif) as src:
        if src.crs is None:
            return None
        dst_crs = "EPSG:4326"
        transform, w, h = calculate_default_transform(src.crs, dst_crs, src.width, src.height,
                                                      *src.bounds)
        scale = max(1.0, max(w, h) / OVERLAY_MAX_PX)
        w, h = max(1, int(round(w / scale))), max(1, int(round(h / scale)))
        transform, w, h = calculate_default_transform(src.crs, dst_crs, src.width, src.height,
                                                      *src.bounds, dst_width=w, dst_height=h)
        bands = src.count if kind == "rgb" else 1
        data = np.zeros((bands, h, w), dtype=np.float32)
        nodata = src.nodata
        for b in range(bands):
            reproject(source=rasterio.band(src, b + 1), destination=data[b],
                      src_transform=src.transform, src_crs=src.crs, dst_transform=transform,
                      dst_crs=dst_crs, resampling=Resampling.bilinear,
                      src_nodata=nodata, dst_nodata=np.nan)
    if kind == "prob":  # p(mound) 0..1: the map's ramp, transparent where low or nodata
        z = data[0]
        ok = np.isfinite(z)
        t = np.clip(np.nan_to_num(z), 0, 1)
        ramp = np.array([[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98],
                         [253, 231, 37]], float)
        k = t * (len(ramp) - 1)
        lo = np.floor(k).astype(int).clip(0, len(ramp) - 2)
        f = (k - lo)[..., None]
        rgb = (ramp[lo] * (1 - f) + ramp[lo + 1] * f).round().astype(np.uint8)
        alpha = np.where(ok, (60 + 170 * t).round(), 0).astype(np.uint8)
        rgba = np.dstack([rgb, alpha])
    elif kind == "rgb":
        rgb = np.nan_to_num(data[:3]).clip(0, 255).astype(np.uint8).transpose(1, 2, 0)
        if bands >= 4:
            alpha = np.nan_to_num(data[3]).clip(0, 255).astype(np.uint8)
        else:
            alpha = np.where(np.isnan(data[0]), 0, 255).astype(np.uint8)
        rgba = np.dstack([rgb, alpha])
    else:
        z = data[0]
        ok = np.isfinite(z)
        span = float(np.percentile(np.abs(z[ok]), 98)) if ok.any() else 1.0
        t = np.clip(np.nan_to_num(z) / max(span, 1e-6), -1, 1)
        r = np.where(t > 0, 1.0, 1.0 + t)
        g = 1.0 - np.abs(t)
        bl = np.where(t < 0, 1.0, 1.0 - t)
        rgba = np.dstack([r, g, bl, np.where(ok, 0.85, 0.0)])
        rgba = (rgba * 255).round().astype(np.uint8)
    out_png.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(rgba, "RGBA").save(out_png)
    west, north = transform * (0, 0)
    east, south = transform * (w, h)
    return [[float(south), float(west)], [float(north), float(east)]]


def site_files(tree: RunTree, r: SurveySite) -> dict[str, str]:
    """A visited site's files that exist (relative to the run directory)."""
    files = r.row.files if r.row is not None else {}
    return {k: v for k, v in files.items() if (tree.root / v).exists()}


def site_card(r: SurveySite, files: dict[str, str]) -> JsonObject:
    """What the map's side panel says of a site: the classifier's p and reward, the
    verdict's answer, p and reason to send the field team, the judged rise, the second
    look, the files."""
    v = r.judged_verdict
    card: JsonObject = {"p_mound": r.p_mound, "reward": r.site.reward, "visited": r.visited}
    if r.verdict is not None:
        card["verdict"] = v.label if v is not None else r.verdict  # its own answer
    card.update(final_label=r.final_label, label_source=r.label_source)
    if v is not None:
        card["confidence"] = v.confidence
        if v.p_mound is not None:
            card["verdict_p_mound"] = v.p_mound
    if r.truth is not None:
        card["truth"] = r.truth
    if r.visited and not r.judged:
        card["failure"] = (r.row.reason if r.row is not None else "not processed") or "?"
    if v is not None and v.label == "undecided":
        card["field_team"] = "; ".join(str(x.get("text", "")) for x in r.undecided_reasons())
    rise = v.rise if v is not None and v.rise is not None else {}
    card["measurements"] = {k: rise[k] for k in ("height_m", "base_diameter_m", "roundness")
                            if k in rise}
    look = r.row.second_look if v is not None and r.row is not None else None
    if look is not None:
        scan, p = look.site_diameter_m, look.p_mound
        card["second_look"] = (
            f"flown ({look.source if look.source is not None else 'simulated'}"
            + (f", a {scan:.0f} m scan" if scan is not None else "") + ")"
            + (f": p(mound) {p:.3f} after both flights" if p is not None else "")
            if look.flown else
            f"advised, not flown: {look.reason if look.reason is not None else ''}")
    card["files"] = dict(files)
    return card


def map_data(tree: RunTree, summary: SurveySummary, sites_doc: Sites,
             out_dir: Path) -> dict[str, Any]:
    """What the page draws of the survey (WGS84 degrees), the overlay PNGs written into
    out_dir."""
    rows, plan = summary.sites, summary.plan
    origin = sites_doc.origin
    if origin is None:
        raise InputError("sites: origin: missing (the map is in WGS84)")
    by_id = {r.id: r for r in rows}
    pos = {s.id: _lat_lon(origin, s.x_m, s.y_m) for s in sites_doc.sites}
    home = sites_doc.home
    pos[home.id] = _lat_lon(origin, home.x_m, home.y_m)
    if plan is not None:
        for w in plan.waypoints:
            pos.setdefault(w.id, _lat_lon(origin, w.x_m, w.y_m))
    sites = []
    overlays = []

    def overlay(tif: Path, name: str, kind: str, site: str | None, png_name: str) -> None:
        png = out_dir / "overlays" / png_name
        bounds = overlay_png(tif, png, kind)
        if bounds:
            overlays.append({"site": site, "name": name, "tif": str(tif.relative_to(tree.root)),
                             "png": f"map/overlays/{png_name}", "bounds": bounds})

    for site in sites_doc.sites:
        lat, lon = pos[site.id]
        here = by_id[site.id]
        files = site_files(tree, here)
        sites.append({"id": site.id, "lat": lat, "lon": lon, "card": site_card(here, files)})
        if files.get("rasters"):
            for name, kind in (("orthophoto", "rgb"), ("lrm", "relief")):
                overlay(tree.root / files["rasters"] / f"{name}.tif", name, kind, site.id,
                        f"{site.id}_{name}.png")
    for k, tif in enumerate(sorted(tree.root.glob("scene/*/p_mound.tif"))):
        overlay(tif, "scene_p_mound", "prob", None, f"scene{k:02d}_p_mound.png")
    footprints = []
    for gj in sorted([*tree.root.glob("mission*.geojson"),
                      *tree.root.glob("battery_*/mission*.geojson")]):
        for f in load_json(gj).get("features", []):
            if f.get("properties", {}).get("kind") == "image_footprint":
                ring = f["geometry"]["coordinates"][0]
                footprints.append([[float(c[1]), float(c[0])] for c in ring])
    def paths(flights: tuple[Flight, ...]) -> list[JsonObject]:
        """Each flight as a path of WGS84 points."""
        return [{"flight": k + 1, "cost_m": f.cost_m,
                 "path": [list(pos[i]) for i in f.tour if i in pos]}
                for k, f in enumerate(flights)]

    flights = paths(plan.flights) if plan is not None else []
    # the second looks' missions (second_look/plan.json), when the verdicts advised any
    sl_plan = tree.second_look / "plan.json"
    second_looks = (paths(tuple(f for f in Plan.read(sl_plan).flights if f.sites))
                    if sl_plan.is_file() else [])
    # every mission file of the run read back by its own reader: the map draws each path
    # (a file the survey wrote that its reader refuses is a bug: not caught here)
    from mound.uav import mission_format

    mission_files = []
    for fmt in (f for f in mission_format.registry() if f.readable):
        for path in sorted([*tree.root.glob(f"mission*{fmt.suffix}"),
                            *tree.root.glob(f"battery_*/mission*{fmt.suffix}")]):
            _, routes = fmt.read(path)
            for r in routes:
                mission_files.append({"file": str(path.relative_to(tree.root)),
                                      "format": path.suffix[1:],
                                      "waypoints": len(r.points),
                                      "path": [[p.lat_deg, p.lon_deg] for p in r.points]})
    nb = _next_battery(tree, summary.learn)
    next_battery = {"battery": nb[0], **paths(nb[1].flights)[0]} if nb else None
    return {"schema": "mound.map", "version": 1, "second_looks": second_looks,
            "next_battery": next_battery,
            "mission_files": mission_files,
            "home": {"id": home.id, "lat": pos[home.id][0], "lon": pos[home.id][1]},
            "sites": sites, "flights": flights, "overlays": overlays,
            "footprints": footprints,
            "budget_m": plan.budget_m if plan else None,
            "metrics": summary.metrics.to_doc()}


def _next_battery(tree: RunTree, learn: LearnRecord | None) -> tuple[int, Plan] | None:
    """A day on cards (`mound day`): the battery to fly next and its plan."""
    waiting = learn.waiting_for_battery if learn is not None else None
    plan = tree.root / f"battery_{waiting}" / "plan.json"
    if waiting is not None and plan.is_file():
        return waiting, Plan.read(plan)
    return None


class Frustum(NamedTuple):
    """A registered camera as the viewer draws it: its centre and the corners of its image
    at FRUSTUM_DEPTH_M (ENU m)."""

    centre: np.ndarray
    corners: list[np.ndarray]


def viewer_doc(site_id: str, xyz: np.ndarray, rgb: np.ndarray | None, centre: np.ndarray,
               ground: list[float], radius_m: float, rise: Rise | None = None,
               cameras: list[Frustum] | None = None, note: str = "",
               seed: int = 0) -> JsonObject:
    """The 3-D viewer's data for one site: the cloud (at most MAX_VIEW_POINTS, a seeded
    random subset) in metres from `centre` (x, y: ENU east, north of the site centre; z:
    above the ground fit's height at the centre), its colours, the ground fit
    z = c0 + c1 x + c2 y + c3 x^2 + c4 x y + c5 y^2 (x, y from the centre, as verdict.json's
    ground_coefficients) shifted to the same datum, the judged rise, the cameras' frustums
    (`cameras`, ENU)."""
    import base64

    n = len(xyz)
    idx = np.arange(n)
    if n > MAX_VIEW_POINTS:
        idx = np.sort(np.random.default_rng(seed).choice(n, MAX_VIEW_POINTS, replace=False))
    z0 = float(ground[0]) if ground else 0.0
    shift = np.array([centre[0], centre[1], z0])
    pts = (np.asarray(xyz, float)[idx] - shift).astype("<f4")
    if rgb is None:
        col = np.full((len(idx), 3), 170, np.uint8)
    else:
        col = np.asarray(rgb, np.uint8)[idx]
    g = [0.0] + [float(c) for c in ground[1:6]] if ground else [0.0] * 6
    frustums: list[JsonValue] = [{"centre": [float(v) for v in np.asarray(c.centre) - shift],
                 "corners": [[float(v) for v in np.asarray(k) - shift] for k in c.corners]}
                for c in cameras or []]
    shown: JsonObject | None = None
    if (rise is not None and rise.centre_enu_m is not None and rise.height_m is not None
            and rise.base_diameter_m is not None):
        cx, cy = np.asarray(rise.centre_enu_m, float) - shift[:2]
        shown = {"x": float(cx), "y": float(cy), "height_m": rise.height_m,
                 "base_diameter_m": rise.base_diameter_m}
        plane = rise.ground_plane  # the rise's own ground: z at its centre, slopes
        if plane is not None:
            shown["plane"] = [plane[0] - z0, plane[1], plane[2]]
            # a rise measured over a curved ground: its quadratic terms (1/m)
            if rise.ground_curvature is not None:
                shown["curvature"] = list(rise.ground_curvature)
    return {
        "site": site_id, "points": len(idx), "points_in_cloud": n, "note": note,
        "positions": base64.b64encode(pts.tobytes()).decode("ascii"),
        "colours": base64.b64encode(np.ascontiguousarray(col).tobytes()).decode("ascii"),
        "ground": g, "radius_m": float(radius_m), "origin_enu_m": [float(v) for v in shift],
        "cameras": frustums, "rise": shown}


def site_viewer_doc(tree: RunTree, site_id: str, files: dict[str, str]
                    ) -> JsonObject | None:
    """viewer_doc for a visited site of the survey (its files: site_files): its dense cloud
    (else the sparse one), verdict.json's site centre, ground fit and rise, recon.json's
    cameras."""
    from mound.ply import read_ply

    cloud = None
    if files.get("dense") and (tree.root / files["dense"] / "dense.ply").is_file():
        cloud = tree.root / files["dense"] / "dense.ply"
    elif files.get("recon") and (tree.root / files["recon"] / "points.ply").is_file():
        cloud = tree.root / files["recon"] / "points.ply"
    if cloud is None:
        return None
    xyz, rgb = read_ply(cloud)
    m = Measurements()
    if files.get("verdict") and (tree.root / files["verdict"]).is_file():
        m = VerdictFile.read(tree.root / files["verdict"]).measurements or m
    centre = np.array(m.site_centre_enu_m or np.median(xyz[:, :2], axis=0), float)
    ground = list(m.ground_coefficients or [float(np.median(xyz[:, 2]))] + [0.0] * 5)
    radius = float(m.site_radius_m or np.percentile(np.hypot(*(xyz[:, :2] - centre).T), 80))
    cameras = []
    if files.get("recon") and (tree.root / files["recon"] / "recon.json").is_file():
        recon = Recon.read(tree.root / files["recon"] / "recon.json")
        cam = recon.camera
        K, w, h = (cam.K, cam.width_px, cam.height_px) if cam else (np.eye(3), 0, 0)
        for _, pose, c in recon.poses() if cam else ():
            R = pose.R
            corners = []
            for u, v in ((0, 0), (w, 0), (w, h), (0, h)):
                ray = np.array([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], 1.0])
                corners.append(c + R.T @ (ray * FRUSTUM_DEPTH_M))
            cameras.append(Frustum(c, corners))
    note = f"{cloud.name}: {len(xyz):,} points"
    return viewer_doc(site_id, xyz, rgb, np.array([centre[0], centre[1]]),
                      ground, radius, m.rise, cameras, note)


def write_viewer_data(out_dir: Path, doc: Mapping[str, object]) -> Path:
    """map/sites/<id>.js: the viewer's data as a script (site3d.html#<id> loads it)."""
    path = out_dir / "sites" / f"{doc['site']}.js"
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(path, "window.MOUND_SITE = " + json.dumps(doc, separators=(",", ":")) + ";\n")
    return path


def copy_web_files(root: Path) -> Path:
    """Leaflet, three.js and the pages' own scripts into root/map/; root/site3d.html."""
    out_dir = root / "map"
    if out_dir.exists():
        shutil.rmtree(out_dir)
    (out_dir / "leaflet").mkdir(parents=True)
    shutil.copy2(LEAFLET_DIR / "leaflet.js", out_dir / "leaflet" / "leaflet.js")
    shutil.copy2(LEAFLET_DIR / "leaflet.css", out_dir / "leaflet" / "leaflet.css")
    shutil.copytree(LEAFLET_DIR / "images", out_dir / "leaflet" / "images")
    (out_dir / "three").mkdir()
    shutil.copy2(THREE_JS, out_dir / "three" / "three.min.js")
    for js in ("pagecheck.js", "webmap.js", "site3d.js"):
        shutil.copy2(Path(__file__).with_name(js), out_dir / js)
    write_atomic(root / "site3d.html", SITE_PAGE)
    return out_dir


def write_map(tree: RunTree, summary: SurveySummary, sites_doc: Sites,
              basemap: str | None = None) -> Path | None:
    """DIR/map.html, DIR/site3d.html and DIR/map/ (Leaflet, three.js, survey.js, the
    sites' clouds, overlays); None (and nothing written) when the libraries are not
    installed (tools/setup.sh installs them)."""
    if not web_libraries_available():
        return None
    out_dir = copy_web_files(tree.root)
    data = map_data(tree, summary, sites_doc, out_dir)
    data["basemap"] = basemap
    cards = {s["id"]: s["card"] for s in data["sites"]}
    for r in summary.sites:
        doc = site_viewer_doc(tree, r.id, site_files(tree, r)) if r.visited else None
        if doc is not None:
            write_viewer_data(out_dir, doc)
            cards[r.id]["viewer"] = f"site3d.html#{r.id}"
    write_atomic(out_dir / "survey.js",
                 "window.MOUND_SURVEY = " + json.dumps(data, separators=(",", ":")) + ";\n")
    page = tree.root / "map.html"
    write_atomic(page, PAGE)
    return page


PAGE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>Survey map</title>
<meta name="viewport" content="width=device-width, initial-scale=1">
<link rel="stylesheet" href="map/leaflet/leaflet.css">
<style>
  html, body { height: 100%; margin: 0; font: 14px/1.4 system-ui, sans-serif; }
  #map { position: absolute; top: 0; bottom: 0; left: 0; right: 340px; }
  #card { position: absolute; top: 0; bottom: 0; right: 0; width: 340px; overflow: auto;
          padding: 12px; box-sizing: border-box; border-left: 1px solid #ccc; }
  #card table { border-collapse: collapse; } #card td { padding: 2px 6px; }
  .legend { background: white; padding: 6px 8px; border-radius: 4px; line-height: 1.5; }
  .legend i { display: inline-block; width: 12px; height: 12px; margin-right: 4px; }
</style>
</head>
<body>
<div id="map"></div>
<div id="card"><h2>Survey map</h2><p>Click a site for its card.</p>
<p><a href="report.html">the full report</a></p></div>
<script src="map/pagecheck.js"></script>
<script src="map/leaflet/leaflet.js"></script>
<script src="map/survey.js"></script>
<script src="map/webmap.js"></script>
</body>
</html>
"""

SITE_PAGE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>Site in 3-D</title>
<meta name="viewport" content="width=device-width, initial-scale=1">
<style>
  html, body { height: 100%; margin: 0; font: 14px/1.4 system-ui, sans-serif; overflow: hidden; }
  #view { position: absolute; inset: 0; }
  #panel { position: absolute; top: 8px; left: 8px; background: rgba(255,255,255,0.92);
           padding: 8px 10px; border-radius: 4px; max-width: 360px; }
  #panel button { margin: 2px 4px 2px 0; }
  #measure-out { font-weight: bold; }
</style>
</head>
<body>
<div id="view"></div>
<div id="panel">
  <div id="title">Site</div>
  <div id="note"></div>
  <button id="colour">colour: RGB</button>
  <button id="measure">measure</button>
  <button id="reset">reset view</button>
  <div id="measure-out"></div>
  <div>drag: turn · shift-drag or right-drag: pan · wheel: zoom</div>
  <div><a href="map.html">back to the map</a></div>
</div>
<script src="map/pagecheck.js"></script>
<script src="map/three/three.min.js"></script>
<script src="map/site3d.js"></script>
</body>
</html>
"""
