"""QGroundControl `.plan` (MAVLink items for PX4 and ArduPilot; uav/files.py): the
reference format, written last, keeping what the other formats wrote or refused."""

from __future__ import annotations

from pathlib import Path

from mound.errors import InputError
from mound.jsonio import json_text
from mound.uav import files
from mound.uav.mission_format import (
    About,
    Content,
    FileFormat,
    Record,
    WriteOptions,
    record_doc,
)
from mound.uav.mission_items import Mission
from mound.uav.route import Route, items_route

LIMITS = ("the mission's own (MAVLink float32 numbers, the flight budget, the terrain "
          "clearance), checked when it is built: never refused alone")


class QgcPlan(FileFormat):
    def check(self, opts: WriteOptions) -> None:
        if opts.firmware not in files.FIRMWARE:
            raise InputError(f"--firmware: {opts.firmware!r} is not one of "
                             f"{', '.join(files.FIRMWARE)}")

    def describe(self, m: Mission, opts: WriteOptions) -> About:
        return {"firmware": opts.firmware,
                "heights": "above home" + ("'s ground" if m.terrain else "")}

    def write(self, m: Mission, path: Path, opts: WriteOptions,
              record: Record) -> list[tuple[Path, Content]]:
        doc = files.plan_document(m, opts.firmware)
        mound = doc["mound"]
        assert isinstance(mound, dict)  # plan_document writes it
        mound["formats"] = record_doc(record)
        return [(path, json_text(doc))]

    def read(self, path: Path) -> tuple[str, list[Route]]:
        items, _, kind = files.read_mission(path)
        return f"{kind}, heights above home", [items_route(items)]


FORMAT = QgcPlan("qgc_plan", ".plan", "--out",
                 "QGroundControl .plan file (MAVLink: PX4, ArduPilot)", LIMITS, 0,
                 reference=True)
