"""A mission file format, and the one registry of them.

Each format a crew flies or reads is one module of `mound.uav.filetypes` holding a
`FORMAT`: a MissionFormat (its name in mission.json's `formats`, its file suffix, its
`mound mission build` option, its limits, and how it writes a built Mission and reads a
file back as Routes). The registry finds the modules there; `mound mission build` makes
an option of each, the survey writes each flight in each, `mound mission show` reads a
file by its suffix, `mound mission formats` lists them, and the report's map draws every
file it can read back. A new format is a new module there and nothing else.

The `.plan` (MAVLink items) is the reference: it is written last, keeps the record of
what the other formats wrote or refused under `mound.formats`, and is never refused (its
limits are the mission's own, checked when the mission is built). Any other format that a
limit of its own refuses is left out alone, its refusal recorded: one format's refusal
never blocks another.
"""

from __future__ import annotations

import functools
import importlib
import pkgutil
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Literal, Protocol

import numpy as np

from mound.errors import InputError
from mound.formats.mission import About, FormatEntry
from mound.jsonio import JsonObject
from mound.uav.mission_items import Mission
from mound.uav.route import Route

Content = str | bytes
DjiHeights = Literal["relative", "wgs84"]
Record = dict[str, FormatEntry]


@dataclass(frozen=True)
class WriteOptions:
    """What the formats are written with (each reads what it needs)."""

    firmware: str = "px4"             # the .plan's firmwareType: px4 or ardupilot
    aircraft: str = "m3e"             # the DJI aircraft of a WPML file (dji.AIRCRAFT)
    dji_heights: DjiHeights = "relative"
    dem: bool = False                 # the mission was built over a DEM


class MissionFormat(Protocol):
    """One mission file format (a module of `mound.uav.filetypes` holds one as FORMAT)."""

    name: str           # its key in mission.json's `formats` (dji_kmz, litchi_csv, ...)
    suffix: str         # of its files: ".kmz"
    option: str         # `mound mission build`'s option that asks for it: "--dji-kmz"
    help: str           # that option's help
    limits: str         # what it refuses, in a sentence (`mound mission formats`)
    order: int          # where it comes in listings
    reference: bool     # the MAVLink .plan: written last, never refused
    readable: bool      # read() reads its files back (else a map, not a mission)

    def check(self, opts: WriteOptions) -> None:
        """InputError naming the option when `opts` cannot make this format at all."""

    def describe(self, m: Mission, opts: WriteOptions) -> About:
        """What its files are (their heights, aircraft, ...) for mission.json."""

    def write(self, m: Mission, path: Path, opts: WriteOptions,
              record: Record) -> list[tuple[Path, Content]]:
        """The files of mission `m` (path: the flight's file; a format may split it),
        not written yet; InputError naming the limit when the format refuses the mission.
        `record`: the other formats' entries (the reference keeps them)."""

    def read(self, path: Path) -> tuple[str, list[Route]]:
        """(what the file is, its routes) or InputError naming the file and field."""


@dataclass(frozen=True)
class FileFormat:
    """What a format declares (MissionFormat's data) and the defaults most formats keep:
    nothing to check or describe, no reader. A module of mound.uav.filetypes subclasses it
    with its write (and read) and holds an instance as FORMAT."""

    name: str
    suffix: str
    option: str
    help: str
    limits: str
    order: int
    reference: bool = False
    readable: bool = True

    def check(self, opts: WriteOptions) -> None:
        return None

    def describe(self, m: Mission, opts: WriteOptions) -> About:
        return {}

    def read(self, path: Path) -> tuple[str, list[Route]]:
        raise InputError(f"{path}: a {self.name} file is not read back")


@functools.cache
def registry() -> tuple[MissionFormat, ...]:
    """Every format, in listing order: each module of mound.uav.filetypes's FORMAT."""
    from mound.uav import filetypes

    found = []
    for info in pkgutil.iter_modules(filetypes.__path__):
        module = importlib.import_module(f"{filetypes.__name__}.{info.name}")
        fmt = getattr(module, "FORMAT", None)
        if fmt is None:
            raise RuntimeError(f"{module.__name__}: a module of mound.uav.filetypes holds no "
                               "FORMAT")
        found.append(fmt)
    names = [f.name for f in found]
    if len(set(names)) != len(names) or sum(f.reference for f in found) != 1:
        raise RuntimeError(f"mound.uav.filetypes: names {names} must differ and one format "
                           "be the reference")
    return tuple(sorted(found, key=lambda f: (f.order, f.name)))


