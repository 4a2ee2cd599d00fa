"""A photo card sorted into the sites the aircraft scanned (`mound photos sort`).

The card is listed by `mound_recon photos` (the project's one EXIF reader: file kinds by
their first bytes, GPS, capture time, camera; headers only). Then, in this order, each file
gets a site or the reason it has none:

- `not_an_image` / `unreadable`: as the listing says (a name that is not UTF-8 is
  `unreadable`);
- `duplicate`: the same bytes (SHA-256) as an earlier file in path order;
- `no_gps`: an image without a usable GPS fix (none, or the EXIF's 0, 0 that cameras write
  before a fix);
- `other_flight`: taken more than `max_gap_h` hours from the median capture time of the
  card's GPS photos (another day's photos left on the card);
- the site whose scan area holds the photo's GPS position: within the scan's reach (the
  farthest camera position of the scan pattern from the site centre, from the plan's
  `scan`, else `site_diameter_m`) plus `margin_m` for GPS error (consumer GNSS: a few
  metres), the nearest such site;
- `transit`: not over a site but within the survey's area (home and the sites, grown by
  the scan's reach and `transit_margin_m`): shot on the way;
- `outside_sites`: elsewhere;
- `blurred`: a site's photo whose sharpness (the variance of the Laplacian of the image
  decoded at about 640 px, grey levels 0-255) is below `blur_ratio` times the median of
  that site's photos: no site (`over_site` says which), listed, not deleted, and left out
  of the site's folder.

Each file is read once: hashed, and every image with GPS decoded from the same bytes for
its sharpness. Nothing on the card is changed: the site folders hold symbolic links (or
copies with `copy=True`). Each site records the camera its reconstruction starts from:
the user's camera.json (copied into the site's folder), else the photos' EXIF (the focal
length in pixels from the focal plane resolution, the 35 mm equivalent or the sensor
width of a known UAV camera: mound_recon's one EXIF reader, which refines it).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np

from mound import native
from mound.bounds import SITE_DIAMETER_M, Bound
from mound.errors import InputError
from mound.formats.plan import Plan
from mound.formats.sites import user_sites
from mound.geometry.flight import DEFAULT_SITE_DIAMETER_M, ScanSpec
from mound.geometry.geodesy import Origin, geodetic_to_enu
from mound.jsonio import (
    load_json,
    read_json,
    require_id,
    require_number,
    write_json,
)

SCHEMA = "mound.photos"
VERSION = 1
MIN_PHOTOS = 8   # fewer than this: the site is reported, not reconstructed
MAX_ENU_M = 1e6  # a site's east or north from the origin (the survey is local)


# The numbers of a SortSpec: the flag that gives each, and its bound.
SORT_NUMBERS = {
    "site_diameter_m": ("--site-diameter", SITE_DIAMETER_M),
    "margin_m": ("--margin-m", Bound(0, 1_000, "m")),
    "transit_margin_m": ("transit_margin_m", Bound(0, 10_000, "m")),
    "max_gap_h": ("--max-gap-h", Bound(0, 10_000, "h", above=True)),
    "blur_ratio": ("--blur-ratio", Bound(0, 1))}


@dataclass(frozen=True)
class SortSpec:
    site_diameter_m: float = DEFAULT_SITE_DIAMETER_M  # the scan's scale where no plan says it
    margin_m: float = 10.0          # GPS error allowed around a scan area
    transit_margin_m: float = 200.0
    max_gap_h: float = 6.0
    blur_ratio: float = 0.3
    copy: bool = False

    def validate(self) -> None:
        """InputError naming the flag (as `mound photos sort` spells it) of a value out of
        its bound (NaN and inf included)."""
        for name, (flag, bound) in SORT_NUMBERS.items():
            bound.check(getattr(self, name), flag)


@dataclass
class CardSites:
    origin: Origin
    ids: list[str]
    xy: np.ndarray          # (n, 2) ENU metres
    home_xy: np.ndarray     # (2,)
    reach_m: float          # the scan's farthest camera position from a site centre


def sites_of(path: str, spec: SortSpec) -> CardSites:
    """The sites a card may hold: a plan's visited sites (mound.plan, every flight), or the
    sites of a `--sites` file as every command reads it (mound.formats.sites: a mound.sites
    document, or a WGS84 GeoJSON such as `mound scene score` writes); the scan's reach from
    the document's `scan`, else from `site_diameter_m`."""
    doc = load_json(path)  # read once, whatever it holds
    if isinstance(doc, dict) and doc.get("schema") == "mound.plan":
        return _plan_sites(doc, path, spec)
    if not isinstance(doc, dict) or (doc.get("schema") != "mound.sites"
                                     and doc.get("type") != "FeatureCollection"):
        raise InputError(f"{path}: expected a mound.plan, a mound.sites document or a GeoJSON "
                         "FeatureCollection of sites")
    scan = _scan_of(doc, path, spec)
    # (the budget plays no part in sorting photos: any positive default)
    sites = user_sites(doc, Path(path), scan, None, default_budget_m=1.0, need_truth=False,
                       need_p_mound=False)
    assert sites.origin is not None  # the reader requires one
    return CardSites(sites.origin, [s.id for s in sites.sites],
                     np.array([s.xy for s in sites.sites], dtype=float).reshape(-1, 2),
                     np.array([sites.home.x_m, sites.home.y_m], dtype=float), scan.reach_m())


