"""GeoJSON (RFC 7946) of a mission (uav/files.py): the flown path, the sites, each
image's footprint and, over a DEM, each leg's terrain profile. A map of the mission, not
a mission: no reader flies it."""

from __future__ import annotations

from pathlib import Path

from mound.uav import files
from mound.uav.mission_format import About, Content, FileFormat, Record, WriteOptions
from mound.uav.mission_items import Mission


class GeoJson(FileFormat):
    def describe(self, m: Mission, opts: WriteOptions) -> About:
        return {"heights": "coordinates' third value above home" + (
            "'s ground" if m.terrain else "")}

    def write(self, m: Mission, path: Path, opts: WriteOptions,
              record: Record) -> list[tuple[Path, Content]]:
        return [(path, files.geojson_text(m))]


FORMAT = GeoJson("geojson", ".geojson", "--geojson", "also the path, sites and image "
                 "footprints as GeoJSON", "none: a map of the mission", 2, readable=False)
