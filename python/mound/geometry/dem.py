"""The project's one reader of terrain models: a single-band GeoTIFF DEM/DSM in any CRS.

Positions come in the survey's local ENU frame (metres east/north of a WGS84 origin); PROJ
(pyproj) takes them to the DEM's CRS, the file's own, never an assumption. Heights come
out in metres above mean sea level as the autopilot's AMSL knows it (EGM96): a DEM whose
heights are above the ellipsoid or EGM2008 is converted with PROJ's geoid grids, and
refused with a clear message where those grids are not installed (a guess of the geoid
would put the aircraft tens of metres off).

- `height(xy)`: bilinear heights at points (InputError for a point off the DEM or on
  nodata).
- `corridor_max(a, b, radius)`: the highest terrain within `radius` metres (a box, which
  holds the disk) of any point of the straight segments a -> b, conservatively: the DEM is
  max-filtered by the radius plus a sampling margin and sampled every half pixel along the
  segment; the 2 x 2 pixels around each sample count.

Only the window around the points of interest (`around`, plus a margin) is read.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import math
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from mound.errors import InputError, library_warnings
from mound.geometry.geodesy import Origin, enu_to_geodetic

if TYPE_CHECKING:
    from pyproj import CRS

VERTICALS = ("ellipsoid", "egm96", "egm2008")
# PROJ CRSs of each vertical reference (3-D geographic for the ellipsoid).
_VERTICAL_CRS = {"ellipsoid": "EPSG:4979", "egm96": "EPSG:4326+5773",
                 "egm2008": "EPSG:4326+3855"}
MAX_WINDOW_PX = 64_000_000  # 512 MB of float64
MAX_COORD = 1e9             # |coordinate| of a DEM's corners in its CRS (metres or degrees)
MAX_PIXEL_M = 10_000.0      # a DEM pixel on the ground (SRTM's are 30-90 m)
MAX_MARGIN_M = 100_000.0    # the margin read around the points of interest
LOG = logging.getLogger(__name__)


def _unreadable(path: str, e: Exception) -> InputError:
    msg = " ".join(str(e).split())[:160]
    return InputError(f"{path}: not a readable DEM ({msg})")


# Where PROJ's grids are looked for besides pyproj's own folder (whose wheel ships none):
# $PROJ_DATA's folders, then Debian's proj-data (/usr/share/proj: egm96_15.gtx, which PROJ
# knows as us_nga_egm96_15.tif). Without the grid PROJ would return a zero geoid height
# silently; vertical_shift refuses instead.
PROJ_GRID_DIRS = ("/usr/share/proj",)


@functools.cache
def use_proj_grids() -> tuple[str, ...]:
    """Adds the folders holding PROJ's grids to pyproj's search path (once); the folders
    added."""
    import os

    import pyproj

    added = []
    extra = os.environ.get("PROJ_DATA", "").split(os.pathsep)
    for d in [*extra, *PROJ_GRID_DIRS]:
        if d and os.path.isdir(d) and d not in added:
            pyproj.datadir.append_data_dir(d)
            added.append(d)
    return tuple(added)


@contextlib.contextmanager
def _opened(path: str) -> Iterator[Any]:
    """rasterio.open(path): its errors InputError naming the file; the libraries' warnings
    (a missing geotransform, odd tags) logged when the DEM is refused."""
    import rasterio
    from rasterio.errors import RasterioError

    with library_warnings(LOG):
        try:
            with rasterio.open(path) as ds:
                yield ds
        except RasterioError as e:
            raise _unreadable(path, e) from None


@dataclass(frozen=True)
class Georef:
    """A DEM's position on the earth, checked: its CRS (pyproj), geotransform (file pixel
    corners -> CRS) and the transformers to and from WGS84 (horizontal parts)."""

    crs: Any
    transform: Any
    to_dem: Any      # lon/lat -> the DEM's CRS
    to_lonlat: Any   # the DEM's CRS -> lon/lat


def georef(ds: Any, path: str) -> Georef:
    """The open dataset's CRS and geotransform, each checked: InputError naming the file
    and what is wrong (no CRS, one PROJ cannot read or relate to WGS84, no geotransform, a
    pixel size or tie point that is not finite, a degenerate one)."""
    from pyproj import CRS, Transformer
    from pyproj.exceptions import CRSError, ProjError

    if ds.crs is None:
        raise InputError(f"{path}: the DEM states no CRS")
    try:
        crs = CRS.from_user_input(ds.crs.to_wkt())
    except (CRSError, ProjError) as e:
        raise InputError(f"{path}: the DEM's CRS is not one PROJ reads "
                         f"({' '.join(str(e).split())[:120]})") from None
    tf = ds.transform
    if tf.is_identity:
        raise InputError(f"{path}: the DEM has no geotransform (pixel positions unknown)")
    scale = (tf.a, tf.b, tf.d, tf.e)
    if not all(math.isfinite(v) for v in scale):
        raise InputError(f"{path}: geotransform: the pixel size is not finite {scale}")
    if not (math.isfinite(tf.c) and math.isfinite(tf.f)):
        raise InputError(f"{path}: geotransform: the tie point is not finite ({tf.c}, {tf.f})")
    if not (abs(tf.c) <= MAX_COORD and abs(tf.f) <= MAX_COORD
            and max(abs(v) for v in scale) * max(ds.width, ds.height) <= MAX_COORD):
        raise InputError(f"{path}: geotransform: the DEM reaches beyond {MAX_COORD:g} units "
                         f"of its CRS (tie point ({tf.c:g}, {tf.f:g}), pixel {scale})")
    if not abs(tf.a * tf.e - tf.b * tf.d) >= 1e-18:
        raise InputError(f"{path}: geotransform: degenerate (pixel size {scale})")
    try:
        to_dem = Transformer.from_crs(CRS("EPSG:4326"), _horizontal(crs), always_xy=True)
        to_lonlat = Transformer.from_crs(_horizontal(crs), CRS("EPSG:4326"), always_xy=True)
    except (CRSError, ProjError) as e:
        raise InputError(f"{path}: PROJ cannot relate the DEM's CRS ({crs.name}) to WGS84 "
                         f"({' '.join(str(e).split())[:100]})") from None
    return Georef(crs, tf, to_dem, to_lonlat)


def _horizontal(crs: CRS) -> CRS:
    """The horizontal part of a (maybe compound) pyproj CRS."""
    return crs.to_2d() if crs.is_compound or len(crs.axis_info) == 3 else crs


def _file_georef(path: str) -> Georef:
    """The DEM's own CRS and geotransform, checked (InputError when the file is no raster
    or states no usable position)."""
    with _opened(path) as ds:
        return georef(ds, path)


def file_vertical(crs: Any) -> str | None:
    """What the heights of a DEM with this CRS are above, as far as the CRS says: the
    vertical part of a compound CRS (egm96, egm2008, "other:NAME"), "ellipsoid" for a 3-D
    geographic or projected CRS (its third axis the ellipsoidal height), else None. The
    compound CRS is read first: EPSG:4326+5773 is also "geographic" with three axes, and
    its heights are EGM96 ones."""
    if crs.is_compound:
        for sub in crs.sub_crs_list:
            if sub.is_vertical:
                code = sub.to_epsg()
                name = sub.name.upper()
                if code == 5773 or "EGM96" in name:
                    return "egm96"
                if code == 3855 or "EGM2008" in name:
                    return "egm2008"
                return "other:" + sub.name
        return None
    if len(crs.axis_info) == 3 and (crs.is_geographic or crs.is_projected):
        return "ellipsoid"
    return None


def vertical_shift(vertical: str, lon: np.ndarray, lat: np.ndarray, h: np.ndarray,
                   path: str) -> np.ndarray:
    """Heights of `vertical` at (lon, lat) as EGM96 heights (AMSL), through PROJ grids;
    InputError if PROJ lacks them."""
    if vertical == "egm96":
        return h
    from pyproj.transformer import TransformerGroup

    use_proj_grids()
    with warnings.catch_warnings():  # the missing grid is reported below, as an error
        warnings.simplefilter("ignore", UserWarning)
        group = TransformerGroup(_VERTICAL_CRS[vertical], _VERTICAL_CRS["egm96"],
                                 always_xy=True)
    if not group.transformers or not group.best_available:
        grids = sorted({g.short_name for op in group.unavailable_operations for g in op.grids
                        if not g.available}) or ["us_nga_egm96_15.tif"]
        raise InputError(
            f"{path}: heights above the {vertical} need PROJ's geoid grid ({', '.join(grids)}) "
            f"to become AMSL, and it is not installed (projsync --file {grids[0]}, or "
            "Debian's proj-data for EGM96); or give a DEM in EGM96 heights")
    _, _, out = group.transformers[0].transform(lon, lat, h)
    out = np.asarray(out, dtype=float)
    if not np.all(np.isfinite(out)):
        raise InputError(f"{path}: PROJ could not convert the {vertical} heights to EGM96")
    return out


def _one_band(ds: Any, path: str) -> Georef:
    """The georeferencing of an opened DEM (georef); InputError unless it has one band."""
    if ds.count != 1:
        raise InputError(f"{path}: a DEM has one band, this file has {ds.count}")
    return georef(ds, path)


def valid_cells(path: str, max_px: int = MAX_WINDOW_PX) -> tuple[np.ndarray, Any]:
    """The whole DEM's validity mask (finite and not nodata; rows north to south as in the
    file) and its geotransform (affine: pixel corners -> its CRS); InputError unless it is
    one band of at most `max_px` cells whose CRS is in metres."""
    with _opened(path) as ds:
        g = _one_band(ds, path)
        axes = _horizontal(g.crs).axis_info
        unit = axes[0].unit_name if axes else ""
        if unit not in ("metre", "meter", "m"):
            raise InputError(f"{path}: its CRS ({g.crs.name}) is not in metres but "
                             f"{unit or 'unknown units'} (reproject it)")
        if ds.width * ds.height > max_px:
            raise InputError(f"{path}: {ds.width} x {ds.height} px, more than {max_px:,} "
                             "(a tile of it, please)")
        with np.errstate(invalid="ignore", over="ignore"):  # checked below
            z = ds.read(1).astype(np.float64)
        valid = np.isfinite(z)
        if ds.nodata is not None and math.isfinite(ds.nodata):
            valid &= z != ds.nodata
        return valid, g.transform


@dataclass
class Dem:
    path: str
    origin: Origin
    vertical: str
    z: np.ndarray                   # the window's heights, AMSL (EGM96), float64
    col0: int                       # the window's first column and row in the file
    row0: int
    inverse: Any                    # affine: DEM CRS -> file (col, row), pixel corners
    to_dem: Any                     # pyproj Transformer lon/lat -> DEM CRS
    pixel_m: tuple[float, float]    # a pixel's size on the ground, east and north, m
    crs_name: str
    _filtered: dict[float, np.ndarray] = field(default_factory=dict, repr=False)

    # ---- opening ------------------------------------------------------------------------
    @classmethod
    def open(cls, path: str, origin: Origin, vertical: str | None = None,
             around: np.ndarray | None = None, margin_m: float = 200.0) -> Dem:
        """Reads the DEM window holding the ENU points `around` (n, 2) plus `margin_m`
        (the whole file when None). `vertical` (ellipsoid, egm96, egm2008) says what the
        heights are above; None: what the file's compound CRS says, else InputError."""
        from rasterio.windows import Window

        if vertical is not None and vertical not in VERTICALS:
            raise InputError(f"--dem-vertical: expected one of {', '.join(VERTICALS)}, "
                             f"got {vertical!r}")
        with _opened(path) as ds:
            g = _one_band(ds, path)
            crs, tf, to_dem, to_lonlat = g.crs, g.transform, g.to_dem, g.to_lonlat
            stated = file_vertical(crs)
            if vertical is None:
                if stated is None or stated.startswith("other:"):
                    what = stated[6:] if stated else "no vertical datum"
                    raise InputError(
                        f"{path}: the DEM's CRS states {what}; say what its heights are "
                        "above with --dem-vertical ellipsoid|egm96|egm2008")
                vertical = stated
            elif stated in VERTICALS and stated != vertical:
                raise InputError(f"{path}: the file says its heights are {stated} heights, "
                                 f"--dem-vertical says {vertical}")
            inverse = ~tf
            c0, r0, c1, r1 = 0, 0, ds.width, ds.height
            if around is not None:
                pts = np.asarray(around, dtype=float).reshape(-1, 2)
                if not (np.all(np.isfinite(pts)) and math.isfinite(margin_m)
                        and 0 <= margin_m <= MAX_MARGIN_M):
                    raise InputError(f"{path}: the area to read is not a finite one "
                                     f"(margin {margin_m:g} m)")
                ext = np.array([[-1, -1], [-1, 1], [1, -1], [1, 1]]) * margin_m
                corners = (pts[:, None, :] + ext[None]).reshape(-1, 2)
                col, row = _to_pixel(corners, origin, to_dem, inverse, path)
                c0 = max(0, int(math.floor(col.min())) - 2)
                r0 = max(0, int(math.floor(row.min())) - 2)
                c1 = min(ds.width, int(math.ceil(col.max())) + 3)
                r1 = min(ds.height, int(math.ceil(row.max())) + 3)
                if c0 >= c1 or r0 >= r1:
                    raise InputError(f"{path}: the sites lie off the DEM")
            if (c1 - c0) * (r1 - r0) > MAX_WINDOW_PX:
                raise InputError(f"{path}: the area needed is {c1 - c0} x {r1 - r0} px, "
                                 f"more than {MAX_WINDOW_PX:,} (a coarser DEM, please)")
            with np.errstate(invalid="ignore", over="ignore"):  # checked below
                z = ds.read(1, window=Window(c0, r0, c1 - c0, r1 - r0)).astype(np.float64)
            nodata = ds.nodata
            mid_c, mid_r = (c0 + c1) / 2, (r0 + r1) / 2
            pixel_m = _pixel_size_m(tf, mid_c, mid_r, to_lonlat, origin, path)
            name = crs.name
        bad = ~np.isfinite(z)
        if nodata is not None and math.isfinite(nodata):
            bad |= z == nodata
        z[bad] = np.nan
        if vertical != "egm96" and z.size:
            rr, cc = np.mgrid[0:z.shape[0], 0:z.shape[1]]
            xs, ys = tf @ (cc.ravel() + c0 + 0.5, rr.ravel() + r0 + 0.5)
            lon, lat = to_lonlat.transform(np.asarray(xs), np.asarray(ys))
            ok = np.isfinite(z.ravel())
            flat = z.ravel().copy()
            flat[ok] = vertical_shift(vertical, np.asarray(lon)[ok], np.asarray(lat)[ok],
                                      flat[ok], path)
            z = flat.reshape(z.shape)
        return cls(path, origin, vertical, z, c0, r0, inverse, to_dem, pixel_m, name)

    @classmethod
    def at(cls, path: str, x: float, y: float, vertical: str | None = None,
           margin_m: float = 200.0) -> Dem:
        """The DEM around (x, y) given in its own CRS, with the ENU origin there."""
        if not (math.isfinite(x) and math.isfinite(y)):
            raise InputError(f"{path}: ({x:g}, {y:g}) is not a place in the DEM's CRS")
        lon, lat = _file_georef(path).to_lonlat.transform(x, y)
        if not (math.isfinite(lon) and math.isfinite(lat) and abs(lat) <= 90):
            raise InputError(f"{path}: ({x:g}, {y:g}) is not a place in the DEM's CRS")
        return cls.open(path, Origin(float(lat), float(lon)), vertical,
                        around=np.zeros((1, 2)), margin_m=margin_m)

    # ---- queries -------------------------------------------------------------------------
    def height_crs(self, x: np.ndarray, y: np.ndarray, what: str = "a point",
                   nodata_ok: bool = False) -> np.ndarray:
        """Bilinear AMSL heights at points given in the DEM's own CRS (`nodata_ok`: NaN
        where a cell read is nodata, else InputError)."""
        col, row = self._window_crs(x, y)
        return self._bilinear(col.ravel(), row.ravel(),
                              np.column_stack([np.ravel(x), np.ravel(y)]), what, nodata_ok)

    def inside_crs(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Whether each point given in the DEM's own CRS can be read (its bilinear cells lie
        in the window read), as a boolean array shaped like x."""
        return ~self._off(*self._window_crs(x, y))

    def _window_crs(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(col, row) in the window, pixel centres at integers, of points in the DEM's CRS
        (shaped like x)."""
        col, row = self.inverse @ (np.asarray(x, dtype=float), np.asarray(y, dtype=float))
        return (np.asarray(col, dtype=float) - self.col0 - 0.5,
                np.asarray(row, dtype=float) - self.row0 - 0.5)

    def _off(self, col: np.ndarray, row: np.ndarray) -> np.ndarray:
        """Whether window coordinates (pixel centres at integers) lie off the window."""
        h, w = self.z.shape
        return np.asarray((col < 0) | (row < 0) | (col > w - 1) | (row > h - 1))

    def pixel(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(col, row) in the window, pixel centres at integers, of ENU points (n, 2)."""
        col, row = _to_pixel(np.asarray(xy, dtype=float).reshape(-1, 2), self.origin,
                             self.to_dem, self.inverse, self.path)
        return col - self.col0 - 0.5, row - self.row0 - 0.5

    def _check_inside(self, col: np.ndarray, row: np.ndarray, xy: np.ndarray,
                      what: str) -> None:
        out = self._off(col, row)
        if np.any(out):
            k = int(np.flatnonzero(out)[0])
            p = np.asarray(xy).reshape(-1, 2)[min(k, len(np.asarray(xy).reshape(-1, 2)) - 1)]
            raise InputError(f"{self.path}: {what} at ({p[0]:.1f}, {p[1]:.1f}) m lies off "
                             "the DEM")

    def height(self, xy: np.ndarray, what: str = "a point") -> np.ndarray:
        """Bilinear AMSL heights at ENU points (n, 2)."""
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        col, row = self.pixel(xy)
        return self._bilinear(col, row, xy, what)

    def _bilinear(self, col: np.ndarray, row: np.ndarray, xy: np.ndarray,
                  what: str, nodata_ok: bool = False) -> np.ndarray:
        self._check_inside(col, row, xy, what)
        h, w = self.z.shape
        c0 = np.clip(np.floor(col).astype(int), 0, max(w - 2, 0))
        r0 = np.clip(np.floor(row).astype(int), 0, max(h - 2, 0))
        c1, r1 = np.minimum(c0 + 1, w - 1), np.minimum(r0 + 1, h - 1)
        fc, fr = col - c0, row - r0
        z = self.z
        out = ((z[r0, c0] * (1 - fc) + z[r0, c1] * fc) * (1 - fr)
               + (z[r1, c0] * (1 - fc) + z[r1, c1] * fc) * fr)
        if not nodata_ok and not np.all(np.isfinite(out)):
            k = int(np.flatnonzero(~np.isfinite(out))[0])
            raise InputError(f"{self.path}: {what} at ({xy[k, 0]:.1f}, {xy[k, 1]:.1f}) m "
                             "falls on nodata")
        return out

    def filtered(self, radius_m: float) -> np.ndarray:
        """The window max-filtered over a box of +-radius (plus one pixel) around each
        pixel (nodata counts as +inf: never flown over blind)."""
        key = round(float(radius_m), 6)
        if key not in self._filtered:
            from scipy.ndimage import maximum_filter

            rx = int(math.ceil(radius_m / self.pixel_m[0])) + 1
            ry = int(math.ceil(radius_m / self.pixel_m[1])) + 1
            z = np.where(np.isfinite(self.z), self.z, np.inf)
            self._filtered[key] = maximum_filter(z, size=(2 * ry + 1, 2 * rx + 1),
                                                 mode="nearest")
        return self._filtered[key]

    def corridor_max(self, a: np.ndarray, b: np.ndarray, radius_m: float,
                     what: str = "a leg") -> tuple[np.ndarray, np.ndarray]:
        """(highest terrain, ENU point where it is) within radius_m of each segment
        a[k] -> b[k] (ENU, (n, 2) each)."""
        a = np.asarray(a, dtype=float).reshape(-1, 2)
        b = np.asarray(b, dtype=float).reshape(-1, 2)
        ca, ra = self.pixel(a)
        cb, rb = self.pixel(b)
        self._check_inside(ca, ra, a, what)
        self._check_inside(cb, rb, b, what)
        f = self.filtered(radius_m)
        h, w = f.shape
        best = np.full(len(a), -np.inf)
        where = np.zeros((len(a), 2))
        span = np.maximum(np.abs(cb - ca), np.abs(rb - ra))
        chunk = 256
        for s in range(0, len(a), chunk):
            sl = slice(s, s + chunk)
            k = int(np.ceil(2 * span[sl].max())) + 1 if len(span[sl]) else 1
            t = np.linspace(0.0, 1.0, k + 1)
            cc = ca[sl, None] + (cb - ca)[sl, None] * t[None]
            rr = ra[sl, None] + (rb - ra)[sl, None] * t[None]
            c0 = np.clip(np.floor(cc).astype(int), 0, w - 1)
            r0 = np.clip(np.floor(rr).astype(int), 0, h - 1)
            c1, r1 = np.minimum(c0 + 1, w - 1), np.minimum(r0 + 1, h - 1)
            v = np.maximum(np.maximum(f[r0, c0], f[r0, c1]), np.maximum(f[r1, c0], f[r1, c1]))
            j = np.argmax(v, axis=1)
            rows = np.arange(len(j))
            best[sl] = v[rows, j]
            tj = t[j]
            where[sl] = a[sl] + (b[sl] - a[sl]) * tj[:, None]
        if not np.all(np.isfinite(best)):
            k = int(np.flatnonzero(~np.isfinite(best))[0])
            raise InputError(f"{self.path}: {what} near ENU ({where[k, 0]:.1f}, "
                             f"{where[k, 1]:.1f}) m passes over nodata")
        return best, where


def lonlat_to_crs(path: str, lon: float, lat: float) -> tuple[float, float]:
    """A WGS84 point in the DEM's own CRS."""
    x, y = _file_georef(path).to_dem.transform(float(lon), float(lat))
    return float(x), float(y)


def _to_pixel(xy: np.ndarray, origin: Origin, to_dem: Any, inverse: Any,
              path: str) -> tuple[np.ndarray, np.ndarray]:
    """File (col, row) (pixel corners at integers) of ENU points on the ellipsoid."""
    enu = np.column_stack([xy, np.zeros(len(xy))])
    llh = enu_to_geodetic(origin, enu)
    if len(llh) == 1:  # pyproj takes a one-element array for a point, with a warning
        x, y = to_dem.transform(float(llh[0, 1]), float(llh[0, 0]))
    else:
        x, y = to_dem.transform(llh[:, 1], llh[:, 0])
    x, y = np.atleast_1d(np.asarray(x, dtype=float)), np.atleast_1d(np.asarray(y, dtype=float))
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise InputError(f"{path}: PROJ cannot place the sites in the DEM's CRS")
    col, row = inverse @ (x, y)
    return np.asarray(col, dtype=float), np.asarray(row, dtype=float)


def _pixel_size_m(tf: Any, col: float, row: float, to_lonlat: Any,
                  origin: Origin, path: str) -> tuple[float, float]:
    """A pixel's extent on the ground along columns and rows, metres (through PROJ and
    the ENU frame, so geographic DEMs in degrees are measured too)."""
    from mound.geometry.geodesy import geodetic_to_enu

    pts = [tf @ (col, row), tf @ (col + 1, row), tf @ (col, row + 1)]
    lon, lat = to_lonlat.transform(np.array([p[0] for p in pts]), np.array([p[1] for p in pts]))
    enu = geodetic_to_enu(origin, np.column_stack([lat, lon, np.zeros(3)]))
    dx = float(np.linalg.norm(enu[1, :2] - enu[0, :2]))
    dy = float(np.linalg.norm(enu[2, :2] - enu[0, :2]))
    if not (0 < dx <= MAX_PIXEL_M and 0 < dy <= MAX_PIXEL_M):
        raise InputError(f"{path}: geotransform: a pixel is {dx:g} x {dy:g} m on the ground "
                         f"(a DEM's is in (0, {MAX_PIXEL_M:g}] m)")
    return dx, dy
