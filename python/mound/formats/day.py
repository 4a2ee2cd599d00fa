"""day.json (`mound day`, mound.day v1), typed once: per battery the plan flown, the sites
judged, the second looks added and the plan of the batteries left; the next battery to fly;
the second looks' missions. `mound day` writes it; nothing reads it back in-process (the
crew and outside scripts do), so its members are TypedDicts the writer is checked against.
"""

from __future__ import annotations

from typing import TypedDict

from mound.jsonio import JsonObject

SCHEMA = "mound.day"
VERSION = 1


class BatteryPlan(TypedDict):
    sites: list[str]
    cost_m: float


class Judged(TypedDict):
    id: str
    answer: str | None   # mound, no_mound, undecided or failed; None: not judged yet


class Battery(TypedDict):
    battery: int
    card: str | None
    folder: str
    plan: BatteryPlan
    judged: list[Judged]
    second_looks_added: list[str]
    plan_left: list[list[str]]   # the re-planned flights of the batteries left


class NextBattery(TypedDict):
    battery: int
    folder: str
    sites: list[str]


class SecondLooks(TypedDict):
    folder: str
    sites: list[str]
    scan_factor: float
    refused: list[JsonObject]   # {id, reason}: the looks no mission could fly


class DayDoc(TypedDict):
    schema: str
    version: int
    status: str
    batteries: int
    flown: list[Battery]
    next: NextBattery | None
    second_looks: SecondLooks | None
    stopped: str
    learn_weight: float
