"""`QGC WPL 110` waypoint text (Mission Planner, MAVProxy; uav/files.py): the MAVLink
items with home as item 0."""

from __future__ import annotations

from pathlib import Path

from mound.uav import files
from mound.uav.filetypes.qgc_plan import QgcPlan
from mound.uav.mission_format import About, Content, FileFormat, Record, WriteOptions
from mound.uav.mission_items import Mission


class Wpl(FileFormat):
    def describe(self, m: Mission, opts: WriteOptions) -> About:
        return {"heights": "above home" + ("'s ground" if m.terrain else "")}

    def write(self, m: Mission, path: Path, opts: WriteOptions,
              record: Record) -> list[tuple[Path, Content]]:
        return [(path, files.wpl_text(m))]

    read = QgcPlan.read  # the same MAVLink reader (files.read_mission tells them apart)


FORMAT = Wpl("wpl", ".waypoints", "--wpl", "also a 'QGC WPL 110' waypoint file (Mission "
             "Planner, MAVProxy)", "the .plan's (the same MAVLink items)", 1)
