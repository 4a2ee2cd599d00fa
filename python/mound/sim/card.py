"""What a real camera writes: JPEGs with EXIF, and a whole simulated flight as one photo card.

- `site_jpegs(site_dir, ...)` turns a simulated site's rendered PNGs into JPEGs carrying
  what a UAV camera writes into EXIF: GPS latitude, longitude and altitude (the simulator's
  noisy GPS, altitude above the WGS84 origin's datum), the capture time, make and model,
  the focal length with the focal plane resolution (a 1/2.3" sensor, 6.17 mm wide) and the
  35 mm equivalent. `mound sim site --jpeg` does this.
- `write_card(plan, sites, out, spec)` writes the photos of a planned survey (or, with
  `spec.scan_factor`, of its second looks: the survey's second_look/plan.json), flight by
  flight, as they come off the aircraft: `OUT/DCIM/100MEDIA/DJI_NNNN.JPG`, each visited
  site's scan rendered the way the survey driver simulates it (`survey_site_spec`: the same
  terrain, mound height and seeds), and transit frames shot every `transit_every_s` along
  the legs between sites (ground texture only; never within reach of a site's scan), with
  times from the flight's speed. `mound sim flight PLAN --out CARD` does this, and writes
  what each file is (`mound.card_truth` v1) with `--truth`.
"""

from __future__ import annotations

import itertools
import math
import shutil
import tempfile
from dataclasses import dataclass, replace
from datetime import datetime, timedelta
from fractions import Fraction
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mound.errors import InputError
from mound.formats.plan import Plan
from mound.formats.sites import Site, Sites
from mound.geometry.camera import Camera
from mound.geometry.flight import DEFAULT_SITE_DIAMETER_M
from mound.geometry.geodesy import Origin, enu_to_geodetic
from mound.jsonio import JsonObject, read_json, write_json

if TYPE_CHECKING:
    from PIL import Image
    from PIL.TiffImagePlugin import IFDRational

    from mound.sim.site import SimSpec

SENSOR_WIDTH_MM = 6.17   # the simulated camera's sensor: 1/2.3", as on small UAVs
MOUND_HEIGHTS_M = (4.0, 12.0)  # simulated tumuli: heights drawn uniformly from this range
EXIF_TIME = "%Y:%m:%d %H:%M:%S"
CARD_TRUTH = "mound.card_truth"


EXIF_STYLES = ("sim", "dji")
# "dji": what a DJI Phantom 3's FC300S writes (../shared/data/dji/photo_meta): make DJI,
# model FC300S, the focal length in mm and the 35 mm equivalent but no focal plane
# resolution (the focal length in pixels then comes from the sensor table), and the XMP
# drone-dji packet (AbsoluteAltitude = GPSAltitude, RelativeAltitude above take-off,
# gimbal and aircraft attitude).
DJI_SENSOR = (6.17, 4.55)   # mm, the FC300S's 1/2.3" sensor


@dataclass(frozen=True)
class ExifFacts:
    lat: float
    lon: float
    alt_m: float
    time: datetime
    focal_px: float
    width_px: int
    make: str = "mound-survey"
    model: str = "sim"
    style: str = "sim"
    height_px: int | None = None
    takeoff_alt_m: float | None = None   # "dji": RelativeAltitude = alt_m less this
    yaw_deg: float = 0.0                 # "dji": the aircraft's and gimbal's heading


def dji_xmp(f: ExifFacts) -> bytes:
    """The drone-dji XMP packet a DJI aircraft writes (the attributes of the FC300S's)."""
    rel = f.alt_m - (f.takeoff_alt_m if f.takeoff_alt_m is not None else f.alt_m)
    return ('<?xpacket begin="\ufeff" id="W5M0MpCehiHzreSzNTczkc9d"?>'
            '<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf='
            '"http://www.w3.org/1999/02/22-rdf-syntax-ns#"><rdf:Description rdf:about='
            '"DJI Meta Data" xmlns:tiff="http://ns.adobe.com/tiff/1.0/"'
            ' xmlns:drone-dji="http://www.dji.com/drone-dji/1.0/"'
            ' tiff:Make="DJI" tiff:Model="FC300S"'
            f' drone-dji:AbsoluteAltitude="{f.alt_m:+.2f}"'
            f' drone-dji:RelativeAltitude="{rel:+.2f}"'
            f' drone-dji:GimbalRollDegree="+0.00" drone-dji:GimbalYawDegree="{f.yaw_deg:+.2f}"'
            ' drone-dji:GimbalPitchDegree="-90.00" drone-dji:FlightRollDegree="+0.00"'
            f' drone-dji:FlightYawDegree="{f.yaw_deg:+.2f}" drone-dji:FlightPitchDegree="+0.00"'
            '/></rdf:RDF></x:xmpmeta><?xpacket end="w"?>').encode()


