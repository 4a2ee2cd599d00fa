"""Rasters of a site from its point cloud, as GeoTIFFs in the UTM zone of the site's origin.

The cloud lies in the site's local ENU frame (metres, WGS84 origin stated in recon.json).
Each point is taken to geodetic coordinates exactly (mound.geometry.geodesy) and then to
UTM (PROJ through pyproj), so the rasters are north-up grids in a projected CRS that QGIS
places correctly. Heights are metres above the datum of the model's origin (recon.json's
`origin.alt_datum`): the WGS84 ellipsoid (a poses file; DJI photos with an RTK fix) or
EGM96 (the photos' EXIF GPS altitude, above sea level): then the files' CRS is compound,
UTM + EGM96 height (EPSG:326zz+5773), and every height band says which.

- DSM (digital surface model): the highest point of each cell; empty cells are nodata.
- DTM (terrain): a progressive morphological ground filter (Zhang et al. 2003) on the cell
  minima less their plane trend (fitted to the low half) — openings with windows doubling up
  to `ground_window_m`; a cell is off-ground when one opening lowers it by more than
  dh0 + s * (the window's growth), dh0 = 0.2 m, s = 0.02 (relief steeper than 2 % beyond the
  trend is thinned; a tumulus's flanks, 10-30 %, are removed) — then the ground cells
  interpolated linearly over the grid (nearest value outside their hull).
  A DTM the filter leaves too little ground for (fewer than MIN_GROUND_SHARE of the
  observed cells, or fewer than MIN_GROUND_CELLS) is not written: it would be the
  triangles of a few cells and the LRM the surface less a constant. `rasters.json` then
  says `status: failed` and why, the DSM, hillshade and orthophoto are still written,
  and `mound recon rasters` exits 3.
- LRM (local relief model, after Hesse 2010): DSM minus the DTM smoothed by a Gaussian of
  `relief_sigma_m`, so the broad terrain trend is removed and a mound stands out as a
  positive anomaly of its own height.
- Hillshade of the DSM (Horn's gradient, sun azimuth 315 deg, altitude 45 deg), 0-255.
- Orthophoto (RGBA, uint8): every cell's centre at the surface height (the DSM, the DTM in
  its gaps) projected into the registered images with the model's poses and camera
  (distortion included); the cell takes the bilinear colour of the image that sees it most
  nearly from above (the smallest angle between its ray and the vertical). Occlusion is
  not tested: with the nadir raster chosen first this matters only at steep relief.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from scipy import ndimage
from scipy.interpolate import LinearNDInterpolator
from scipy.spatial import cKDTree

from mound.errors import InputError, NoResultError
from mound.formats.rasters import SCHEMA, VERSION, RasterFiles, RastersDoc
from mound.formats.recon import Recon
from mound.geometry.camera import Camera, Pose, project
from mound.geometry.geodesy import Origin, enu_to_geodetic, geodetic_to_enu
from mound.jsonio import staged_file

if TYPE_CHECKING:
    from affine import Affine

NODATA = -9999.0


def utm_epsg(lat_deg: float, lon_deg: float) -> int:
    """The EPSG code of the WGS84 / UTM zone holding (lat, lon): 326zz north, 327zz south
    (the standard 6-degree zones; the Norway and Svalbard exceptions are not applied)."""
    if not (-80 <= lat_deg <= 84):
        raise InputError(f"origin: latitude {lat_deg} is outside UTM's -80..84 degrees")
    zone = min(60, int((lon_deg + 180) // 6) + 1)
    return (32600 if lat_deg >= 0 else 32700) + zone


def enu_to_utm(origin: Origin, enu: np.ndarray, epsg: int) -> np.ndarray:
    """(n, 3) ENU metres -> (n, 3) UTM easting, northing, ellipsoidal height (metres)."""
    from pyproj import Transformer

    llh = enu_to_geodetic(origin, enu)
    to_utm = Transformer.from_crs("EPSG:4326", f"EPSG:{epsg}", always_xy=True)
    e, n = to_utm.transform(llh[:, 1], llh[:, 0])
    return np.stack([np.asarray(e), np.asarray(n), llh[:, 2]], axis=-1)


def utm_to_enu(origin: Origin, e: np.ndarray, n: np.ndarray, h: np.ndarray,
               epsg: int) -> np.ndarray:
    """UTM easting, northing and ellipsoidal height -> (n, 3) ENU metres."""
    from pyproj import Transformer

    to_geo = Transformer.from_crs(f"EPSG:{epsg}", "EPSG:4326", always_xy=True)
    lon, lat = to_geo.transform(e, n)
    return geodetic_to_enu(origin, np.stack([np.asarray(lat), np.asarray(lon), h], axis=-1))


@dataclass(frozen=True)
class Grid:
    """A north-up grid: cell (row, col) covers easting west + res*[col, col+1) and
    northing north - res*[row, row+1)."""
    epsg: int
    west: float
    north: float
    res: float
    width: int
    height: int
    alt_datum: str = "ellipsoid"  # what the heights are above: "ellipsoid" or "egm96"

    @property
    def crs(self) -> str:
        """The files' CRS: UTM, compound with EGM96 height (EPSG:5773) where the heights
        are above the geoid; GeoTIFF has no code for ellipsoidal heights, so those say it
        in each band's description and rasters.json's `vertical_datum`."""
        return f"EPSG:{self.epsg}+5773" if self.alt_datum == "egm96" else f"EPSG:{self.epsg}"

    @property
    def height_words(self) -> str:
        return "m above the EGM96 geoid" if self.alt_datum == "egm96" else \
            "m above the WGS84 ellipsoid"

    @classmethod
    def covering(cls, epsg: int, e: np.ndarray, n: np.ndarray, res: float) -> Grid:
        west = math.floor(float(e.min()) / res) * res
        north = math.ceil(float(n.max()) / res) * res
        if north == float(n.max()):
            north += res
        width = int(math.floor((float(e.max()) - west) / res)) + 1
        height = int(math.floor((north - float(n.min())) / res)) + 1
        if width * height > 50_000_000:
            raise InputError(f"--resolution-m: {res} m gives a {width} x {height} raster "
                             "(more than 5e7 cells)")
        return cls(epsg, west, north, res, width, height)

    def cell(self, e: np.ndarray, n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        col = np.floor((e - self.west) / self.res).astype(np.int64)
        row = np.floor((self.north - n) / self.res).astype(np.int64)
        return row, col

    def transform(self) -> Affine:
        from rasterio.transform import from_origin

        return from_origin(self.west, self.north, self.res, self.res)


def surfaces(grid: Grid, e: np.ndarray, n: np.ndarray,
             z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-cell maximum and minimum of z; NaN where no point falls."""
    row, col = grid.cell(e, n)
    flat = row * grid.width + col
    out = []
    for fill, reduce in ((-np.inf, np.maximum), (np.inf, np.minimum)):
        a = np.full(grid.width * grid.height, fill)
        reduce.at(a, flat, z)
        a[~np.isfinite(a)] = np.nan
        out.append(a.reshape(grid.height, grid.width))
    return out[0], out[1]


