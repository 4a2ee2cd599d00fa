"""A measured site of a verdict grid (`mound sim grid`), typed: what stands on it
(`SiteTruth`, its truth.json), the rises its verdict judged (`Rise`), its second look, and
how far its tumulus stands out of its ground. `verdict_data.load_grid` reads them from a
grid's files; the verdict model's training, evaluation and bound take them.

Each `from_doc` validates what the model uses, with an InputError naming the file and the
field; a truth keeps its document as written (`SiteTruth.doc`), which the reports copy.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from mound.errors import InputError
from mound.formats.grid import GridRow
from mound.formats.verdict import CANDIDATES, Measurements, Rise, VerdictFile, rises_of
from mound.jsonio import (
    JsonObject,
    JsonValue,
    as_object,
    number_map,
    require_number,
    short_repr,
    xy_metres,
)


def _bool(doc: Mapping[str, object], key: str, where: str, default: bool = False) -> bool:
    v = doc.get(key, default)
    if not isinstance(v, bool):
        raise InputError(f"{where}.{key}: expected true or false, got {short_repr(v)}")
    return v


@dataclass(frozen=True)
class SiteTruth:
    """What stands on a simulated site (sim.terrain.TerrainSpec.truth): a tumulus with its
    size and centre (site frame, m), the most prominent confuser, or bare ground."""

    mound: bool
    kind: str
    height_m: float
    diameter_m: float
    centre_enu_m: tuple[float, float] = (0.0, 0.0)
    profile: str | None = None
    cut: bool = False  # a looters' trench or pit
    doc: Mapping[str, JsonValue] = field(default_factory=dict, compare=False)

    @classmethod
    def from_doc(cls, doc: object, where: str) -> SiteTruth:
        d = as_object(doc, where)
        kind = d.get("kind", "tumulus" if d.get("mound") else "flat")
        profile = d.get("profile")
        if not isinstance(kind, str) or not (profile is None or isinstance(profile, str)):
            raise InputError(f"{where}: kind and profile: expected strings")
        return cls(_bool(d, "mound", where), kind,
                   require_number(d, "height_m", where, lo=0.0),
                   require_number(d, "diameter_m", where, lo=0.0),
                   xy_metres(d["centre_enu_m"], f"{where}.centre_enu_m") if "centre_enu_m" in d
                   else (0.0, 0.0), profile,
                   _bool(d, "trench", where) or _bool(d, "pit", where), dict(d))

    def to_doc(self) -> JsonObject:
        """The truth as written (built from the fields for one made in code)."""
        if self.doc:
            return dict(self.doc)
        return {"mound": self.mound, "kind": self.kind, "height_m": self.height_m,
                "diameter_m": self.diameter_m, "centre_enu_m": list(self.centre_enu_m),
                **({"profile": self.profile} if self.profile else {})}

    @property
    def terrain_kind(self) -> str:
        """The ground the site was drawn on, as the figures split it: ridges (terraced or
        not), or a DEM's patch or undulating ground with its regional slope (flat, 2-15 or
        15-35 degrees); "unknown" for a truth that does not say."""
        d = self.doc
        slope = d.get("slope_deg")
        if not isinstance(slope, int | float) or "dem" not in d:
            return "unknown"
        if d.get("ridge_relief_m"):  # on a regional slope of at most 10 degrees
            return "ridges, terraced" if d.get("terrace_step_m") else "ridges"
        grade = "flat" if slope == 0 else "2-15 deg" if slope < 15 else "15-35 deg"
        return f"{'dem' if d.get('dem') else 'undulating'}, {grade}"

    @property
    def reach_m(self) -> float:
        """How far from the site centre the object reaches (its centre's offset + radius)."""
        return math.hypot(*self.centre_enu_m) + self.diameter_m / 2


@dataclass(frozen=True)
class GridSite:
    """A site of a grid: its truth, and when measured (`measured`: its verdict is ok) the
    rises its verdict judged, the chosen one, the second look's rises (None: not flown or
    no verdict), the site's disc, the cloud and coverage its verdict names, and its
    tumulus's relief (terrain.mound_relief; None without one or without the surface)."""

    dir: str
    truth: SiteTruth
    measured: bool = False
    rises: tuple[Rise, ...] = ()
    rise: Rise | None = None
    second: tuple[Rise, ...] | None = None
    relief: Mapping[str, float] | None = None
    grid: str = ""
    terrain: Mapping[str, object] | None = None  # the grid row's spec.terrain, as written
    cloud: str = "unknown"  # "dense", "sparse" (the verdict's cloud), unknown: no verdict
    coverage: str | None = None  # the verdict's coverage.status ("clipped", ...)
    site_centre_enu_m: tuple[float, float] | None = None
    site_radius_m: float | None = None
    # the ground it stands on (verdict.json's measurements.terrain; None: an older verdict)
    ground: Mapping[str, float] | None = None
    # the candidate rises its verdict measured (measurements.candidates; site_ground before
    # verdicts named it): a model scores only sites measured with the set it was trained on
    candidates: str = CANDIDATES[0]

    @property
    def where(self) -> str:
        return f"{self.grid}/{self.dir}" if self.grid else self.dir

    def disc(self) -> tuple[tuple[float, float], float] | None:
        """The scanned site's centre and radius (its verdict's), None without them."""
        if self.site_centre_enu_m is None or self.site_radius_m is None:
            return None
        return self.site_centre_enu_m, self.site_radius_m


def grid_site(row: GridRow, verdict: VerdictFile | None, second: VerdictFile | None,
              grid: str, where: str) -> GridSite:
    """A grid row (grid.json's rows[k]) with its site's verdict (None: not measured) and
    second look's verdict (None: not flown or no verdict); its relief is the caller's to
    add (it reads the site's true surface)."""
    name = row.dir
    truth = SiteTruth.from_doc(row.truth, f"{where}.truth")
    spec = row.spec
    terrain = spec.get("terrain") if spec is not None else None
    terrain_doc = as_object(terrain, f"{where}.spec.terrain") if terrain else None
    if verdict is None:
        return GridSite(name, truth, grid=grid, terrain=terrain_doc)
    m = verdict.measurements or Measurements()
    return GridSite(
        name, truth, verdict.ok, m.judged_rises, m.rise,
        None if second is None else (second.measurements or Measurements()).judged_rises,
        None, grid, terrain_doc, verdict.cloud_kind, verdict.coverage_status,
        m.site_centre_enu_m, m.site_radius_m, m.terrain, m.candidates)


def _relief(v: object, where: str) -> Mapping[str, float] | None:
    if v is None:
        return None
    return number_map(v, where)


def sites_of(docs: Sequence[Mapping[str, object]], where: str = "rows") -> list[GridSite]:
    """Grid sites from rows written as plain objects (a script's, a test's): dir, truth,
    measured (default true), rises, rise, second ({"rises": [...]}), relief, grid, and
    verdict.coverage.status."""
    out = []
    for k, d in enumerate(docs):
        w = f"{where}[{k}]"
        second, rise = d.get("second"), d.get("rise")
        coverage = as_object(d.get("verdict") or {}, f"{w}.verdict").get("coverage")
        status = as_object(coverage, f"{w}.verdict.coverage").get("status") if coverage else None
        out.append(GridSite(
            str(d.get("dir", k)), SiteTruth.from_doc(d.get("truth"), f"{w}.truth"),
            _bool(d, "measured", w, True), rises_of(d.get("rises", []), f"{w}.rises"),
            Rise.from_doc(rise, f"{w}.rise") if rise else None,
            None if second is None else rises_of(
                as_object(second, f"{w}.second").get("rises", []), f"{w}.second.rises"),
            _relief(d.get("relief"), f"{w}.relief"), str(d.get("grid", "")),
            coverage=status if isinstance(status, str) else None))
    return out
