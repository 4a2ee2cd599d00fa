"""`QGC WPL 110` waypoint text (Mission Planner, MAVProxy; uav/files.py): the MAVLink
items with home as item 0."""

from __future__ import annotations

from pathlib import Path

from mound.uav import files
from mound.uav.mission_format import Content, WriteOptions
from mound.uav.mission_items import Mission
from mound.uav.route import Route, items_route


class Wpl:
    name = "wpl"
    suffix = ".waypoints"
    option = "--wpl"
    help = "also a 'QGC WPL 110' waypoint file (Mission Planner, MAVProxy)"
    limits = "the .plan's (the same MAVLink items)"
    order = 1
    reference = False
    readable = True

    def check(self, opts: WriteOptions) -> None:
        return None

    def describe(self, m: Mission, opts: WriteOptions) -> dict[str, object]:
        return {"heights": "above home" + ("'s ground" if m.terrain else "")}

    def write(self, m: Mission, path: Path, opts: WriteOptions,
              record: dict[str, dict[str, object]]) -> list[tuple[Path, Content]]:
        return [(path, files.wpl_text(m))]

    def read(self, path: Path) -> tuple[str, list[Route]]:
        items, _, kind = files.read_mission(path)
        return f"{kind}, heights above home", [items_route(items)]


FORMAT = Wpl()
