"""The one reader of satellite scenes (GeoTIFF or any raster GDAL reads, through rasterio).

A scene must be north-up (no rotation terms in its geotransform), in a projected CRS whose
unit is the metre (UTM, a national grid): the features are measured in metres. Bands are
chosen by 1-based index (GDAL's numbering) or by name: the names come from the file's band
descriptions, or from `band_names` given by the user for the whole file (IKONOS stamps, as
most GeoTIFFs, carry none). Values are read as they are stored (digital numbers or
reflectance) into float64; a pixel is nodata where any chosen band equals the file's nodata
value or is not finite (NaN in the arrays handed on). Nothing here writes.
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from mound.errors import InputError, library_warnings

if TYPE_CHECKING:
    from pyproj import Transformer
    from rasterio.crs import CRS

LOG = logging.getLogger(__name__)
BAND_ALIASES = {"nir": ("nir", "near-infrared", "near_infrared", "nir1", "b8", "near infrared"),
                "red": ("red", "r", "b4"), "green": ("green", "g", "b3"),
                "blue": ("blue", "b", "b2")}


def _canonical(name: str) -> str:
    n = name.strip().lower()
    for canon, aliases in BAND_ALIASES.items():
        if n in aliases:
            return canon
    return n


@dataclass(frozen=True)
class SceneInfo:
    path: Path
    crs_wkt: str
    epsg: int | None
    transform: tuple[float, float, float, float, float, float]  # a, b, c, d, e, f (GDAL order)
    width: int
    height: int
    count: int
    dtype: str
    nodata: float | None
    band_names: tuple[str, ...]       # canonical names, "" where unknown

    @property
    def res_m(self) -> float:
        return abs(self.transform[0])

    @property
    def west(self) -> float:
        return self.transform[2]

    @property
    def north(self) -> float:
        return self.transform[5]

    def bounds(self) -> tuple[float, float, float, float]:
        """(west, south, east, north) in the scene's CRS."""
        return (self.west, self.north - self.height * self.res_m,
                self.west + self.width * self.res_m, self.north)

    def pixel_of(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(row, col) as floats (pixel centres at .5) of CRS coordinates."""
        return (self.north - y) / self.res_m, (x - self.west) / self.res_m

    def resolve_bands(self, bands: list[str] | None) -> list[int]:
        """1-based band indices of `bands` (indices or names); all bands for None."""
        if not bands:
            return list(range(1, self.count + 1))
        out = []
        for b in bands:
            b = b.strip()
            if b.isdigit():
                k = int(b)
                if not 1 <= k <= self.count:
                    raise InputError(f"--bands: band {k} does not exist in {self.path} "
                                     f"(bands 1..{self.count})")
            else:
                name = _canonical(b)
                if name not in self.band_names:
                    known = ", ".join(n or "?" for n in self.band_names)
                    raise InputError(f"--bands: no band named {b!r} in {self.path} (its bands: "
                                     f"{known}; name them with --band-names)")
                k = self.band_names.index(name) + 1
            if k in out:
                raise InputError(f"--bands: band {b!r} named twice")
            out.append(k)
        return out

    def crs(self) -> CRS:
        from rasterio.crs import CRS

        return CRS.from_wkt(self.crs_wkt)

    def digest(self) -> str:
        from mound.datasets import sha256_of

        return sha256_of(self.path)


def open_scene(path: str | Path, band_names: list[str] | None = None) -> SceneInfo:
    """Validates a scene file and returns its facts; InputError naming the file for a
    missing/non-raster file, no CRS, a geographic or non-metre CRS, a rotated or south-up
    geotransform, or `band_names` of the wrong length."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    with library_warnings(LOG):
        return _checked_scene(path, band_names)


def _checked_scene(path: Path, band_names: list[str] | None) -> SceneInfo:
    import rasterio
    from rasterio.errors import RasterioIOError

    try:
        with rasterio.open(path) as ds:
            crs, tf = ds.crs, ds.transform
            info: dict[str, Any] = {"width": ds.width, "height": ds.height, "count": ds.count,
                                    "dtype": ds.dtypes[0] if ds.count else "",
                                    "nodata": ds.nodata, "descriptions": ds.descriptions}
    except RasterioIOError as e:
        raise InputError(f"{path}: not a raster GDAL can read ({str(e).splitlines()[0][:120]})"
                         ) from None
    if info["count"] < 1 or info["width"] < 1 or info["height"] < 1:
        raise InputError(f"{path}: no pixels or no bands")
    if crs is None:
        raise InputError(f"{path}: no CRS (georeference the scene, e.g. gdal_translate -a_srs)")
    if tf.is_identity:
        raise InputError(f"{path}: no geotransform (pixel positions unknown)")
    if not all(math.isfinite(v) for v in tuple(tf)[:6]):
        raise InputError(f"{path}: geotransform: not finite ({tuple(tf)[:6]})")
    # A projected CRS in metres spans +-2e7 m; a pixel of a scene is at most a few hundred.
    if not (abs(tf.c) <= 1e8 and abs(tf.f) <= 1e8 and 0 < abs(tf.a) <= 10_000
            and abs(tf.a) * max(info["width"], info["height"]) <= 1e8):
        raise InputError(f"{path}: geotransform: origin ({tf.c:g}, {tf.f:g}) or pixel "
                         f"size {tf.a:g} is no place on the earth")
    if tf.b != 0 or tf.d != 0 or tf.e >= 0 or tf.a <= 0:
        raise InputError(f"{path}: geotransform is rotated or not north-up ({tuple(tf)[:6]}); "
                         "warp it north-up first (gdalwarp)")
    if not math.isclose(tf.a, -tf.e, rel_tol=0.01):
        raise InputError(f"{path}: pixels are not square ({tf.a} x {-tf.e})")
    if not crs.is_projected:
        raise InputError(f"{path}: CRS {crs.to_string()} is not projected; the features are "
                         "in metres: warp the scene to a UTM zone (gdalwarp -t_srs EPSG:326zz)")
    unit = (crs.linear_units or "").lower()
    if unit not in ("metre", "meter", "m", "metres", "meters"):
        raise InputError(f"{path}: CRS unit is {crs.linear_units!r}, not metres")
    if info["dtype"] not in ("uint8", "int8", "uint16", "int16", "uint32", "int32",
                             "float32", "float64"):
        raise InputError(f"{path}: pixel type {info['dtype']} is not supported")
    if band_names:
        if len(band_names) != info["count"]:
            raise InputError(f"--band-names: {len(band_names)} names for the {info['count']} "
                             f"bands of {path}")
        names = tuple(_canonical(n) for n in band_names)
    else:
        names = tuple(_canonical(d) if d else "" for d in info["descriptions"])
    named = [n for n in names if n]
    if len(set(named)) != len(named):
        raise InputError(f"{path}: band names are not unique ({', '.join(names)})")
    epsg = crs.to_epsg()
    return SceneInfo(path=path, crs_wkt=crs.to_wkt(), epsg=epsg,
                     transform=(tf.a, tf.b, tf.c, tf.d, tf.e, tf.f), width=info["width"],
                     height=info["height"], count=info["count"], dtype=info["dtype"],
                     nodata=info["nodata"], band_names=names)


# Pixel types whose every value float32 holds exactly: their windows are read as float32
# (half the memory and the bytes handed to the kernel), others as float64.
_FLOAT32_EXACT = {"float32", "uint8", "int8", "uint16", "int16"}


def window_dtype(scene: SceneInfo) -> type[np.floating[Any]]:
    return np.float32 if scene.dtype in _FLOAT32_EXACT else np.float64


def read_window(scene: SceneInfo, bands: list[int], row0: int, col0: int, rows: int,
                cols: int) -> np.ndarray:
    """(len(bands), rows, cols) of the window whose top-left pixel is (row0, col0), float32
    when that holds the scene's pixel type exactly (window_dtype), else float64; parts
    outside the scene and nodata pixels are NaN (in every band where one is)."""
    from rasterio.windows import Window

    dtype = window_dtype(scene)
    r0, c0 = max(row0, 0), max(col0, 0)
    r1, c1 = min(row0 + rows, scene.height), min(col0 + cols, scene.width)
    # A window inside a scene of the window's type is read straight into the result.
    inside = (r0, c0, r1, c1) == (row0, col0, row0 + rows, col0 + cols)
    direct = inside and np.dtype(scene.dtype) == np.dtype(dtype)
    shape = (len(bands), rows, cols)
    out = np.empty(shape, dtype=dtype) if direct else np.full(shape, np.nan, dtype=dtype)
    if r1 <= r0 or c1 <= c0:
        return out
    try:
        window = Window(c0, r0, c1 - c0, r1 - r0)
        with _reading(scene.path, rows, len(bands)) as ds:
            a = ds.read(bands, window=window, out=out) if direct else ds.read(bands, window=window)
    except Exception as e:  # a truncated or corrupt file fails only when its blocks are read
        raise InputError(f"{scene.path}: cannot read pixels ({str(e).splitlines()[0][:120]})"
                         ) from None
    bad = np.zeros(a.shape[1:], dtype=bool)
    for band in a:
        if band.dtype.kind == "f":
            bad |= ~np.isfinite(band)
        if scene.nodata is not None and math.isfinite(scene.nodata):
            bad |= band == band.dtype.type(scene.nodata)
    dst = out[:, r0 - row0:r1 - row0, c0 - col0:c1 - col0]
    if not direct:
        dst[...] = a
    if bad.any():
        dst[:, bad] = np.nan
    return out


# The scenes open for reading: one dataset per file and process, shared by the scoring
# threads under a lock (a GDAL dataset is not safe to read from two threads at once), and
# kept open between blocks, so that GDAL's block cache decompresses each of the file's
# tiles once. Blocks overlap by their halos: the tiles of a block's edge are read again by
# the block beside it (handed to the other thread) and by the row of blocks below. A
# dataset per thread decoded them once per thread, and a cache smaller than a row of
# blocks' tiles decoded them again a row later: on a 10,000-pixel, 4-band DEFLATE scene
# that was 10.0 CPU-s of reading against 3.1 s with one dataset and a cache holding a row
# of blocks (tools/bench/bench_scene.py). The cache holds the tiles that the rows of a
# window span, plus one tile row, across the scene (at least CACHE_MIN, at most CACHE_MAX:
# far below GDAL's default of 5 % of the RAM, which held a 1.2 GB cache per process and
# paused Dask workers at their memory limit). GDAL_CACHEMAX in the environment wins.
CACHE_MIN = 64 * 2**20
CACHE_MAX = 1024 * 2**20
_open_lock = threading.Lock()
_open_sets: dict[tuple[str, int, int], tuple[Any, threading.Lock]] = {}
_cache_bytes = 0


@contextlib.contextmanager
def _reading(path: Path, rows: int, n_bands: int) -> Iterator[Any]:
    """The scene's dataset, held for this thread's read of a window of `rows` rows and
    `n_bands` bands. Re-opened when the file changes; a few scenes open at a time."""
    import rasterio

    while True:
        st = path.stat()
        key = (str(path), st.st_mtime_ns, st.st_size)
        with _open_lock:
            entry = _open_sets.get(key)
            if entry is None:
                for k in [k for k in _open_sets if k[0] == key[0]]:
                    _close(_open_sets.pop(k))
                if len(_open_sets) >= 4:  # scenes of an evaluation: a few at a time
                    _close(_open_sets.pop(next(iter(_open_sets))))
                entry = _open_sets[key] = (rasterio.open(path), threading.Lock())
            ds, lock = entry
            _grow_cache(ds, rows, n_bands)
        with lock:
            if not ds.closed:  # else closed by another thread since: open it again
                yield ds
                return


def _close(entry: tuple[Any, threading.Lock]) -> None:
    with entry[1]:  # after a read in flight
        entry[0].close()


def _grow_cache(ds: Any, rows: int, n_bands: int) -> None:
    """GDAL's block cache raised to hold a row of windows' tiles (see above)."""
    global _cache_bytes
    if "GDAL_CACHEMAX" in os.environ:
        return
    tile_rows = int(ds.block_shapes[0][0]) if ds.block_shapes else 1
    spans = -(-rows // tile_rows) + 2  # the tile rows a window of `rows` rows can touch, + 1
    item = max(np.dtype(t).itemsize for t in ds.dtypes)
    want = spans * tile_rows * ds.width * n_bands * item
    want = min(max(want, CACHE_MIN), CACHE_MAX)
    if want > _cache_bytes:
        from rasterio.env import set_gdal_config

        set_gdal_config("GDAL_CACHEMAX", int(want))
        _cache_bytes = int(want)


def transformer_to_scene(scene: SceneInfo) -> Transformer:
    """pyproj Transformer WGS84 (lon, lat) -> the scene's CRS (x, y)."""
    from pyproj import CRS, Transformer

    return Transformer.from_crs("EPSG:4326", CRS.from_wkt(scene.crs_wkt), always_xy=True)


def transformer_from_scene(scene: SceneInfo) -> Transformer:
    from pyproj import CRS, Transformer

    return Transformer.from_crs(CRS.from_wkt(scene.crs_wkt), "EPSG:4326", always_xy=True)