def _filled(a: np.ndarray) -> np.ndarray:
    """NaN cells take the value of the nearest observed cell."""
    missing = np.isnan(a)
    if not missing.any():
        return a
    idx = ndimage.distance_transform_edt(missing, return_distances=False, return_indices=True)
    return a[tuple(idx)]


def _plane_trend(z: np.ndarray, observed: np.ndarray) -> np.ndarray:
    """A plane through the low half of the observed cells (two least-squares passes, the
    second on the cells at or below the first plane), evaluated on the whole grid."""
    rr, cc = np.mgrid[0:z.shape[0], 0:z.shape[1]]
    keep = observed.copy()
    coef = np.zeros(3)
    for _ in range(2):
        a = np.stack([np.ones(keep.sum()), rr[keep], cc[keep]], axis=1).astype(float)
        coef, *_ = np.linalg.lstsq(a, z[keep], rcond=None)
        plane = coef[0] + coef[1] * rr + coef[2] * cc
        low = observed & (z <= plane)
        if low.sum() < 3:
            break
        keep = low
    return coef[0] + coef[1] * rr + coef[2] * cc


def ground_model(zmin: np.ndarray, res: float, window_m: float = 80.0, slope: float = 0.02,
                 dh0: float = 0.2, dh_max: float = 2.5) -> tuple[np.ndarray, np.ndarray]:
    """Progressive morphological filter on the cell minima, less their plane trend;
    returns (DTM, ground mask)."""
    observed = ~np.isnan(zmin)
    if observed.sum() < 3:
        raise InputError("cloud: too few cells with points to model the terrain")
    trend = _plane_trend(zmin, observed)
    surface_ = _filled(zmin) - trend
    ground = observed.copy()
    half, prev = 1, 0
    while True:
        size = 2 * half + 1
        opened = ndimage.grey_opening(surface_, size=(size, size))
        dh = min(dh_max, dh0 + slope * 2 * (half - prev) * res)
        ground &= ~(surface_ - opened > dh)
        surface_ = opened
        if half * res * 2 >= window_m:
            break
        prev, half = half, half * 2
    if np.count_nonzero(ground) < 3:  # no surface through them: write_all says why
        return np.full(zmin.shape, np.nan), ground
    # Ground cells keep their minima; the others are interpolated linearly over a Delaunay
    # triangulation of the ground cells, and outside its hull take the nearest ground cell.
    # Only the ground cells beside another cell or the grid's edge are triangulated: a
    # triangle across a gap has its corners on the gap's rim (and the hull's corners are rim
    # cells too), and qhull on every cell of a regular grid took most of a second.
    dtm = np.where(ground, zmin, np.nan)
    todo = np.argwhere(~ground).astype(float)
    if len(todo):
        rim = ground & ndimage.binary_dilation(~ground, structure=np.ones((3, 3), bool))
        rim[[0, -1], :] |= ground[[0, -1], :]
        rim[:, [0, -1]] |= ground[:, [0, -1]]
        rows, cols = np.nonzero(rim)
        pts = np.stack([rows, cols], axis=1).astype(float)
        vals = zmin[rows, cols]
        z = LinearNDInterpolator(pts, vals)(todo)
        out = np.isnan(z)
        if out.any():
            z[out] = vals[cKDTree(pts).query(todo[out])[1]]
        dtm[~ground] = z
    return dtm, ground