def _rational(x: float, denominator: int = 1_000_000) -> IFDRational:
    from PIL.TiffImagePlugin import IFDRational

    f = Fraction(round(abs(x) * denominator), denominator)
    return IFDRational(f.numerator, f.denominator)


def _dms(deg: float) -> tuple[IFDRational, IFDRational, IFDRational]:
    deg = abs(deg)
    d = math.floor(deg)
    m = math.floor((deg - d) * 60)
    s = (deg - d - m / 60) * 3600
    return _rational(d, 1), _rational(m, 1), _rational(s, 10_000_000)


def exif_of(f: ExifFacts) -> Image.Exif:
    """A Pillow Exif block with the facts (EXIF 2.3 tags, GPS IFD)."""
    from PIL import Image

    ex = Image.Exif()
    stamp = f.time.strftime(EXIF_TIME)
    dji = f.style == "dji"
    ex[0x010F], ex[0x0110], ex[0x0132] = ("DJI", "FC300S", stamp) if dji else (
        f.make, f.model, stamp)
    e = ex.get_ifd(0x8769)
    pitch_mm = SENSOR_WIDTH_MM / f.width_px
    e[0x9003] = stamp
    e[0x920A] = _rational(f.focal_px * pitch_mm)               # FocalLength, mm
    if dji:  # the 35 mm equivalent on the sensor's diagonal, as DJI writes it
        e[0xA405] = int(round(f.focal_px * pitch_mm * 43.27 / math.hypot(*DJI_SENSOR)))
    else:
        e[0xA405] = int(round(f.focal_px / f.width_px * 36))   # FocalLengthIn35mmFilm
        e[0xA20E] = _rational(10.0 / pitch_mm)                 # FocalPlaneXResolution
        e[0xA20F] = _rational(10.0 / pitch_mm)
        e[0xA210] = 3                                          # ... per centimetre
    e[0xA002] = f.width_px                                     # PixelXDimension
    if f.height_px:
        e[0xA003] = f.height_px                                # PixelYDimension
    g = ex.get_ifd(0x8825)
    g[0] = b"\x02\x03\x00\x00"
    g[1], g[2] = ("N" if f.lat >= 0 else "S"), _dms(f.lat)
    g[3], g[4] = ("E" if f.lon >= 0 else "W"), _dms(f.lon)
    g[5], g[6] = (b"\x00" if f.alt_m >= 0 else b"\x01"), _rational(f.alt_m, 1000)
    return ex


def save_jpeg(rgb: np.ndarray | Path, out: Path, facts: ExifFacts, quality: int = 95) -> None:
    """Writes an image (an array or a file) as a JPEG with the EXIF facts, atomically."""
    from PIL import Image

    im = Image.open(rgb) if isinstance(rgb, Path) else Image.fromarray(rgb)
    with im:
        tmp = out.with_name(out.name + ".tmp")
        extra = {"xmp": dji_xmp(facts)} if facts.style == "dji" else {}
        im.convert("RGB").save(tmp, format="JPEG", quality=quality, exif=exif_of(facts),
                               **extra)
    tmp.replace(out)


