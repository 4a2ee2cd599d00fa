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

import functools
import logging
import math
import os
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mound.errors import InputError, library_warnings

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

    def crs(self) -> Any:
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
        ds = _open_for_reading(scene.path)
        window = Window(c0, r0, c1 - c0, r1 - r0)
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


_readers = threading.local()
# GDAL's block cache for the scenes' tiles: enough for the tiles that neighbouring blocks'
# halos share (a 1024-pixel block with its halo spans 3-4 tiles of 512 a side, 4 MB each in
# 4 float32 bands), far below GDAL's default of 5 % of the RAM, which held a 1.2 GB cache
# per process (and paused Dask workers at their memory limit). GDAL_CACHEMAX in the
# environment wins.
CACHE_BYTES = 256 * 2**20


@functools.cache
def _bound_gdal_cache() -> None:
    if "GDAL_CACHEMAX" not in os.environ:
        from rasterio.env import set_gdal_config

        set_gdal_config("GDAL_CACHEMAX", CACHE_BYTES)


def _open_for_reading(path: Path) -> Any:
    """The scene opened for this thread, kept open between blocks: GDAL's block cache then
    decompresses each of the file's tiles once, where a dataset opened per block decoded
    again the tiles its halo shares with the blocks beside it (a third of the reading time
    on a DEFLATE scene). Re-opened when the file changes; closed with the thread."""
    import rasterio

    _bound_gdal_cache()
    st = path.stat()
    key = (str(path), st.st_mtime_ns, st.st_size)
    open_sets: dict[tuple[str, int, int], Any] = _readers.__dict__.setdefault("open", {})
    ds = open_sets.get(key)
    if ds is None or ds.closed:
        for k in [k for k in open_sets if k[0] == key[0]]:
            open_sets.pop(k).close()
        if len(open_sets) >= 4:  # scenes of an evaluation: a few at a time
            open_sets.pop(next(iter(open_sets))).close()
        ds = open_sets[key] = rasterio.open(path)
    return ds


def transformer_to_scene(scene: SceneInfo) -> Any:
    """pyproj Transformer WGS84 (lon, lat) -> the scene's CRS (x, y)."""
    from pyproj import CRS, Transformer

    return Transformer.from_crs("EPSG:4326", CRS.from_wkt(scene.crs_wkt), always_xy=True)


def transformer_from_scene(scene: SceneInfo) -> Any:
    from pyproj import CRS, Transformer

    return Transformer.from_crs(CRS.from_wkt(scene.crs_wkt), "EPSG:4326", always_xy=True)