def local_relief(dsm: np.ndarray, dtm: np.ndarray, res: float,
                 sigma_m: float = 30.0) -> np.ndarray:
    """Hesse's local relief model: the surface minus the low-pass filtered terrain."""
    trend = ndimage.gaussian_filter(dtm, sigma=sigma_m / res, mode="nearest")
    return dsm - trend


def hillshade(z: np.ndarray, res: float, azimuth_deg: float = 315.0,
              altitude_deg: float = 45.0) -> np.ndarray:
    """0-255 shading of a north-up surface (Horn's gradients); NaN stays NaN."""
    dz_dn, dz_de = np.gradient(_filled(z), res)  # rows run south: d/d(row) = -d/d(north)
    dz_dn = -dz_dn
    slope = np.arctan(np.hypot(dz_de, dz_dn))
    aspect = np.arctan2(-dz_de, -dz_dn)  # direction the slope faces, from north clockwise
    az, alt = np.radians(azimuth_deg), np.radians(altitude_deg)
    shade = (np.sin(alt) * np.cos(slope)
             + np.cos(alt) * np.sin(slope) * np.cos(az - aspect))
    out = np.clip(255 * shade, 0, 255)
    out[np.isnan(z)] = np.nan
    return out


def write_geotiff(path: Path, a: np.ndarray, grid: Grid, description: str) -> None:
    """Float32 GeoTIFF (deflate), NaN written as NODATA; atomically (temporary + rename)."""
    import rasterio

    data = np.where(np.isnan(a), NODATA, a).astype(np.float32)
    with staged_file(path, ".tif") as tmp, rasterio.open(
            tmp, "w", driver="GTiff", width=grid.width, height=grid.height, count=1,
            dtype="float32", crs=grid.crs, transform=grid.transform(),
            nodata=NODATA, compress="deflate") as ds:
        ds.write(data, 1)
        ds.set_band_description(1, description)
        ds.update_tags(1, units="m" if "shade" not in description else "0-255")