def _scan_of(doc: dict[str, Any], path: str, spec: SortSpec) -> ScanSpec:
    """The document's scan, else a raster scan of `spec.site_diameter_m`."""
    return (ScanSpec.from_doc(doc["scan"], f"{path}: scan") if isinstance(doc.get("scan"), dict)
            else ScanSpec(pattern="raster", scale_m=spec.site_diameter_m))


def _plan_sites(doc: dict[str, Any], path: str, spec: SortSpec) -> CardSites:
    """A mound.plan's visited sites (every flight)."""
    plan = Plan.from_doc(doc, path)
    if plan.origin is None:
        raise InputError(f"{path}: origin: missing (the sites' WGS84 frame)")
    waypoints = _objects(doc, "waypoints", path)
    for k, w in enumerate(waypoints):
        require_id(w.get("id"), f"{path}: waypoints[{k}].id")
    wanted = plan.visited()
    nodes = [(f"{path}: waypoints[{k}]", w) for k, w in enumerate(waypoints)
             if w.get("id") in wanted]
    home = next((w for w in waypoints if w.get("kind") == "home"), None)
    if not nodes:
        raise InputError(f"{path}: no sites")
    scan = _scan_of(doc, path, spec)
    ids = [require_id(n.get("id"), f"{where}.id") for where, n in nodes]
    xy = np.array([[require_number(n, k, where, lo=-MAX_ENU_M, hi=MAX_ENU_M)
                    for k in ("x_m", "y_m")] for where, n in nodes])
    home_xy = np.zeros(2) if home is None else np.array(
        [require_number(home, k, f"{path}: home", lo=-MAX_ENU_M, hi=MAX_ENU_M, default=0.0)
         for k in ("x_m", "y_m")])
    return CardSites(plan.origin, ids, xy, home_xy, scan.reach_m())


def _objects(doc: dict[str, Any], key: str, path: str) -> list[dict[str, Any]]:
    """doc[key]: a list of objects, else InputError naming the field."""
    items = doc.get(key)
    if not isinstance(items, list):
        raise InputError(f"{path}: {key}: expected a list")
    for k, item in enumerate(items):
        if not isinstance(item, dict):
            raise InputError(f"{path}: {key}[{k}]: expected an object")
    return items


# A DJI photo's XMP and its EXIF say the same position and height to the precision they
# are written (EXIF's GPS rationals: centimetres); beyond these the two disagree, and the
# photo says so in photos.json (`xmp_conflicts`) instead of one being taken silently. The
# EXIF values stay what the sort and the reconstruction use.
XMP_EXIF_MAX_M = 1.0


