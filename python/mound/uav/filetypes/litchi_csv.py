"""Litchi CSV for the consumer DJI aircraft Litchi flies (uav/litchi.py): a flight over
99 waypoints in parts OUT_part1.csv, ...; altitudes above the take-off point."""

from __future__ import annotations

from pathlib import Path

from mound.uav import litchi
from mound.uav.mission_format import About, Content, FileFormat, Record, WriteOptions
from mound.uav.mission_items import Mission
from mound.uav.route import Route, mission_route


def parts(m: Mission) -> list[str]:
    """The CSV texts of mission `m`, one per part (InputError naming Litchi's limit)."""
    return [litchi.csv_text(r) for r in litchi.prepare(mission_route(m))]


HELP = ("also a Litchi CSV mission (consumer DJI aircraft; a flight over 99 waypoints in "
        "parts OUT_part1.csv, ...)")
LIMITS = (f"{litchi.MAX_WAYPOINTS} waypoints a part, altitudes {litchi.ALTITUDE_RANGE_M[0]:g}.."
          f"{litchi.ALTITUDE_RANGE_M[1]:g} m above take-off, speeds up to "
          f"{litchi.MAX_SPEED_M_S:g} m/s")


class LitchiCsv(FileFormat):
    def describe(self, m: Mission, opts: WriteOptions) -> About:
        return {"heights": "above the take-off point", "crew": litchi.CREW_SETTINGS}

    def write(self, m: Mission, path: Path, opts: WriteOptions,
              record: Record) -> list[tuple[Path, Content]]:
        texts = parts(m)
        return [(litchi.part_path(path, k + 1, len(texts)), t) for k, t in enumerate(texts)]

    def read(self, path: Path) -> tuple[str, list[Route]]:
        pts = litchi.read_litchi(path)
        return ("Litchi CSV, altitudes above take-off",
                [Route(pts[0].lat_deg, pts[0].lon_deg, tuple(pts), "unknown")])


FORMAT = LitchiCsv("litchi_csv", ".csv", "--litchi", HELP, LIMITS, 4)