def site_jpegs(site_dir: str | Path, start: datetime, every_s: float = 2.0,
               quality: int = 95, gps_latency_s: float = 0.0,
               style: str = "sim") -> list[tuple[str, datetime]]:
    """The simulated site's images as JPEGs with EXIF (the PNGs replaced; poses.json and
    site.json name the JPEGs); returns (file, capture time) in flight order. With
    `gps_latency_s` the EXIF position is where the camera was that long before the shutter
    (DJI's GNSS latency: the camera's velocity from its neighbours in flight order, at one
    photo every `every_s`), so alternate strips of a raster are shifted along track in
    opposite directions; poses.json's gps_enu_m keeps the positions without it. `style`
    "dji" writes the metadata of a DJI FC300S (EXIF_STYLES) instead of the simulator's."""
    if style not in EXIF_STYLES:
        raise InputError(f"--exif-style: expected one of {', '.join(EXIF_STYLES)}")
    d = Path(site_dir)
    poses = read_json(d / "poses.json", "mound.poses", 1)
    cam = read_json(d / "camera.json", "mound.camera", 1)
    origin = Origin.from_doc(poses["origin"], f"{d}/poses.json: origin")
    gps = np.array([im["gps_enu_m"] for im in poses["images"]], dtype=float)
    if gps_latency_s:
        c = np.array([im["centre_enu_m"] for im in poses["images"]], dtype=float)
        ahead = np.vstack([c[1:], c[-1:]])
        behind = np.vstack([c[:1], c[:-1]])
        span = np.array([2.0] * len(c))
        span[0] = span[-1] = 1.0
        velocity = (ahead - behind) / (span[:, None] * every_s)
        velocity[:, 2] = 0.0
        gps = gps - gps_latency_s * velocity
    llh = enu_to_geodetic(origin, gps)
    out: list[tuple[str, datetime]] = []
    for k, im in enumerate(poses["images"]):
        png = d / im["file"]
        jpg = png.with_suffix(".jpg")
        when = start + timedelta(seconds=k * every_s)
        yaw = 0.0
        if style == "dji":  # the heading: from this photo towards the next (last: previous)
            j = min(k + 1, len(gps) - 1)
            ahead = gps[j] - gps[k] if j != k else gps[k] - gps[k - 1]
            yaw = math.degrees(math.atan2(ahead[0], ahead[1]))
        save_jpeg(png, jpg, ExifFacts(float(llh[k, 0]), float(llh[k, 1]), float(llh[k, 2]),
                                      when, float(cam["K"][0][0]), int(cam["width"]),
                                      style=style, height_px=int(cam["height"]),
                                      takeoff_alt_m=origin.alt_m, yaw_deg=yaw), quality)
        png.unlink()
        im["file"] = str(Path(im["file"]).with_suffix(".jpg"))
        out.append((im["file"], when))
    write_json(d / "poses.json", poses)
    site = read_json(d / "site.json", "mound.sim_site", 1)
    site["files"]["images"] = [im["file"] for im in poses["images"]]
    site["jpeg"] = {"quality": quality, "start": start.isoformat(), "every_s": every_s,
                    "sensor_width_mm": SENSOR_WIDTH_MM, "gps_latency_s": gps_latency_s,
                    "exif_style": style}
    write_json(d / "site.json", site)
    return out


@dataclass(frozen=True)
class SiteGround:
    """A visited site's ground over the survey's DEM: the DEM (its path), what its heights
    are above (`vertical`), and the mission's ground height of the site (m AMSL)."""

    dem: str
    vertical: str
    ground_amsl_m: float

    def to_doc(self) -> JsonObject:
        return {"dem": self.dem, "vertical": self.vertical, "ground_amsl_m": self.ground_amsl_m}


