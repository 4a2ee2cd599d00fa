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
length in pixels from DJI's XMP calibration, the focal plane resolution, the sensor width
of a known camera or, last, the 35 mm equivalent: mound_recon's one EXIF reader, which
refines it; `focal_source` and `focal_detail` say which and from what).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
from collections.abc import Mapping
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path

import numpy as np

from mound import native
from mound.bounds import SITE_DIAMETER_M, Bound
from mound.errors import InputError
from mound.formats.photos import SCHEMA, VERSION, CardSite
from mound.formats.plan import Plan
from mound.formats.sites import user_sites
from mound.geometry.flight import DEFAULT_SITE_DIAMETER_M, ScanSpec
from mound.geometry.geodesy import Origin, geodetic_to_enu
from mound.jsonio import (
    JsonObject,
    load_json,
    read_json,
    write_json,
)

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

    def check(self) -> None:
        """InputError naming the flag (as `mound photos sort` spells it) of a value out of
        its bound (NaN and inf included)."""
        for name, (flag, bound) in SORT_NUMBERS.items():
            bound.check(getattr(self, name), flag)


@dataclass(frozen=True)
class Proposal:
    """How sites were proposed from the photos (no sites file): photos.json's and the
    proposed sites.json's `proposed`; `sites` each site's x_m, y_m, reach_m, diameter_m."""

    method: str
    spacing_m: float
    link_m: float
    home: str
    home_ground: str
    sites: dict[str, dict[str, float]]

    def to_doc(self) -> JsonObject:
        return {"method": self.method, "spacing_m": self.spacing_m, "link_m": self.link_m,
                "home": self.home, "home_ground": self.home_ground,
                "sites": {k: dict(v) for k, v in self.sites.items()}}


@dataclass
class CardSites:
    origin: Origin
    ids: list[str]
    xy: np.ndarray          # (n, 2) ENU metres
    home_xy: np.ndarray     # (2,)
    reach_m: float          # the scan's farthest camera position from a site centre
    # per site, where each has its own (sites proposed from the photos); else reach_m
    site_reach_m: np.ndarray | None = None
    proposed: Proposal | None = None  # how the sites were proposed (no sites file)

    def reach_of(self) -> np.ndarray:
        return (self.site_reach_m if self.site_reach_m is not None
                else np.full(len(self.ids), self.reach_m))


# A card without a plan: photos whose positions chain within LINK_SPACINGS times the
# card's median spacing (nearest neighbour) are one site. Survey strips lie 2-3.5 spacings
# apart at the usual 60-70 % side and 75-80 % forward overlap; the separate sites of a
# flight hundreds of metres.
LINK_SPACINGS = 4.0
PROPOSED_PREFIX = "c"