def orthophoto(r: Rasters, origin: Origin, camera: Camera,
               views: list[tuple[Pose, Path]]) -> np.ndarray:
    """(height, width, 4) uint8 RGBA: each cell coloured from the image that sees its surface
    point most nearly from above (alpha 0 where no image sees it or no height is known)."""
    from PIL import Image

    g = r.grid
    z = np.where(np.isnan(r.dsm), r.dtm, r.dsm)
    rows, cols = np.nonzero(~np.isnan(z))
    e = g.west + (cols + 0.5) * g.res
    n = g.north - (rows + 0.5) * g.res
    enu = utm_to_enu(origin, e, n, z[rows, cols], g.epsg)
    best = np.full(len(enu), -np.inf)
    which = np.full(len(enu), -1)
    uv_best = np.zeros((len(enu), 2))
    for k, (pose, _) in enumerate(views):
        uv, depth = project(camera, pose, enu)
        inside = (depth > 0) & (uv[:, 0] >= 0) & (uv[:, 1] >= 0) & \
            (uv[:, 0] <= camera.width_px - 1) & (uv[:, 1] <= camera.height_px - 1)
        ray = pose.centre - enu
        score = np.where(inside, ray[:, 2] / np.maximum(np.linalg.norm(ray, axis=1), 1e-9),
                         -np.inf)
        take = score > best
        best[take], which[take], uv_best[take] = score[take], k, uv[take]
    out = np.zeros((g.height, g.width, 4), dtype=np.uint8)
    for k, (_, path) in enumerate(views):
        sel = np.nonzero(which == k)[0]
        if len(sel) == 0:
            continue
        try:
            with Image.open(path) as im:
                img = np.asarray(im.convert("RGB"), dtype=np.float32)
        except OSError as err:
            raise InputError(f"{path}: cannot read the image ({err})") from err
        if img.shape[:2] != (camera.height_px, camera.width_px):
            raise InputError(f"{path}: {img.shape[1]}x{img.shape[0]} pixels, the model's camera "
                             f"is {camera.width_px}x{camera.height_px}")
        coords = [uv_best[sel, 1], uv_best[sel, 0]]
        for c in range(3):
            out[rows[sel], cols[sel], c] = np.clip(np.round(ndimage.map_coordinates(
                img[:, :, c], coords, order=1)), 0, 255).astype(np.uint8)
        out[rows[sel], cols[sel], 3] = 255
    return out


def write_rgba_geotiff(path: Path, rgba: np.ndarray, grid: Grid) -> None:
    """A 4-band uint8 RGBA GeoTIFF (deflate), atomically."""
    import rasterio
    from rasterio.enums import ColorInterp

    with staged_file(path, ".tif") as tmp, rasterio.open(
            tmp, "w", driver="GTiff", width=grid.width, height=grid.height, count=4,
            dtype="uint8", crs=grid.crs, transform=grid.transform(),
            photometric="RGB", compress="deflate") as ds:
        ds.write(np.moveaxis(rgba, 2, 0))
        ds.colorinterp = [ColorInterp.red, ColorInterp.green, ColorInterp.blue,
                          ColorInterp.alpha]


def model_views(recon: Recon, images_dir: Path) -> tuple[Camera, list[tuple[Pose, Path]]]:
    """The camera and the registered images' poses and paths of a reconstruction."""
    if recon.camera is None:
        raise InputError(f"{recon.path}: camera: missing")
    return recon.camera, [(pose, images_dir / name) for name, pose, _ in recon.poses()]


@dataclass
class Rasters:
    grid: Grid
    dsm: np.ndarray
    dtm: np.ndarray
    lrm: np.ndarray
    shade: np.ndarray
    ground: np.ndarray


