"""rasters.json (`mound recon rasters`, a survey site's rasters/; mound.rasters v1), typed
once: the GeoTIFFs a model was rasterised to (north-up, in the UTM zone of its origin),
what their heights are above, their grid and how much of it the cloud covers. Written by
mound.recon.rasters and printed by its command; the survey keeps a few members in the
site's row. TypedDicts: nothing reads the file back in-process.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import NotRequired, TypedDict

SCHEMA = "mound.rasters"
VERSION = 1


class RasterFiles(TypedDict):
    """What the rasters are (their names: dsm, dtm, lrm, hillshade, orthophoto) and where
    they are written, relative to rasters.json. A failed ground filter leaves out the DTM
    and the LRM."""

    status: str                     # ok | failed (too little ground for a DTM: `reason`)
    crs: str                        # EPSG:326zz / 327zz (+5773 for EGM96 heights)
    vertical_datum: str             # ellipsoid | egm96: what the heights are above
    file_crs: str                   # the CRS the GeoTIFFs state
    resolution_m: float
    width: int
    height: int
    west: float                     # m, the grid's west and north edges (UTM)
    north: float
    nodata: float
    files: dict[str, str]
    coverage: float                 # share of the cells the cloud observed
    ground_fraction: float          # share of the cells the ground filter kept
    ground_share_of_observed: float
    reason: NotRequired[str]
    orthophoto_skipped: NotRequired[str]


class RastersDoc(RasterFiles):
    """The whole of rasters.json: the files, and what they came from."""

    schema: str
    version: int
    origin: Mapping[str, float]     # the model's WGS84 origin (recon.json's)
    cloud: str                      # the cloud rasterised
    points: int
    vertical_datum_note: NotRequired[str]   # a recon.json that did not state its datum