def xmp_conflicts(row: dict[str, Any], xmp: dict[str, Any]) -> list[str]:
    """Where a photo's DJI XMP contradicts its EXIF (position, absolute height)."""
    out = []
    if row["lat"] is not None and xmp.get("lat") is not None and xmp.get("lon") is not None:
        o = Origin(row["lat"], row["lon"])
        e = geodetic_to_enu(o, np.array([[xmp["lat"], xmp["lon"], 0.0]]))[0]
        if math.hypot(e[0], e[1]) > XMP_EXIF_MAX_M:
            out.append(f"position: XMP {math.hypot(e[0], e[1]):.1f} m from EXIF's")
    if row["alt_m"] is not None and xmp.get("abs_alt_m") is not None and abs(
            xmp["abs_alt_m"] - row["alt_m"]) > XMP_EXIF_MAX_M:
        out.append(f"height: XMP AbsoluteAltitude {xmp['abs_alt_m']:.2f} m, EXIF GPSAltitude "
                   f"{row['alt_m']:.2f} m")
    return out


def altitude_drift(rows: list[dict[str, Any]]) -> dict[str, Any] | None:
    """AbsoluteAltitude less RelativeAltitude is the take-off point's height and should not
    change over a flight: its spread over the card's DJI photos (the GNSS height's drift
    against the barometer), or None without such photos."""
    d = [r["dji_xmp"]["abs_alt_m"] - r["dji_xmp"]["rel_alt_m"] for r in rows
         if isinstance(r.get("dji_xmp"), dict) and r["dji_xmp"].get("abs_alt_m") is not None
         and r["dji_xmp"].get("rel_alt_m") is not None and r.get("reason") is None]
    if not d:
        return None
    return {"photos": len(d), "takeoff_abs_alt_median_m": float(np.median(d)),
            "spread_m": float(np.max(d) - np.min(d))}


def sharpness(data: bytes) -> float | None:
    """The variance of the Laplacian of the image (its file's bytes) in grey levels,
    decoded at about 640 px on its longer side (a JPEG is decoded at that scale directly);
    None when it does not decode."""
    import io

    from PIL import Image, UnidentifiedImageError
    from scipy.ndimage import laplace

    try:
        with Image.open(io.BytesIO(data)) as src:
            src.draft("L", (640, 640))
            im = src.convert("L")
            scale = 640 / max(im.size)
            if scale < 1:
                im = im.resize((max(1, round(im.width * scale)), max(1, round(im.height * scale))))
            a = np.asarray(im, dtype=np.float64)
    except (OSError, UnidentifiedImageError, ValueError, Image.DecompressionBombError):
        return None
    return float(laplace(a).var()) if a.size else None


def _time(text: str | None) -> datetime | None:
    try:
        return datetime.strptime(text, "%Y:%m:%d %H:%M:%S") if text else None
    except ValueError:
        return None


def site_camera(photos: list[dict[str, Any]], camera_file: str | None) -> dict[str, Any]:
    """The camera a site's reconstruction starts from: the user's camera.json (copied into
    the site's folder), else the EXIF of the site's photos (the most common make, model and
    focal length; mound_recon reads the same EXIF and refines it in bundle adjustment)."""
    if camera_file:
        return {"source": "file", "file": camera_file}
    if not photos:
        return {"source": "none"}
    keys = [json.dumps(r.get("camera", {}), sort_keys=True) for r in photos]
    best = max(set(keys), key=lambda k: (keys.count(k), k))
    cam = json.loads(best)
    mixed = len(set(keys)) > 1
    if "focal_px" in cam:
        return {"source": f"exif ({cam['focal_source']})", **cam, "mixed": mixed}
    return {"source": "default (1.2 x the longer side): no focal length in EXIF "
            "(give --camera)", **cam, "mixed": mixed}