def from_cloud(origin: Origin, enu: np.ndarray, resolution_m: float = 0.25,
               ground_window_m: float = 80.0, relief_sigma_m: float = 30.0,
               alt_datum: str = "ellipsoid") -> Rasters:
    """The rasters of an ENU cloud (n, 3); its heights, the origin's plus z, above
    `alt_datum` (recon.json's origin.alt_datum)."""
    if alt_datum not in ALT_DATUMS:
        raise InputError(f"origin.alt_datum: expected one of {', '.join(ALT_DATUMS)}, "
                         f"got {alt_datum!r:.40}")
    if not (np.isfinite(resolution_m) and 0.01 <= resolution_m <= 100):
        raise InputError(f"--resolution-m: expected 0.01..100 m, got {resolution_m}")
    if not (np.isfinite(ground_window_m) and 2 * resolution_m <= ground_window_m <= 1e4):
        raise InputError("--ground-window-m: expected 2 cells .. 10 km, got "
                         f"{ground_window_m}")
    if not (np.isfinite(relief_sigma_m) and 0 < relief_sigma_m <= 1e4):
        raise InputError(f"--relief-sigma-m: expected (0, 1e4] m, got {relief_sigma_m}")
    enu = np.asarray(enu, dtype=float)
    if enu.ndim != 2 or enu.shape[1] != 3 or len(enu) == 0:
        raise InputError("cloud: no points")
    enu = enu[np.isfinite(enu).all(axis=1)]
    if len(enu) == 0:
        raise InputError("cloud: no finite points")
    epsg = utm_epsg(origin.lat_deg, origin.lon_deg)
    utm = enu_to_utm(origin, enu, epsg)
    grid = replace(Grid.covering(epsg, utm[:, 0], utm[:, 1], resolution_m), alt_datum=alt_datum)
    dsm, zmin = surfaces(grid, utm[:, 0], utm[:, 1], utm[:, 2])
    dtm, ground = ground_model(zmin, resolution_m, window_m=ground_window_m)
    lrm = local_relief(dsm, dtm, resolution_m, sigma_m=relief_sigma_m)
    return Rasters(grid, dsm, dtm, lrm, hillshade(dsm, resolution_m), ground)


ALT_DATUMS = ("ellipsoid", "egm96")

# The least ground a DTM is made from: a share of the observed cells and a count. See
# docs/densify.md for the shares measured on simulated sites and on a real card.
MIN_GROUND_SHARE = 0.02
MIN_GROUND_CELLS = 100


def ground_failure(r: Rasters) -> str | None:
    """Why the ground filter's DTM cannot be trusted (None: it can)."""
    observed = int(np.count_nonzero(~np.isnan(r.dsm)))
    ground = int(np.count_nonzero(r.ground))
    share = ground / max(observed, 1)
    if share >= MIN_GROUND_SHARE and ground >= MIN_GROUND_CELLS:
        return None
    return (f"too little ground for a terrain model: {ground} of {observed} observed cells "
            f"({100 * share:.3g} %) passed the ground filter (at least "
            f"{100 * MIN_GROUND_SHARE:g} % and {MIN_GROUND_CELLS} cells are needed): the scan "
            "saw little bare ground, or the cloud is too noisy at this cell size; no DTM or "
            "LRM written")


