"""Synthetic satellite scenes for the tests: textured ground with painted round "mounds",
written as real GeoTIFFs (rasterio) in UTM 35N, and their labels as WGS84 GeoJSON (PROJ)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
from scipy import ndimage

EPSG = 32635
WEST, NORTH = 366000.0, 4727000.0


def texture(rng: np.random.Generator, h: int, w: int) -> np.ndarray:
    """Fields: value noise at two scales plus pixel noise (digital numbers ~ 300)."""
    coarse = ndimage.zoom(rng.standard_normal((h // 16 + 2, w // 16 + 2)), 16, order=1)[:h, :w]
    fine = ndimage.gaussian_filter(rng.standard_normal((h, w)), 1.5)
    return 300 + 25 * coarse + 12 * fine + 4 * rng.standard_normal((h, w))


def make_scene(path: Path, seed: int, size: int = 240, n_mounds: int = 4, res: float = 1.0,
               nodata_border: int = 0, west: float = WEST, north: float = NORTH,
               descriptions: tuple[str, ...] | None = ("blue", "green", "red", "nir"),
               crs: bool = True, transform: bool = True) -> list[tuple[float, float]]:
    """A 4-band float32 scene with `n_mounds` mounds (disc of radius 9-13 px: brighter in
    red/green, darker in NIR, a shaded south-east flank); returns their (x, y) in EPSG:32635."""
    import rasterio
    from rasterio.transform import from_origin

    rng = np.random.default_rng(seed)
    bands = np.stack([texture(rng, size, size) * f for f in (0.8, 0.9, 1.0, 1.3)])
    yy, xx = np.mgrid[0:size, 0:size]
    centres = []
    margin = min(60, size // 3) + nodata_border
    while len(centres) < n_mounds:
        r, c = rng.uniform(margin, size - margin, 2)
        if all(np.hypot(r - a, c - b) > 45 for a, b in centres):
            centres.append((r, c))
    for r, c in centres:
        rad = rng.uniform(9, 13)
        d = np.hypot(yy - r, xx - c)
        dome = np.clip(1 - (d / rad) ** 2, 0, None)
        shade = dome * (1 + 0.6 * ((yy - r) + (xx - c)) / rad)
        bands[0] += 40 * shade
        bands[1] += 55 * shade
        bands[2] += 60 * shade
        bands[3] -= 70 * dome
    nodata = -9999.0
    if nodata_border:
        b = nodata_border
        bands[:, :b, :] = nodata
        bands[:, :, :b] = nodata
    profile: dict[str, Any] = {"driver": "GTiff", "width": size, "height": size, "count": 4,
                               "dtype": "float32", "nodata": nodata}
    if crs:
        profile["crs"] = f"EPSG:{EPSG}"
    if transform:
        profile["transform"] = from_origin(west, north, res, res)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # NotGeoreferencedWarning for the bad-input cases
        with rasterio.open(path, "w", **profile) as ds:
            ds.write(bands.astype(np.float32))
            if descriptions:
                for k, d in enumerate(descriptions, start=1):
                    ds.set_band_description(k, d)
    return [(west + (c + 0.5) * res, north - (r + 0.5) * res) for r, c in centres]


def to_lonlat(xy: list[tuple[float, float]]) -> list[tuple[float, float]]:
    from pyproj import Transformer

    tr = Transformer.from_crs(f"EPSG:{EPSG}", "EPSG:4326", always_xy=True)
    return [tuple(map(float, tr.transform(x, y))) for x, y in xy]  # type: ignore[misc]


def write_labels(path: Path, mounds: list[tuple[float, float]],
                 not_mounds: list[tuple[float, float]] = (),  # type: ignore[assignment]
                 extra: dict[str, Any] | None = None) -> Path:
    feats = []
    for kind, pts in (("mound", mounds), ("not_mound", not_mounds)):
        for k, (lon, lat) in enumerate(to_lonlat(list(pts))):
            feats.append({"type": "Feature", "id": f"{kind}{k}",
                          "geometry": {"type": "Point", "coordinates": [lon, lat]},
                          "properties": {"kind": kind, "height_m": 6.0}})
    doc = {"type": "FeatureCollection", "features": feats, **(extra or {})}
    path.write_text(json.dumps(doc))
    return path
