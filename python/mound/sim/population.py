"""A population of tumuli measured in the field: what `mound sim grid --population` draws
its tumuli's sizes from instead of the grid's uniform ranges.

A population file is a GeoJSON FeatureCollection whose features' properties carry the
mound's base `length_m` and `width_m` (m, its longer and shorter extent), `height_m` (m,
above the ground around it) and `robber_trench` (a looters' trench or pit seen in the
field: true, false or null where not recorded) — the Kazanlak inventory's fields
(`../shared/data/kazanlak/mounds.geojson`; `kazanlak` names it). Every row is checked
(`read_population`: InputError naming the file, the feature and the field); a row of
height 0 (a levelled mound: nothing stands to be seen) is left out and counted.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mound.errors import InputError
from mound.jsonio import JsonObject, load_json

KAZANLAK = "kazanlak"  # the Kazanlak inventory, ../shared/data/kazanlak/mounds.geojson
MAX_SIZE_M = 1000.0    # a tumulus's base, m (the largest known, Alyattes's, is 355 m)
MAX_HEIGHT_M = 100.0


@dataclass(frozen=True)
class Tumulus:
    """One measured tumulus: base `length_m` >= `width_m` > 0, `height_m` > 0; `trench`
    True / False, or None where the field did not record it."""

    length_m: float
    width_m: float
    height_m: float
    trench: bool | None


@dataclass(frozen=True)
class Population:
    path: str
    rows: tuple[Tumulus, ...]
    levelled: int  # rows of height 0, left out

    @property
    def trench_share(self) -> float:
        """The share of the rows that record it with a looters' trench."""
        known = [r.trench for r in self.rows if r.trench is not None]
        return sum(known) / len(known) if known else 0.0

    def summary(self) -> JsonObject:
        return {"file": self.path, "rows": len(self.rows), "levelled": self.levelled,
                "trench_share": self.trench_share}


def _number(props: Mapping[str, object], key: str, where: str, upper: float) -> float:
    v = props.get(key)
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise InputError(f"{where}: {key}: expected a number, got {v!r}")
    if not (math.isfinite(v) and 0 <= v <= upper):
        raise InputError(f"{where}: {key}: must be in 0 .. {upper:g}, got {v!r}")
    return float(v)


def parse_population(doc: Any, path: str) -> Population:
    """The population in a parsed GeoJSON document (see the module text)."""
    if not isinstance(doc, dict) or doc.get("type") != "FeatureCollection":
        raise InputError(f"{path}: expected a GeoJSON FeatureCollection")
    features = doc.get("features")
    if not isinstance(features, list):
        raise InputError(f"{path}: features: expected a list")
    rows, levelled = [], 0
    for k, f in enumerate(features):
        where = f"{path}: features[{k}]"
        props = f.get("properties") if isinstance(f, dict) else None
        if not isinstance(props, dict):
            raise InputError(f"{where}: properties: expected an object")
        length = _number(props, "length_m", f"{where}.properties", MAX_SIZE_M)
        width = _number(props, "width_m", f"{where}.properties", MAX_SIZE_M)
        height = _number(props, "height_m", f"{where}.properties", MAX_HEIGHT_M)
        trench = props.get("robber_trench")
        if trench is not None and not isinstance(trench, bool):
            raise InputError(f"{where}.properties: robber_trench: expected true, false or "
                             f"null, got {trench!r}")
        if not (length > 0 and width > 0):
            raise InputError(f"{where}.properties: length_m, width_m: a base must be > 0 "
                             f"across, got {length:g} x {width:g}")
        if height == 0:
            levelled += 1
            continue
        rows.append(Tumulus(max(length, width), min(length, width), height, trench))
    if not rows:
        raise InputError(f"{path}: no tumulus with a height > 0")
    return Population(path, tuple(rows), levelled)


def population_path(name: str) -> Path:
    """The file `name` stands for: `kazanlak` the shared (or cached) inventory, else the
    path itself (InputError naming --population when there is no such file)."""
    if name == KAZANLAK:
        from mound.datasets import cache_dir
        from mound.paths import shared_data_dir

        here = [p / "kazanlak" / "mounds.geojson" for p in (cache_dir(), shared_data_dir())]
        found = [p for p in here if p.is_file()]
        if not found:
            raise InputError(f"--population: no Kazanlak inventory at {here[0]} nor "
                             f"{here[1]}")
        return found[0]
    p = Path(name)
    if not p.is_file():
        raise InputError(f"--population: no file {name}")
    return p


def read_population(name: str) -> Population:
    """The population `name` names (population_path), read and checked."""
    path = population_path(name)
    return parse_population(load_json(path), str(path))
