"""The survey on a map, offline: `DIR/map.html` with Leaflet (from npm at set-up, shipped
beside the page in `DIR/map/`), in WGS84. Candidate sites coloured by p(mound), one path per
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
from pathlib import Path
from typing import Any

import numpy as np

from mound.geometry.geodesy import Origin, enu_to_geodetic
from mound.jsonio import write_atomic
from mound.paths import REPO_ROOT
from mound.survey.tree import RunTree

LEAFLET_DIR = REPO_ROOT / "tools" / "web" / "node_modules" / "leaflet" / "dist"
OVERLAY_MAX_PX = 1024  # the longer side of an overlay image


def leaflet_available() -> bool:
    return (LEAFLET_DIR / "leaflet.js").is_file()


def _lat_lon(origin: Origin, x: float, y: float) -> tuple[float, float]:
    llh = enu_to_geodetic(origin, np.array([[x, y, 0.0]]))[0]
    return float(llh[0]), float(llh[1])


def overlay_png(tif: Path, out_png: Path, kind: str) -> tuple[list[list[float]], str] | None:
    """The GeoTIFF reprojected to WGS84 (EPSG:4326) as a PNG with transparency, and its
    bounds [[south, west], [north, east]]; None when the file is missing or has no CRS.
    kind: "rgb" (an orthophoto, its alpha band kept) or "relief" (a single band, coloured
    blue-white-red over ±its 98th absolute percentile)."""
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
    if kind == "rgb":
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
    return [[float(south), float(west)], [float(north), float(east)]], kind


def map_data(tree: RunTree, summary: dict[str, Any], sites_doc: dict[str, Any],
             plan: dict[str, Any] | None, out_dir: Path) -> dict[str, Any]:
    """What the page draws (WGS84 degrees), the overlay PNGs written into out_dir."""
    origin = Origin.from_doc(sites_doc["origin"], "sites: origin")
    rows = {r["id"]: r for r in summary["sites"]}
    pos = {s["id"]: _lat_lon(origin, s["x_m"], s["y_m"]) for s in sites_doc["sites"]}
    home = sites_doc["home"]
    pos[home["id"]] = _lat_lon(origin, home["x_m"], home["y_m"])
    if plan is not None:
        for w in plan.get("waypoints", []):
            pos.setdefault(w["id"], _lat_lon(origin, w["x_m"], w["y_m"]))
    sites = []
    overlays = []
    for s in sites_doc["sites"]:
        r = rows.get(s["id"], {})
        lat, lon = pos[s["id"]]
        card = {k: r[k] for k in ("p_mound", "reward", "visited", "verdict", "final_label",
                                  "label_source", "confidence", "verdict_p_mound", "truth",
                                  "failure") if k in r}
        rise = r.get("rise") or {}
        card["measurements"] = {k: rise[k] for k in ("height_m", "base_diameter_m",
                                                       "roundness") if k in rise}
        files = r.get("files") or {}
        card["files"] = {k: v for k, v in files.items() if isinstance(v, str)}
        sites.append({"id": s["id"], "lat": lat, "lon": lon, "card": card})
        rasters = files.get("rasters")
        if rasters:
            for name, kind in (("orthophoto", "rgb"), ("lrm", "relief")):
                png = out_dir / "overlays" / f"{s['id']}_{name}.png"
                got = overlay_png(tree.root / rasters / f"{name}.tif", png, kind)
                if got:
                    overlays.append({"site": s["id"], "name": name,
                                     "tif": f"{rasters}/{name}.tif",
                                     "png": f"map/overlays/{png.name}", "bounds": got[0]})
    flights = []
    if plan is not None:
        fl = plan.get("flights") or [{"tour": plan["tour"], "cost_m": plan.get("cost_m")}]
        for k, f in enumerate(fl):
            flights.append({"flight": k + 1, "cost_m": f.get("cost_m"),
                            "path": [list(pos[i]) for i in f["tour"] if i in pos]})
    return {"schema": "mound.map", "version": 1,
            "home": {"id": home["id"], "lat": pos[home["id"]][0], "lon": pos[home["id"]][1]},
            "sites": sites, "flights": flights, "overlays": overlays,
            "budget_m": plan.get("budget_m") if plan else None,
            "metrics": summary.get("metrics", {})}


def write_map(tree: RunTree, summary: dict[str, Any], sites_doc: dict[str, Any],
              plan: dict[str, Any] | None, basemap: str | None = None) -> Path | None:
    """DIR/map.html and DIR/map/ (Leaflet, survey.js, overlays); None (and nothing
    written) when Leaflet is not installed (tools/setup.sh installs it)."""
    if not leaflet_available():
        return None
    out_dir = tree.root / "map"
    if out_dir.exists():
        shutil.rmtree(out_dir)
    (out_dir / "leaflet").mkdir(parents=True)
    shutil.copy2(LEAFLET_DIR / "leaflet.js", out_dir / "leaflet" / "leaflet.js")
    shutil.copy2(LEAFLET_DIR / "leaflet.css", out_dir / "leaflet" / "leaflet.css")
    shutil.copytree(LEAFLET_DIR / "images", out_dir / "leaflet" / "images")
    data = map_data(tree, summary, sites_doc, plan, out_dir)
    data["basemap"] = basemap
    write_atomic(out_dir / "survey.js",
                 "window.MOUND_SURVEY = " + json.dumps(data, separators=(",", ":")) + ";\n")
    shutil.copy2(Path(__file__).with_name("webmap.js"), out_dir / "webmap.js")
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
<script src="map/leaflet/leaflet.js"></script>
<script src="map/survey.js"></script>
<script src="map/webmap.js"></script>
</body>
</html>
"""