def _photo_rows(listing: dict[str, Any], root: Path) -> list[dict[str, Any]]:
    """A row per file of mound_recon photos' listing: its EXIF facts, or why it is of no
    use (unreadable, duplicate, no GPS)."""
    rows: list[dict[str, Any]] = []
    seen: dict[str, str] = {}
    for f in listing["files"]:
        row: dict[str, Any] = {"file": f["file"], "site": None, "reason": None,
                               "lat": None, "lon": None, "alt_m": None, "time": None,
                               "sharpness": None}
        rows.append(row)
        if f["kind"] in ("not_an_image", "unreadable", "bad_name"):
            row["reason"] = "unreadable" if f["kind"] == "bad_name" else f["kind"]
            continue
        try:
            data = (root / f["file"]).read_bytes()
        except OSError:
            row["reason"] = "unreadable"
            continue
        digest = hashlib.sha256(data).hexdigest()
        if digest in seen:
            row["reason"], row["duplicate_of"] = "duplicate", seen[digest]
            continue
        seen[digest] = f["file"]
        exif = f.get("exif", {})
        row["time"] = exif.get("time")
        row["camera"] = {k: exif[k] for k in ("make", "model", "focal_mm", "focal_35mm",
                                              "pixel_pitch_mm", "width_px", "focal_px",
                                              "focal_source") if k in exif}
        lat, lon = exif.get("lat"), exif.get("lon")
        if lat is None or lon is None or (abs(lat) < 1e-9 and abs(lon) < 1e-9):
            row["reason"] = "no_gps"
            continue
        row["lat"], row["lon"] = lat, lon
        # Decoded from the bytes already read (each file is read once); None: it does not
        # decode, which makes a site's photo unreadable below.
        row["sharpness"] = sharpness(data)
        alt = exif.get("alt_m")
        row["alt_m"] = alt if alt is not None and -1000 <= alt <= 20000 else None
        if isinstance(f.get("dji_xmp"), dict):
            row["dji_xmp"] = f["dji_xmp"]
            conflicts = xmp_conflicts(row, f["dji_xmp"])
            if conflicts:
                row["xmp_conflicts"] = conflicts
    return rows