def survey_site_spec(site: Site, index: int, origin: Origin,
                     sim_seed: int, image_size: tuple[int, int], pattern: str,
                     site_diameter_m: float, terrain_input: SiteGround | None = None
                     ) -> tuple[SimSpec, JsonObject]:
    """How the survey simulates a visited site's flight: the SimSpec (from the site's
    hidden truth, seeded by `sim_seed` and the site's index) and what was simulated."""
    from mound.sim import site as sim
    from mound.sim import terrain

    truth = None if site.truth is None else site.truth.mound
    if truth is None and site.extra.get("simulate") == "flat":
        truth = False  # a scene's candidate of unknown truth: flown over flat ground
    if truth is None:
        raise InputError(f"sites: {site.id}.truth: needed to simulate its flight")
    rng = np.random.default_rng([sim_seed, index])
    height = float(rng.uniform(*MOUND_HEIGHTS_M))
    if truth and site.truth is not None and site.truth.height_m is not None:
        height = site.truth.height_m  # the inventory's height
    seed = 1000 * sim_seed + index + 1
    lat, lon, alt = enu_to_geodetic(origin, np.array([[site.x_m, site.y_m, 0.0]]))[0]
    ground = terrain.preset("bin_tepe", mound=bool(truth), seed=seed,
                            diameter_m=site_diameter_m, height_m=height,
                            size_m=max(160.0, 8 * site_diameter_m / 3))
    if terrain_input:
        # Over the survey's DEM: the site's own terrain, z = 0 at the mission's ground of
        # the site, so the simulated flight has the mission's heights above it.
        from mound.geometry.dem import lonlat_to_crs

        x, y = lonlat_to_crs(terrain_input.dem, float(lon), float(lat))
        ground = replace(ground, dem_path=terrain_input.dem, dem_x_m=x, dem_y_m=y,
                         dem_ground_m=float(terrain_input.ground_amsl_m),
                         dem_vertical=terrain_input.vertical)
        ground.check()
    spec = sim.SimSpec(
        terrain=ground,
        width_px=image_size[0], height_px=image_size[1], pattern=pattern,
        seed=seed, origin={"lat": float(lat), "lon": float(lon), "alt_m": float(alt)})
    return spec, {"mound": bool(truth), "height_m": height if truth else 0.0,
                  "truth": "known" if site.truth is not None else "unknown",
                  "diameter_m": site_diameter_m, "seed": seed}


@dataclass(frozen=True)
class CardSpec:
    start: datetime = datetime(2026, 6, 1, 9, 0, 0)
    speed_mps: float = 10.0
    shot_every_s: float = 2.0        # over a site
    transit_every_s: float = 10.0    # between sites (0: no transit frames)
    transit_clear_m: float = 40.0    # transit frames this far beyond a scan's reach
    transit_alt_m: float = 60.0      # above the origin's datum
    between_flights_s: float = 1800.0
    sim_seed: int = 1
    image_size: tuple[int, int] = (640, 480)
    pattern: str = "raster"
    site_diameter_m: float = DEFAULT_SITE_DIAMETER_M
    quality: int = 95
    threads: int | None = None
    # a second look's card (the survey's second_look/plan.json): each site flown with a
    # scan this many times as wide (mound.sim.looks.wider), 1: the survey's own scan
    scan_factor: float = 1.0

    def check(self) -> None:
        for name in ("speed_mps", "shot_every_s", "between_flights_s", "site_diameter_m"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) > 0):
                raise InputError(f"--{name.replace('_', '-')}: must be > 0")
        if not (math.isfinite(self.scan_factor) and 1 <= self.scan_factor <= 10):
            raise InputError("--scan-factor: must be in [1, 10]")
        if not (math.isfinite(self.transit_every_s) and self.transit_every_s >= 0):
            raise InputError("--transit-every-s: must be >= 0")
        if not 1 <= self.quality <= 100:
            raise InputError("--quality: 1 .. 100")


def _ground_frame(rng: np.random.Generator, size: tuple[int, int]) -> np.ndarray:
    """A transit frame: fields seen from above (value-noise albedo, sensor noise)."""
    from mound.sim.appearance import albedo_grid

    w, h = size
    a = albedo_grid((h, w), 0.1, seed=int(rng.integers(1 << 30)))
    rgb = a + rng.normal(0, 2, (h, w, 3))
    return np.clip(rgb, 0, 255).astype(np.uint8)


@dataclass(frozen=True)
class CardFile:
    """A photo of the card: its flight, its site (None: a transit frame, `reason` says)
    and when it was taken (local time, ISO 8601)."""

    file: str
    flight: int
    site: str | None
    reason: str | None
    time: str

    def to_doc(self) -> JsonObject:
        return {"file": self.file, "flight": self.flight, "site": self.site,
                "reason": self.reason, "time": self.time}


@dataclass(frozen=True)
class CardTruth:
    """What a simulated card holds (mound.card_truth v1): the plan it flew, the card's
    folder, how it was made and each file."""

    plan: str
    card: str
    spec: JsonObject
    files: tuple[CardFile, ...]

    def to_doc(self) -> JsonObject:
        return {"schema": CARD_TRUTH, "version": 1, "plan": self.plan, "card": self.card,
                "spec": self.spec, "files": [f.to_doc() for f in self.files]}