def propose_sites(rows: list[PhotoRow]) -> CardSites:
    """Sites proposed from the card's own GPS photos (no plan, no sites file): home where
    the first photo (by capture time, else by name) was taken, with the take-off ground's
    height where DJI's XMP gives it (AbsoluteAltitude less RelativeAltitude); the photos
    chained within LINK_SPACINGS x the median nearest-neighbour spacing (single linkage)
    are a site when they are at least MIN_PHOTOS, its centre their mean position and its
    reach the farthest of them from it (a site's size from its photos, not a fixed
    diameter); smaller groups are left as transit. Ids c01, c02, ... in the order flown."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    gps = [r for r in rows if r.lat is not None and r.reason is None]
    if not gps:
        raise InputError("no sites file and no GPS photo on the card to propose sites from")
    order = sorted(range(len(gps)), key=lambda k: (_time(gps[k].time) or datetime.max,
                                                   gps[k].file))
    first = gps[order[0]]
    ground = None
    if first.dji_xmp and "abs_alt_m" in first.dji_xmp and "rel_alt_m" in first.dji_xmp:
        ground = first.dji_xmp["abs_alt_m"] - first.dji_xmp["rel_alt_m"]
    assert first.lat is not None and first.lon is not None  # a GPS photo
    origin = Origin(first.lat, first.lon, 0.0 if ground is None else ground)
    xy = geodetic_to_enu(origin, np.array([[r.lat, r.lon, 0.0] for r in gps]))[:, :2]
    n = len(gps)
    spacing, label = 0.0, np.zeros(n, dtype=int)
    if n > 1:
        tree = cKDTree(xy)
        spacing = float(np.median(tree.query(xy, k=2)[0][:, 1]))
        pairs = tree.query_pairs(max(LINK_SPACINGS * spacing, 1.0), output_type="ndarray")
        graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
        _, label = connected_components(graph, directed=False)
    link = max(LINK_SPACINGS * spacing, 1.0)
    rank = {k: i for i, k in enumerate(order)}
    groups = sorted((np.flatnonzero(label == g) for g in np.unique(label)),
                    key=lambda ks: min(rank[int(k)] for k in ks))
    centres, reach = [], []
    for ks in groups:
        if len(ks) < MIN_PHOTOS:
            continue
        c = xy[ks].mean(axis=0)
        centres.append(c)
        reach.append(float(np.max(np.linalg.norm(xy[ks] - c, axis=1))))
    if not centres:
        raise InputError(f"no sites file, and no group of {MIN_PHOTOS} or more photos on the "
                         f"card to propose a site from ({len(gps)} GPS photos, spacing "
                         f"{spacing:.1f} m)")
    ids = [f"{PROPOSED_PREFIX}{k + 1:02d}" for k in range(len(centres))]
    how = Proposal(
        "photos chained within link_m (single linkage); a site: a group of at least "
        f"{MIN_PHOTOS}, its centre their mean, its reach the farthest", spacing, link,
        first.file, "DJI XMP AbsoluteAltitude - RelativeAltitude" if ground is not None
        else "unknown (origin alt_m 0)",
        {i: {"x_m": float(c[0]), "y_m": float(c[1]), "reach_m": r, "diameter_m": 2 * r}
         for i, c, r in zip(ids, centres, reach, strict=True)})
    return CardSites(origin, ids, np.array(centres).reshape(-1, 2), np.zeros(2),
                     float(max(reach)), np.array(reach), how)


def proposed_sites_doc(sites: CardSites) -> JsonObject:
    """The proposed sites as a mound.sites document (what `--sites` reads: the survey and
    `mound photos sort --sites` can take it as it is; the site's scan scale its size)."""
    assert sites.proposed is not None and sites.site_reach_m is not None
    return {"schema": "mound.sites", "version": 1, "origin": sites.origin.to_doc(),
            "home": {"id": "home", "x_m": 0.0, "y_m": 0.0}, "end": {"id": "home"},
            "budget_m": 1e6,
            # no scene scored these places: p_mound 0.5, no prior either way (the survey
            # needs one; the verdict decides from the photos)
            "sites": [{"id": i, "x_m": float(xy[0]), "y_m": float(xy[1]), "reward": 1.0,
                       "p_mound": 0.5,
                       "reach_m": float(min(max(r, 1.0), 1e4)), "proposed_from": "photos"}
                      for i, xy, r in zip(sites.ids, sites.xy, sites.site_reach_m,
                                          strict=True)],
            "proposed": sites.proposed.to_doc()}


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
    # a site's own reach_m (a site proposed from a card's photos) instead of the scan's
    raw = doc.get("sites") if doc.get("schema") == "mound.sites" else None
    own = ([r.get("reach_m") if isinstance(r, dict) else None for r in raw]
           if isinstance(raw, list) and len(raw) == len(sites.sites) else [])
    site_reach = None
    numbers = [float(r) for r in own if isinstance(r, int | float) and not isinstance(r, bool)]
    if own and len(numbers) == len(own):
        for s, r in zip(sites.sites, numbers, strict=True):
            if not 0 < r <= 1e4:
                raise InputError(f"{path}: sites[{s.id}].reach_m: expected (0, 10000] m, "
                                 f"got {r!r}")
        site_reach = np.array(numbers)
    return CardSites(sites.origin, [s.id for s in sites.sites],
                     np.array([s.xy for s in sites.sites], dtype=float).reshape(-1, 2),
                     np.array([sites.home.x_m, sites.home.y_m], dtype=float),
                     scan.reach_m() if site_reach is None else float(site_reach.max()),
                     site_reach)


def _scan_of(doc: Mapping[str, object], path: str, spec: SortSpec) -> ScanSpec:
    """The document's scan, else a raster scan of `spec.site_diameter_m`."""
    scan = doc.get("scan")
    return (ScanSpec.from_doc(scan, f"{path}: scan") if isinstance(scan, dict)
            else ScanSpec(pattern="raster", site_diameter_m=spec.site_diameter_m))


def _plan_sites(doc: Mapping[str, object], path: str, spec: SortSpec) -> CardSites:
    """A mound.plan's visited sites (every flight)."""
    plan = Plan.from_doc(doc, path)
    if plan.origin is None:
        raise InputError(f"{path}: origin: missing (the sites' WGS84 frame)")
    if not plan.waypoints:
        raise InputError(f"{path}: waypoints: expected a list")
    wanted = plan.visited()
    nodes = [w for w in plan.waypoints if w.id in wanted]
    home = next((w for w in plan.waypoints if w.kind == "home"), None)
    if not nodes:
        raise InputError(f"{path}: no sites")
    scan = _scan_of(doc, path, spec)
    for w in [*nodes, *([home] if home else [])]:
        for name, v in (("x_m", w.x_m), ("y_m", w.y_m)):
            if abs(v) > MAX_ENU_M:
                raise InputError(f"{path}: waypoints: {w.id}.{name}: {v:g} outside "
                                 f"{-MAX_ENU_M:g}..{MAX_ENU_M:g}")
    xy = np.array([[w.x_m, w.y_m] for w in nodes])
    home_xy = np.zeros(2) if home is None else np.array([home.x_m, home.y_m])
    return CardSites(plan.origin, [w.id for w in nodes], xy, home_xy, scan.reach_m())


# A DJI photo's XMP and its EXIF say the same position and height to the precision they
# are written (EXIF's GPS rationals: centimetres); beyond these the two disagree, and the
# photo says so in photos.json (`xmp_conflicts`) instead of one being taken silently. The
# EXIF values stay what the sort and the reconstruction use.
XMP_EXIF_MAX_M = 1.0


@dataclass
class PhotoRow:
    """A file of the card (photos.json's photos[k]): its EXIF facts, and its site or the
    reason it has none. `camera` and `dji_xmp` are mound_recon photos' `exif` camera facts
    and `dji_xmp` numbers as listed."""

    file: str
    site: str | None = None
    reason: str | None = None
    lat: float | None = None
    lon: float | None = None
    alt_m: float | None = None
    time: str | None = None
    sharpness: float | None = None
    duplicate_of: str | None = None
    camera: dict[str, str | float] | None = None
    dji_xmp: dict[str, float] | None = None
    xmp_conflicts: list[str] = field(default_factory=list)
    enu_m: list[float] | None = None
    over_site: str | None = None

    def to_doc(self) -> JsonObject:
        doc: JsonObject = {
            "file": self.file, "site": self.site, "reason": self.reason, "lat": self.lat,
            "lon": self.lon, "alt_m": self.alt_m, "time": self.time,
            "sharpness": self.sharpness}
        optional: JsonObject = {
            "duplicate_of": self.duplicate_of, "camera": self.camera, "dji_xmp": self.dji_xmp,
            "xmp_conflicts": self.xmp_conflicts or None, "enu_m": self.enu_m,
            "over_site": self.over_site}
        return {**doc, **{k: v for k, v in optional.items() if v is not None}}


def xmp_conflicts(row: PhotoRow, xmp: Mapping[str, float]) -> list[str]:
    """Where a photo's DJI XMP contradicts its EXIF (position, absolute height)."""
    out = []
    if row.lat is not None and row.lon is not None and "lat" in xmp and "lon" in xmp:
        o = Origin(row.lat, row.lon)
        e = geodetic_to_enu(o, np.array([[xmp["lat"], xmp["lon"], 0.0]]))[0]
        if math.hypot(e[0], e[1]) > XMP_EXIF_MAX_M:
            out.append(f"position: XMP {math.hypot(e[0], e[1]):.1f} m from EXIF's")
    if row.alt_m is not None and "abs_alt_m" in xmp and abs(
            xmp["abs_alt_m"] - row.alt_m) > XMP_EXIF_MAX_M:
        out.append(f"height: XMP AbsoluteAltitude {xmp['abs_alt_m']:.2f} m, EXIF GPSAltitude "
                   f"{row.alt_m:.2f} m")
    return out


def altitude_drift(rows: list[PhotoRow]) -> dict[str, float] | None:
    """AbsoluteAltitude less RelativeAltitude is the take-off point's height and should not
    change over a flight: its spread over the card's DJI photos (the GNSS height's drift
    against the barometer), or None without such photos."""
    d = [r.dji_xmp["abs_alt_m"] - r.dji_xmp["rel_alt_m"] for r in rows
         if r.dji_xmp is not None and "abs_alt_m" in r.dji_xmp and "rel_alt_m" in r.dji_xmp
         and r.reason is None]
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


def site_camera(photos: list[PhotoRow], camera_file: str | None) -> JsonObject:
    """The camera a site's reconstruction starts from: the user's camera.json (copied into
    the site's folder), else the EXIF of the site's photos (the most common make, model and
    focal length; mound_recon reads the same EXIF and refines it in bundle adjustment)."""
    if camera_file:
        return {"source": "file", "file": camera_file}
    if not photos:
        return {"source": "none"}
    keys = [json.dumps(r.camera or {}, sort_keys=True) for r in photos]
    best = max(set(keys), key=lambda k: (keys.count(k), k))
    cam = json.loads(best)
    mixed = len(set(keys)) > 1
    if "focal_px" in cam:
        return {"source": f"exif ({cam['focal_source']})", **cam, "mixed": mixed}
    return {"source": "default (1.2 x the longer side): no focal length in EXIF "
            "(give --camera)", **cam, "mixed": mixed}


CAMERA_FACTS = ("make", "model", "focal_mm", "focal_35mm", "pixel_pitch_mm", "width_px",
                "focal_px", "focal_source", "focal_detail")


def _listed(listing: object) -> list[Mapping[str, object]]:
    """mound_recon photos' files (its own output: a malformed one is a bug, exit 1)."""
    files = listing.get("files") if isinstance(listing, dict) else None
    if not isinstance(files, list) or not all(
            isinstance(f, dict) and isinstance(f.get("file"), str) for f in files):
        raise RuntimeError("mound_recon photos: a listing without its files")
    return files


def _facts(obj: object, keys: tuple[str, ...] | None = None) -> dict[str, str | float]:
    """The strings and numbers of a listed object (those of `keys`, in their order)."""
    if not isinstance(obj, dict):
        return {}
    return {k: obj[k] for k in (keys or tuple(obj)) if k in obj
            and isinstance(obj[k], str | int | float) and not isinstance(obj[k], bool)}


def _photo_rows(listing: object, root: Path) -> list[PhotoRow]:
    """A row per file of mound_recon photos' listing: its EXIF facts, or why it is of no
    use (unreadable, duplicate, no GPS)."""
    rows: list[PhotoRow] = []
    seen: dict[str, str] = {}
    for f in _listed(listing):
        row = PhotoRow(str(f["file"]))
        rows.append(row)
        if f.get("kind") in ("not_an_image", "unreadable", "bad_name"):
            row.reason = "unreadable" if f["kind"] == "bad_name" else str(f["kind"])
            continue
        try:
            data = (root / row.file).read_bytes()
        except OSError:
            row.reason = "unreadable"
            continue
        digest = hashlib.sha256(data).hexdigest()
        if digest in seen:
            row.reason, row.duplicate_of = "duplicate", seen[digest]
            continue
        seen[digest] = row.file
        exif = _facts(f.get("exif"))
        time = exif.get("time")
        row.time = time if isinstance(time, str) else None
        row.camera = _facts(exif, CAMERA_FACTS)
        lat, lon = exif.get("lat"), exif.get("lon")
        if not isinstance(lat, float | int) or not isinstance(lon, float | int) or (
                abs(lat) < 1e-9 and abs(lon) < 1e-9):
            row.reason = "no_gps"
            continue
        row.lat, row.lon = lat, lon
        # Decoded from the bytes already read (each file is read once); None: it does not
        # decode, which makes a site's photo unreadable below.
        row.sharpness = sharpness(data)
        alt = exif.get("alt_m")
        row.alt_m = alt if isinstance(alt, float | int) and -1000 <= alt <= 20000 else None
        if isinstance(f.get("dji_xmp"), dict):
            row.dji_xmp = {k: v for k, v in _facts(f["dji_xmp"]).items()
                           if not isinstance(v, str)}
            row.xmp_conflicts = xmp_conflicts(row, row.dji_xmp)
    return rows


def _mark_other_flights(rows: list[PhotoRow], spec: SortSpec) -> None:
    """Another flight's photos: far in time from the card's GPS photos."""
    times = [t for r in rows if r.lat is not None and (t := _time(r.time)) is not None]
    if times:
        mid = sorted(times)[len(times) // 2]
        for r in rows:
            t = _time(r.time)
            if (r.lat is not None and t is not None
                    and abs((t - mid).total_seconds()) > spec.max_gap_h * 3600):
                r.reason = "other_flight"


def _place(rows: list[PhotoRow], sites: CardSites, spec: SortSpec) -> None:
    """Each GPS photo's site by its position (else transit, or outside the sites)."""
    gps = [r for r in rows if r.lat is not None and r.reason is None]
    if gps:
        llh = np.array([[r.lat, r.lon, 0.0] for r in gps])
        enu = geodetic_to_enu(sites.origin, llh)[:, :2]
        d = np.linalg.norm(enu[:, None, :] - sites.xy[None, :, :], axis=2)
        reach = sites.reach_of()
        # the nearest site whose scan area (its reach + the GPS margin) holds the photo
        inside = np.where(d <= reach[None, :] + spec.margin_m, d, np.inf)
        near = inside.argmin(axis=1)
        lo = np.minimum(sites.xy.min(axis=0), sites.home_xy) - sites.reach_m - spec.transit_margin_m
        hi = np.maximum(sites.xy.max(axis=0), sites.home_xy) + sites.reach_m + spec.transit_margin_m
        for k, r in enumerate(gps):
            r.enu_m = [round(float(enu[k, 0]), 2), round(float(enu[k, 1]), 2)]
            if np.isfinite(inside[k, near[k]]):
                r.site = sites.ids[near[k]]
            elif np.all(enu[k] >= lo) and np.all(enu[k] <= hi):
                r.reason = "transit"
            else:
                r.reason = "outside_sites"


def _per_site(rows: list[PhotoRow], sites: CardSites, spec: SortSpec,
              camera: str | None) -> dict[str, CardSite]:
    """A site's photo that does not decode is unreadable; blurred ones are flagged against
    the site's median sharpness; each site's count, status and camera."""
    for r in rows:
        if r.site is not None and r.sharpness is None:
            r.site, r.reason = None, "unreadable"
    per_site: dict[str, CardSite] = {}
    for sid in sites.ids:
        mine = [(r, r.sharpness) for r in rows if r.site == sid and r.sharpness is not None]
        med = float(np.median([q for _, q in mine])) if mine else 0.0
        for r, q in mine:
            if q < spec.blur_ratio * med:
                r.site, r.reason, r.over_site = None, "blurred", sid
        usable = [r for r, _ in mine if r.reason is None]
        per_site[sid] = CardSite(len(usable), len(mine) - len(usable), med,
                                 "ok" if len(usable) >= MIN_PHOTOS else "too_few_photos",
                                 site_camera(usable, camera))
    return per_site


@dataclass(frozen=True)
class SortedCard:
    """A sorted card: photos.json's document as written (`doc`), the card's files, their
    counts by what became of them, the sites and, without a sites file, the proposal."""

    doc: JsonObject
    files: int
    counts: dict[str, int]
    sites: dict[str, CardSite]
    proposed: Proposal | None = None


def sort_card(card: str, sites_path: str | None, out_dir: str, spec: SortSpec | None = None,
              camera: str | None = None) -> SortedCard:
    """Sorts CARD into OUT_DIR (photos.json and one folder per site, with a copy of
    `camera` (a mound.camera file) when given). Without a sites file
    (`sites_path` None) the sites are proposed from the photos (propose_sites) and written
    as OUT_DIR/sites.json. InputError when nothing usable is left (naming why)."""
    spec = spec or SortSpec()
    spec.check()
    if camera is not None:
        read_json(camera, "mound.camera", 1)
    sites = sites_of(sites_path, spec) if sites_path is not None else None
    listing = native.run_json("mound_recon", ["photos", card])
    root = Path(card)
    rows = _photo_rows(listing, root)
    _mark_other_flights(rows, spec)
    if sites is None:
        sites = propose_sites(rows)
        Path(out_dir).mkdir(parents=True, exist_ok=True)
        write_json(Path(out_dir) / "sites.json", proposed_sites_doc(sites))
        sites_path = str(Path(out_dir) / "sites.json")
    _place(rows, sites, spec)
    per_site = _per_site(rows, sites, spec, camera)
    reasons: dict[str, int] = {}
    for r in rows:
        key = r.reason or "site"
        reasons[key] = reasons.get(key, 0) + 1
    skipped = listing.get("skipped", [])
    if not isinstance(skipped, list) or not all(isinstance(x, str) for x in skipped):
        raise native.ToolError("mound_recon", native.EXIT_INTERNAL,
                               "its output's skipped is not a list of strings")
    doc: JsonObject = {
        "schema": SCHEMA, "version": VERSION, "card": str(root.resolve()),
        "sites_file": str(sites_path), "spec": {**spec.__dict__, "reach_m": sites.reach_m},
        **({"proposed": sites.proposed.to_doc()} if sites.proposed else {}),
        "photos": [r.to_doc() for r in rows],
        "sites": {k: v.to_doc() for k, v in per_site.items()}, "counts": reasons,
        "skipped_folders": skipped}
    dji = [r.dji_xmp for r in rows if r.dji_xmp is not None]
    if dji:
        doc["dji_xmp"] = {
            "photos": len(dji), "conflicts": sum(1 for r in rows if r.xmp_conflicts),
            "rtk_fixed": sum(1 for x in dji if x.get("rtk_flag") == 50),
            "abs_alt_datum": "EGM96 (ellipsoidal where rtk_flag is 50)",
            "altitude_drift": altitude_drift(rows)}
    if not any(v.photos for v in per_site.values()):
        why = ", ".join(f"{n} {k}" for k, n in sorted(reasons.items())) or "an empty card"
        raise InputError(f"{card}: no usable photo over any site ({why})")
    _write(rows, per_site, root, Path(out_dir), spec, camera)
    write_json(Path(out_dir) / "photos.json", doc)
    return SortedCard(doc, len(rows), reasons, per_site, sites.proposed)


def _write(rows: list[PhotoRow], per_site: dict[str, CardSite], root: Path,
           out: Path, spec: SortSpec, camera: str | None) -> None:
    """Each site's folder of its usable photos (links, or copies), and its camera.json."""
    out.mkdir(parents=True, exist_ok=True)
    for sid, info in per_site.items():
        folder = out / sid
        if folder.exists():
            shutil.rmtree(folder)
        if not info.photos:
            continue
        folder.mkdir()
        for r in rows:
            if r.site != sid or r.reason is not None:
                continue
            src = (root / r.file).resolve()
            dst = folder / r.file.replace("/", "__")
            if spec.copy:
                shutil.copy2(src, dst)
            else:
                os.symlink(src, dst)
        if camera is not None:
            shutil.copy2(camera, folder / "camera.json")  # its time kept: the site key