def _mark_other_flights(rows: list[dict[str, Any]], spec: SortSpec) -> None:
    """Another flight's photos: far in time from the card's GPS photos."""
    times = [t for r in rows if r["lat"] is not None and (t := _time(r["time"])) is not None]
    if times:
        mid = sorted(times)[len(times) // 2]
        for r in rows:
            t = _time(r["time"])
            if (r["lat"] is not None and t is not None
                    and abs((t - mid).total_seconds()) > spec.max_gap_h * 3600):
                r["reason"] = "other_flight"


def _place(rows: list[dict[str, Any]], sites: CardSites, spec: SortSpec) -> None:
    """Each GPS photo's site by its position (else transit, or outside the sites)."""
    gps = [r for r in rows if r["lat"] is not None and r["reason"] is None]
    if gps:
        llh = np.array([[r["lat"], r["lon"], 0.0] for r in gps])
        enu = geodetic_to_enu(sites.origin, llh)[:, :2]
        d = np.linalg.norm(enu[:, None, :] - sites.xy[None, :, :], axis=2)
        near = d.argmin(axis=1)
        lo = np.minimum(sites.xy.min(axis=0), sites.home_xy) - sites.reach_m - spec.transit_margin_m
        hi = np.maximum(sites.xy.max(axis=0), sites.home_xy) + sites.reach_m + spec.transit_margin_m
        for k, r in enumerate(gps):
            r["enu_m"] = [round(float(enu[k, 0]), 2), round(float(enu[k, 1]), 2)]
            if d[k, near[k]] <= sites.reach_m + spec.margin_m:
                r["site"] = sites.ids[near[k]]
            elif np.all(enu[k] >= lo) and np.all(enu[k] <= hi):
                r["reason"] = "transit"
            else:
                r["reason"] = "outside_sites"


def _per_site(rows: list[dict[str, Any]], sites: CardSites, spec: SortSpec,
              camera: str | None) -> dict[str, dict[str, Any]]:
    """A site's photo that does not decode is unreadable; blurred ones are flagged against
    the site's median sharpness; each site's count, status and camera."""
    for r in rows:
        if r["site"] is not None and r["sharpness"] is None:
            r["site"], r["reason"] = None, "unreadable"
    per_site: dict[str, dict[str, Any]] = {}
    for sid in sites.ids:
        mine = [r for r in rows if r["site"] == sid]
        s = [r["sharpness"] for r in mine]
        med = float(np.median(s)) if s else 0.0
        for r in mine:
            if r["sharpness"] < spec.blur_ratio * med:
                r["site"], r["reason"], r["over_site"] = None, "blurred", sid
        usable = [r for r in mine if r["reason"] is None]
        per_site[sid] = {"photos": len(usable), "blurred": len(mine) - len(usable),
                         "median_sharpness": med,
                         "status": "ok" if len(usable) >= MIN_PHOTOS else "too_few_photos",
                         "camera": site_camera(usable, camera)}
    return per_site


def sort_card(card: str, sites_path: str, out_dir: str, spec: SortSpec | None = None,
              camera: str | None = None) -> dict[str, Any]:
    """Sorts CARD into OUT_DIR (photos.json and one folder per site, with a copy of
    `camera` (a mound.camera file) when given); returns photos.json. InputError when
    nothing usable is left (naming why)."""
    spec = spec or SortSpec()
    spec.validate()
    if camera is not None:
        read_json(camera, "mound.camera", 1)
    sites = sites_of(sites_path, spec)
    listing = native.run_json("mound_recon", ["photos", card])
    root = Path(card)
    rows = _photo_rows(listing, root)
    _mark_other_flights(rows, spec)
    _place(rows, sites, spec)
    per_site = _per_site(rows, sites, spec, camera)
    reasons: dict[str, int] = {}
    for r in rows:
        key = r["reason"] or "site"
        reasons[key] = reasons.get(key, 0) + 1
    doc = {"schema": SCHEMA, "version": VERSION, "card": str(root.resolve()),
           "sites_file": str(sites_path), "spec": {**spec.__dict__, "reach_m": sites.reach_m},
           "photos": rows, "sites": per_site, "counts": reasons,
           "skipped_folders": listing.get("skipped", [])}
    dji = [r for r in rows if "dji_xmp" in r]
    if dji:
        doc["dji_xmp"] = {
            "photos": len(dji), "conflicts": sum(1 for r in dji if "xmp_conflicts" in r),
            "rtk_fixed": sum(1 for r in dji if r["dji_xmp"].get("rtk_flag") == 50),
            "abs_alt_datum": "EGM96 (ellipsoidal where rtk_flag is 50)",
            "altitude_drift": altitude_drift(rows)}
    if not any(v["photos"] for v in per_site.values()):
        why = ", ".join(f"{n} {k}" for k, n in sorted(reasons.items())) or "an empty card"
        raise InputError(f"{card}: no usable photo over any site ({why})")
    _write(doc, root, Path(out_dir), spec, camera)
    return doc


def _write(doc: dict[str, Any], root: Path, out: Path, spec: SortSpec,
           camera: str | None) -> None:
    out.mkdir(parents=True, exist_ok=True)
    for sid, info in doc["sites"].items():
        folder = out / sid
        if folder.exists():
            shutil.rmtree(folder)
        if not info["photos"]:
            continue
        folder.mkdir()
        for r in doc["photos"]:
            if r["site"] != sid or r["reason"] is not None:
                continue
            src = (root / r["file"]).resolve()
            dst = folder / r["file"].replace("/", "__")
            if spec.copy:
                shutil.copy2(src, dst)
            else:
                os.symlink(src, dst)
        if camera is not None:
            shutil.copy2(camera, folder / "camera.json")  # its time kept: the site key
    write_json(out / "photos.json", doc)