def write_card(plan_path: str, sites_path: str, out_dir: str, spec: CardSpec | None = None
               ) -> CardTruth:
    """Writes the card of the plan's flights into OUT_DIR/DCIM/100MEDIA; returns the
    card's truth (mound.card_truth v1: per file its flight, site or `transit`, time)."""
    from mound.geometry.flight import ScanSpec
    from mound.sim import site as sim
    from mound.sim.looks import wider
    spec = spec or CardSpec()
    spec.check()
    plan = Plan.read(plan_path)
    sites_doc = Sites.read(sites_path)
    if (sites_doc.terrain() or {}).get("nodes"):
        raise InputError(f"{sites_path}: sites over a DEM: mound sim flight simulates flat "
                         "flights only (the survey driver simulates DEM ones)")
    if plan.origin is None:
        raise InputError(f"{plan_path}: origin: missing (the card's photos are geotagged)")
    index = {s.id: k for k, s in enumerate(sites_doc.sites)}
    by_id = sites_doc.by_id()
    points = {w.id: np.array([w.x_m, w.y_m]) for w in plan.waypoints}
    scan = plan.scan() or ScanSpec(pattern=spec.pattern, site_diameter_m=spec.site_diameter_m)
    reach = scan.reach_m()
    # Transit frames through the scan's lens at the card's image size.
    transit_fx = Camera.from_fov(spec.image_size[0], spec.image_size[1], scan.hfov_rad).fx
    origin = plan.origin
    site_xy = np.array([points[i] for i in by_id if i in points]) if points else np.zeros((0, 2))
    folder = Path(out_dir) / "DCIM" / "100MEDIA"
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng([spec.sim_seed, 99])
    files: list[CardFile] = []
    when = spec.start

    def name() -> Path:
        return folder / f"DJI_{len(files) + 1:04d}.JPG"

    for number, f in enumerate(plan.flights, start=1):
        if not f.sites and len(plan.flights) > 1:
            continue  # of several flights, one with nothing to visit is not flown
        tour = f.tour
        for a_id, b_id in itertools.pairwise(tour):
            a, b = points[a_id], points[b_id]
            leg = float(np.linalg.norm(b - a))
            if spec.transit_every_s > 0:
                step = spec.speed_mps * spec.transit_every_s
                for s in np.arange(step, leg, step):
                    p = a + (b - a) * (s / leg)
                    if len(site_xy) and np.min(np.linalg.norm(site_xy - p, axis=1)) < (
                            reach + spec.transit_clear_m):
                        continue
                    lat, lon, alt = enu_to_geodetic(origin, np.array(
                        [[p[0], p[1], spec.transit_alt_m]]))[0]
                    t = when + timedelta(seconds=s / spec.speed_mps)
                    path = name()
                    save_jpeg(_ground_frame(rng, spec.image_size), path,
                              ExifFacts(float(lat), float(lon), float(alt), t,
                                        transit_fx, spec.image_size[0]),
                              spec.quality)
                    files.append(CardFile(str(path.relative_to(out_dir)), number, None,
                                          "transit", t.isoformat()))
            when += timedelta(seconds=leg / spec.speed_mps)
            if b_id not in by_id:
                continue  # home
            site_spec, _ = survey_site_spec(by_id[b_id], index[b_id], origin,
                                            spec.sim_seed, spec.image_size, spec.pattern,
                                            spec.site_diameter_m)
            if spec.scan_factor != 1:
                site_spec = wider(site_spec, spec.scan_factor)
            with tempfile.TemporaryDirectory(prefix="card_site_") as tmp:
                sim.simulate(site_spec, tmp, threads=spec.threads)
                shots = site_jpegs(tmp, when, spec.shot_every_s, spec.quality)
                for file, t in shots:
                    path = name()
                    shutil.move(str(Path(tmp) / file), path)
                    files.append(CardFile(str(path.relative_to(out_dir)), number, b_id, None,
                                          t.isoformat()))
            when = shots[-1][1] + timedelta(seconds=spec.shot_every_s) if shots else when
        when += timedelta(seconds=spec.between_flights_s)
    return CardTruth(str(plan_path), str(out_dir),
                     {**{k: v for k, v in spec.__dict__.items() if k != "start"},
                      "start": spec.start.isoformat(), "reach_m": reach}, tuple(files))
