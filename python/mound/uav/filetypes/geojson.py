"""GeoJSON (RFC 7946) of a mission (uav/files.py): the flown path, the sites, each
image's footprint and, over a DEM, each leg's terrain profile. A map of the mission, not
a mission: no reader flies it."""

from __future__ import annotations

from pathlib import Path

from mound.errors import InputError
from mound.uav import files
from mound.uav.mission_format import Content, WriteOptions
from mound.uav.mission_items import Mission
from mound.uav.route import Route


class GeoJson:
    name = "geojson"
    suffix = ".geojson"
    option = "--geojson"
    help = "also the path, sites and image footprints as GeoJSON"
    limits = "none: a map of the mission"
    order = 2
    reference = False
    readable = False

    def check(self, opts: WriteOptions) -> None:
        return None

    def describe(self, m: Mission, opts: WriteOptions) -> dict[str, object]:
        return {"heights": "coordinates' third value above home" + (
            "'s ground" if m.terrain else "")}

    def write(self, m: Mission, path: Path, opts: WriteOptions,
              record: dict[str, dict[str, object]]) -> list[tuple[Path, Content]]:
        return [(path, files.geojson_text(m))]

    def read(self, path: Path) -> tuple[str, list[Route]]:
        raise InputError(f"{path}: GeoJSON is a map of the mission, not a mission to fly")


FORMAT = GeoJson()