def write_all(r: Rasters, out_dir: Path) -> RasterFiles:
    """dsm.tif, dtm.tif, lrm.tif, hillshade.tif in out_dir (without the DTM and LRM where
    ground_failure says why); returns their description."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    failure = ground_failure(r)
    files = {"dsm": (r.dsm, f"digital surface model, {r.grid.height_words}"),
             "dtm": (r.dtm, f"terrain model (ground filter), {r.grid.height_words}"),
             "lrm": (r.lrm, "local relief model (surface - smoothed terrain), m"),
             "hillshade": (r.shade, "hillshade of the surface model, 0-255")}
    if failure:
        del files["dtm"], files["lrm"]
        for name in ("dtm", "lrm"):
            (out_dir / f"{name}.tif").unlink(missing_ok=True)  # none left from a run before
    for name, (a, desc) in files.items():
        write_geotiff(out_dir / f"{name}.tif", a, r.grid, desc)
    g = r.grid
    observed = int(np.count_nonzero(~np.isnan(r.dsm)))
    doc: RasterFiles = {
        "status": "failed" if failure else "ok",
        "crs": f"EPSG:{g.epsg}", "vertical_datum": g.alt_datum, "file_crs": g.crs,
        "resolution_m": g.res, "width": g.width,
        "height": g.height, "west": g.west, "north": g.north, "nodata": NODATA,
        "files": {k: f"{k}.tif" for k in files},
        "coverage": float(np.mean(~np.isnan(r.dsm))),
        "ground_fraction": float(np.mean(r.ground)),
        "ground_share_of_observed": float(np.count_nonzero(r.ground) / max(observed, 1))}
    if failure:
        doc["reason"] = failure
    return doc


def from_recon(recon_dir: Path, out_dir: Path, resolution_m: float = 0.25,
               cloud: Path | None = None, ground_window_m: float = 80.0,
               relief_sigma_m: float = 30.0, ortho: bool = True,
               images_dir: Path | None = None) -> RastersDoc:
    """The rasters of a mound_recon output (recon.json + points.ply, or `cloud` in the same
    frame), written to out_dir with rasters.json (mound.rasters v1); with `ortho` also
    orthophoto.tif from the images (recon.json's images_dir unless `images_dir`).
    NoResultError (after rasters.json says `status: failed` and why) where the cloud
    leaves too little ground for a DTM."""
    from mound.jsonio import write_json
    from mound.ply import read_ply

    recon_dir = Path(recon_dir)
    recon = Recon.read(recon_dir / "recon.json")
    where = recon.path
    if not recon.ok:
        raise InputError(f"{where}: status is {recon.status!r} "
                         f"({recon.reason or 'no reason given'}): no model to rasterise")
    if recon.frame != "enu" or recon.scale != "metric":
        raise InputError(f"{where}: frame {recon.frame!r}, scale {recon.scale!r}: "
                         "rasters need a metric ENU model (reconstruct with --gps)")
    if recon.origin is None:
        raise InputError(f"{where}: origin: missing (a georeferenced model states it)")
    origin = recon.origin
    # what the model's heights are above (recon.json before 2026-11-29 does not say: its
    # origin came from a poses file, ellipsoidal, or from EXIF, EGM96 — stated, not guessed)
    alt_datum = recon.alt_datum
    datum_note = None
    if alt_datum is None:
        alt_datum = "egm96" if recon.gps_source == "exif" else "ellipsoid"
        datum_note = (f"recon.json states no origin.alt_datum (made before 2026-11-29): "
                      f"{alt_datum} taken from its gps_source")
    if alt_datum not in ALT_DATUMS:
        raise InputError(f"{where}: origin.alt_datum: expected one of "
                         f"{', '.join(ALT_DATUMS)}, got {alt_datum!r:.40}")
    cloud_path = Path(cloud) if cloud else recon_dir / "points.ply"
    xyz, _ = read_ply(cloud_path)
    if len(xyz) == 0:
        raise InputError(f"{cloud_path}: the cloud is empty")
    views, ortho_note = None, "not asked for"
    if ortho:
        named = images_dir or recon.images_dir
        if images_dir and not Path(images_dir).is_dir():
            raise InputError(f"--images: {images_dir} is not a directory")
        if named and Path(str(named)).is_dir():
            camera, found = model_views(recon, Path(str(named)))
            views = (camera, found) if found else None
            ortho_note = "no registered image"
        else:
            ortho_note = f"images_dir {named!r} not found (give --images)"
    r = from_cloud(origin, xyz, resolution_m, ground_window_m, relief_sigma_m, alt_datum)
    summary = write_all(r, out_dir)
    if views is not None:
        write_rgba_geotiff(Path(out_dir) / "orthophoto.tif",
                           orthophoto(r, origin, views[0], views[1]), r.grid)
        summary["files"]["orthophoto"] = "orthophoto.tif"
    else:
        summary["orthophoto_skipped"] = ortho_note
    out: RastersDoc = {"schema": SCHEMA, "version": VERSION, "origin": origin.to_doc(),
                       "cloud": str(cloud_path), "points": int(len(xyz)), **summary}
    if datum_note:
        out["vertical_datum_note"] = datum_note
    write_json(Path(out_dir) / "rasters.json", out)
    if out["status"] == "failed":
        raise NoResultError(f"{out_dir}/rasters.json: {out.get('reason', '?')}")
    return out
