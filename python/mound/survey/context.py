"""What every stage of the survey shares: the stage names in order, the run's Context (its
options, run directory, ledger and the keys of the stages run), `run_stage` (run a stage
unless the ledger holds it unchanged) and the digests and options the stages' keys are
made of."""

from __future__ import annotations

import functools
import os
import time
import uuid
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mound.datasets import sha256_of
from mound.formats.survey import StageRun
from mound.geometry.flight import ScanSpec, scan_for_site
from mound.survey.ledger import Ledger, StageRecord, digest
from mound.survey.options import (
    SurveyOptions,
)
from mound.survey.tree import RunTree

if TYPE_CHECKING:
    from mound.uav.mission_items import TerrainInput

@dataclass
class Context:
    args: SurveyOptions
    tree: RunTree
    ledger: Ledger
    stages: list[StageRun] = field(default_factory=list)
    keys: dict[str, str] = field(default_factory=dict)
    # The stages' names in their order: the stage table's (mound.survey.stages.TABLE),
    # set when the stages run; from `redo_from` on (a name; None: none) they are redone.
    order: tuple[str, ...] = ()
    redo_from: str | None = None
    run_id: str = field(default_factory=lambda: uuid.uuid4().hex)
    started: float = field(default_factory=time.time)

    def redoes(self, name: str) -> bool:
        """Whether stage `name` is redone whatever the ledger holds."""
        return (self.redo_from is not None
                and self.order.index(name) >= self.order.index(self.redo_from))

    def before(self, name: str) -> tuple[str, ...]:
        """The stages before `name`, in order."""
        return self.order[:self.order.index(name)]

    @functools.cached_property
    def terrain(self) -> dict[str, object] | None:
        """What the terrain makes of a stage (the DEM's bytes, hashed once per run, and every
        terrain option); None without --dem."""
        return terrain_material(self.args)

    def say(self, text: str) -> None:
        print(text, flush=True)


def run_stage(ctx: Context, name: str, material: Mapping[str, object], work: Any,
              always: bool = False) -> str:
    """Runs `work()` -> (outputs relative to the run directory, a one-line note) unless the
    ledger holds this stage with the same key and its outputs (or `always`); records it."""
    key = digest({"stage": name, **material})
    ctx.keys[name] = key
    redo = always or ctx.redoes(name)
    if not redo and ctx.ledger.is_done(name, key):
        prev = ctx.ledger.previous(name)
        note, wall_s = (prev.note, prev.wall_s) if prev else ("", 0.0)
        ctx.stages.append(StageRun(name, 0.0, True, note, wall_s_when_run=wall_s))
        ctx.say(f"[{name}] skipped, unchanged: {note} (ran in {wall_s:.1f} s)")
        return key
    ctx.ledger.forget(name)
    start = time.perf_counter()
    outputs, note, complete = work()
    wall = time.perf_counter() - start
    if complete:
        ctx.ledger.record(StageRecord(name, key, wall, tuple(outputs), note=note))
    ctx.stages.append(StageRun(name, wall, False, note, complete))
    ctx.say(f"[{name}] {note} ({wall:.1f} s)")
    return key


def digest_files(paths: list[str]) -> list[str]:
    return [sha256_of(Path(p)) for p in paths]


def scan_spec(args: SurveyOptions) -> ScanSpec:

    scan = scan_for_site(args.site_diameter_m, args.scan_pattern)
    from dataclasses import replace
    scan = replace(scan, width_px=args.image_size[0], height_px=args.image_size[1])
    scan.check()
    return scan


def terrain_material(a: SurveyOptions) -> dict[str, object] | None:
    """What the terrain makes of a stage (the DEM's bytes and every terrain option)."""
    if not a.dem:
        return None
    return {"dem": digest_files([a.dem]), "vertical": a.dem_vertical,
            "clearance": a.clearance_m, "scan_clearance": a.scan_clearance_m,
            "footprint": a.footprint_m, "climb": a.climb_factor, "descent": a.descent_factor}


def mission_terrain(a: SurveyOptions) -> TerrainInput | None:
    """The DEM a mission is flown over (mission_items.TerrainInput), None without --dem."""
    if not a.dem:
        return None
    from mound.uav import mission_items
    return mission_items.TerrainInput(a.dem, a.dem_vertical, a.terrain_spec())


def images_root(ctx: Context) -> Path | None:
    """Where each visited site's photos are: the sorted card (--photos), the user's
    folders (--images-root), or nowhere (simulated)."""
    if ctx.args.photos:
        return ctx.tree.photos
    return Path(ctx.args.images_root) if ctx.args.images_root else None


def card_digest(card: Path) -> str:
    """The card's files (names, sizes, times): a changed card is sorted again."""
    rows = []
    for dirpath, _dirs, names in os.walk(card):
        for n in names:
            p = Path(dirpath) / n
            try:
                st = p.stat()
            except OSError:
                continue
            rows.append((str(p.relative_to(card)), st.st_size, st.st_mtime_ns))
    return digest(sorted(rows))


def folder_digest(folder: Path) -> str:
    if not folder.is_dir():
        return "missing"
    return digest(sorted((p.name, p.stat().st_size, p.stat().st_mtime_ns)
                         for p in folder.iterdir() if p.is_file()))