def by_name(name: str) -> MissionFormat:
    for f in registry():
        if f.name == name:
            return f
    raise KeyError(name)


def reference() -> MissionFormat:
    """The MAVLink .plan's format: the one every flight is always written in."""
    return next(f for f in registry() if f.reference)


def option_dest(fmt: MissionFormat) -> str:
    """The argparse destination of a format's option (--dji-kmz -> dji_kmz)."""
    return fmt.option.lstrip("-").replace("-", "_")


def check(names: Iterable[str], opts: WriteOptions) -> None:
    """InputError naming the option when a format asked for cannot be made with `opts`."""
    for name in names:
        by_name(name).check(opts)


def write_flight(m: Mission, paths: dict[str, Path], opts: WriteOptions
                 ) -> tuple[list[tuple[Path, Content]], Record]:
    """Flight `m` in the formats `paths` names (format name -> the flight's file): the
    files (not written yet) and mission.json's `formats` record, each format's entry its
    description and `files` (names), or `refused` with the limit and `files` []."""
    outputs: list[tuple[Path, Content]] = []
    record: Record = {}
    ordered = sorted((f for f in registry() if f.name in paths), key=lambda f: f.reference)
    for fmt in ordered:
        about = fmt.describe(m, opts)
        try:
            files = fmt.write(m, paths[fmt.name], opts, dict(record))
        except InputError as e:
            if fmt.reference:
                raise
            record[fmt.name] = FormatEntry(about, refused=str(e))
            continue
        outputs += files
        record[fmt.name] = FormatEntry(about, tuple(p.name for p, _ in files))
    return outputs, record


def refusals(record: Record) -> list[str]:
    """`NAME not written: why` of each format the record says was refused."""
    return [f"{name} not written: {e.refused}" for name, e in record.items()
            if e.refused is not None]


def record_doc(record: Record) -> JsonObject:
    """mission.json's `formats` (and the .plan's `mound.formats`)."""
    return {name: e.to_doc() for name, e in record.items()}


def for_path(path: str | Path) -> MissionFormat:
    """The readable format of a file, by its suffix; a file of another suffix is read as
    the reference reads (MAVLink .plan or WPL text, told apart by content)."""
    suffix = Path(path).suffix.lower()
    for f in registry():
        if f.readable and f.suffix == suffix:
            return f
    for f in registry():
        if f.suffix == suffix:
            raise InputError(f"{path}: a {f.name} file is not a mission a reader flies "
                             f"(readable: {', '.join(readable_suffixes())})")
    return reference()


def readable_suffixes() -> list[str]:
    return [f.suffix for f in registry() if f.readable]


def read_any(path: str | Path) -> tuple[str, list[Route]]:
    """(what the file is, its routes: one per wayline or file) of any readable format's
    file. Heights as the file states them (a WGS84 KMZ's are ellipsoidal)."""
    return for_path(path).read(Path(path))


def show(path: str | Path) -> str:
    """A table of the mission's waypoints (one block per wayline)."""
    what, routes = read_any(path)
    lines = [f"{path}: {what}"]
    for k, r in enumerate(routes):
        if len(routes) > 1:
            lines.append(f"wayline {k}")
        lines.append(f"{'#':>4} {'lat':>12} {'lon':>13} {'height_m':>9} {'speed':>6} "
                     f"{'photo_m':>8} {'pitch':>6} {'heading':>8}")
        for i, p in enumerate(r.points):
            heading = "path" if p.heading_deg is None else f"{p.heading_deg:.1f}"
            photo = f"{p.photo_every_m:.2f}" if p.photo_every_m > 0 else "-"
            lines.append(f"{i:>4} {p.lat_deg:>12.7f} {p.lon_deg:>13.7f} {p.height_m:>9.2f} "
                         f"{p.speed_m_s:>6.1f} {photo:>8} {p.gimbal_pitch_deg:>6.1f} "
                         f"{heading:>8}")
        length = float(np.sum(r.leg_lengths_m())) if len(r.points) > 1 else 0.0
        lines.append(f"{len(r.points)} waypoints, {length:.0f} m, ends: {r.end}")
    return "\n".join(lines)


def listing() -> str:
    """Every format: name, suffix, option, limits (`mound mission formats`)."""
    lines = []
    for f in registry():
        role = "reference" if f.reference else ("read back" if f.readable else "written only")
        lines.append(f"{f.name:<12} {f.suffix:<11} {f.option:<10} {role}: {f.limits}")
    return "\n".join(lines)
