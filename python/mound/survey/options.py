"""The survey's options, typed: what `python python/mission.py` takes, as one frozen
dataclass. The command line (mound.survey.driver.build_parser) takes its defaults from here
and turns its namespace into a SurveyOptions (from_namespace); the stages read only this.
A script can build one directly: SurveyOptions(out="runs/x", flights=2).check()."""

from __future__ import annotations

import argparse
import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from mound import native
from mound.args import UsageError
from mound.bounds import (
    BUDGET_M,
    CANDIDATES,
    FLIGHTS,
    IMAGE_PX,
    SEED,
    SIM_SEED,
    SITE_DIAMETER_M,
    THREADS,
    TIME_S,
    WORKERS,
    Bound,
)
from mound.errors import InputError
from mound.flightplan.terrain import spec_from_args
from mound.formats.mission import ClearanceSpec
from mound.geometry.flight import DEFAULT_SITE_DIAMETER_M
from mound.jsonio import JsonObject
from mound.recon.tool_options import DensifyOptions

ScanPattern = Literal["raster", "orbit", "both"]
Algo = Literal["alns", "newalg", "newalg-ls", "greedy", "tsiligirides", "glv"]
Firmware = Literal["px4", "ardupilot"]
RewardKind = Literal["entropy", "value"]
DjiAircraft = Literal["m3e", "m3t", "m30", "m300", "m350", "m4e", "mini4pro", "air3"]
DemVertical = Literal["ellipsoid", "egm96", "egm2008"]


SPACING_M = Bound(0, 100_000, "m", above=True)
SEPARATION_M = Bound(0, 10_000, "m")
LEARN_WEIGHT = Bound(0, 1e6, above=True)
MAX_FEATURES = Bound(100, 1_000_000, integer=True)
DENSE_PX = Bound(0, 8_192, "px", integer=True)   # 0: no dense cloud, else at least 32
# Every number of the options and its bound: the parser's flags and check() use these.
NUMBERS: dict[str, Bound] = {
    "field_seed": SEED, "spacing": SPACING_M, "budget": BUDGET_M, "candidates": CANDIDATES,
    "min_separation_m": SEPARATION_M, "site_diameter_m": SITE_DIAMETER_M, "plan_seed": SEED,
    "flights": FLIGHTS, "learn_weight": LEARN_WEIGHT, "image_size": IMAGE_PX,
    "sim_seed": SIM_SEED, "max_features": MAX_FEATURES, "dense_size": DENSE_PX,
    "site_timeout": TIME_S, "workers": WORKERS, "site_threads": THREADS}
# The options whose flag is not their name in kebab case.
FLAGS = {"site_diameter_m": "--site-diameter"}


@dataclass(frozen=True)
class SurveyOptions:
    out: str = "runs/survey"
    # candidate sites: the paper's field, your sites, or a satellite scene
    field_seed: int = 0
    spacing: float = 250.0              # m between neighbouring sites of the field
    sites: str | None = None            # mound.sites JSON or GeoJSON
    budget: float | None = None         # m; None: the sites file's, else the aircraft's range
    scene: tuple[str, ...] | None = None  # GeoTIFF scene(s)
    labels: str | None = None
    scene_model: str | None = None
    home: str | None = None             # "LAT,LON"
    aoi: str | None = None
    band_names: str | None = None
    candidates: int = 20
    min_separation_m: float = 30.0
    # flight
    scan_pattern: ScanPattern = "raster"
    site_diameter_m: float = DEFAULT_SITE_DIAMETER_M       # --site-diameter
    algo: Algo = "alns"
    reward: RewardKind = "entropy"      # what a visit is worth to the planner
    confusion: str | None = None        # --reward value: the verdict's three-answer confusion
    plan_seed: int = 1
    flights: int = 1
    dem: str | None = None
    dem_vertical: DemVertical | None = None
    clearance_m: float = ClearanceSpec.clearance_m
    scan_clearance_m: float = ClearanceSpec.scan_clearance_m
    footprint_m: float = ClearanceSpec.footprint_m
    climb_factor: float = ClearanceSpec.climb_factor
    descent_factor: float = ClearanceSpec.descent_factor
    connect: str | None = None
    firmware: Firmware = "px4"
    aircraft: DjiAircraft = "m3e"       # the DJI aircraft of mission.kmz
    # 3-D stage
    photos: str | None = None
    second_photos: str | None = None
    camera: str | None = None
    images_root: str | None = None
    learn: bool = False
    learn_weight: float = 1.0
    cards: tuple[str, ...] | None = None  # --learn, battery by battery: battery k's card
    image_size: tuple[int, int] = (640, 480)  # px
    sim_seed: int = 1
    max_features: int | None = None     # None: by the photos' source (recon.defaults)
    dense_size: int | None = None       # px; 0: no dense cloud; None: the verdict model's
    reference: str | None = None        # PLY: the paper's test instead of the detector
    verdict_model: str | None = None    # the dense cloud's verdict model; None: built in
    site_timeout: float = 1800.0        # s per tool run of a site
    # scale-out
    scheduler: str | None = None
    workers: int | None = None
    site_threads: int = 1
    # report
    basemap: str | None = None          # a tile URL for map.html ({z}/{x}/{y}); None: no tiles
    # run
    force: bool = False
    rerun_from: str | None = None
    no_progress: bool = False

    @classmethod
    def from_namespace(cls, ns: argparse.Namespace) -> SurveyOptions:
        """The parser's namespace; its names must be exactly the fields (a parser option
        without a field, or a field without an option, is a bug)."""
        given = vars(ns)
        names = {f.name for f in dataclasses.fields(cls)}
        if set(given) != names:
            raise RuntimeError(f"survey options and parser differ: "
                               f"{sorted(set(given) ^ names)}")
        kw: dict[str, Any] = dict(given)
        kw["image_size"] = tuple(kw["image_size"])
        if kw["scene"] is not None:
            kw["scene"] = tuple(kw["scene"])
        if kw["cards"] is not None:
            kw["cards"] = tuple(kw["cards"])
        return cls(**kw)

    @property
    def scenes(self) -> list[str]:
        """The scene GeoTIFFs (none without --scene)."""
        return list(self.scene or ())

    def as_dict(self) -> JsonObject:
        """JSON-ready (tuples as lists), for summary.json's `options`."""
        return {k: (list(v) if isinstance(v, tuple) else v)
                for k, v in dataclasses.asdict(self).items()}

    def terrain_spec(self) -> ClearanceSpec:
        """The terrain options as the aircraft's ClearanceSpec (validated)."""
        return spec_from_args(self)

    def check(self) -> None:
        """UsageError naming the option (as the command line spells it) when the options
        cannot make a survey; files named must exist, scenes must open."""
        for name, bound in NUMBERS.items():  # NaN, inf and sizes no survey reaches
            value = getattr(self, name)
            for v in (value if isinstance(value, tuple) else (value,)):
                if v is None:
                    continue
                try:
                    bound.check(v, FLAGS.get(name, "--" + name.replace("_", "-")))
                except InputError as e:
                    raise UsageError(str(e)) from None
        if min(self.image_size) < 64:
            raise UsageError("--image-size: at least 64 x 64 px")
        if self.dense_size and self.dense_size < 32:  # None: the model's; 0: none
            raise UsageError("--dense-size: 0 (no dense cloud) or at least 32 px")
        if self.images_root and not Path(self.images_root).is_dir():
            raise UsageError(f"--images-root: {self.images_root} is not a folder")
        if self.photos and not Path(self.photos).is_dir():
            raise UsageError(f"--photos: {self.photos} is not a folder")
        if self.photos and self.images_root:
            raise UsageError("--photos and --images-root: give the card or the sorted folders")
        if self.camera and not self.photos:
            raise UsageError("--camera goes with --photos")
        if self.second_photos and not self.photos:
            raise UsageError("--second-photos goes with --photos (the first card)")
        if self.second_photos and not Path(self.second_photos).is_dir():
            raise UsageError(f"--second-photos: {self.second_photos} is not a folder")
        if self.camera and not Path(self.camera).is_file():
            raise UsageError(f"--camera: {self.camera} not found")
        if self.learn:
            if self.sites or self.scene:
                raise UsageError("--learn: the classifier learns on the field's Statlog "
                                 "features; --sites and --scene sites have none here")
            if self.photos or self.images_root:
                raise UsageError("--learn re-plans each flight after the one before: it "
                                 "flies simulated flights, or real ones with --cards (photos "
                                 "of re-planned flights come one card at a time)")
        self._check_day()
        if self.reference and not Path(self.reference).is_file():
            raise UsageError(f"--reference: {self.reference} not found")
        if self.verdict_model:
            if not Path(self.verdict_model).is_file():
                raise UsageError(f"--verdict-model: {self.verdict_model} not found")
            from mound.recon.model_file import read_verdict_model

            try:
                read_verdict_model(self.verdict_model)
            except InputError as e:
                raise UsageError(f"--verdict-model: {e}") from None
            if self.dense_size == 0 or self.reference:
                raise UsageError("--verdict-model: the dense cloud's model; it needs the dense "
                                 "cloud (--dense-size > 0) and the reference-free verdict (no "
                                 "--reference)")
        if self.dense_size != 0 and not self.reference:
            self._check_cloud_settings()
        if self.sites and not Path(self.sites).is_file():
            raise UsageError(f"--sites: {self.sites} not found")
        if self.scene:
            self._check_scene()
        elif self.labels or self.scene_model or self.aoi:
            raise UsageError("--labels, --scene-model and --aoi go with --scene")
        elif self.home:
            if self.sites:
                raise UsageError("--home: the sites file has its own home and origin")
            from mound.args import parse_lat_lon

            parse_lat_lon(self.home)
        if self.basemap is not None and not (
                self.basemap.startswith(("http://", "https://", "file://"))
                and all(k in self.basemap for k in ("{z}", "{x}", "{y}"))):
            raise UsageError("--basemap: a tile URL with {z}, {x} and {y} "
                             "(http://, https:// or file://)")
        if self.dem:
            if not Path(self.dem).is_file():
                raise UsageError(f"--dem: {self.dem} not found")
            self.terrain_spec()
        for tool in ("mound_plan", "mound_recon", "mound_render"):
            try:
                native.tool_path(tool)
            except FileNotFoundError as e:
                raise UsageError(f"{e}") from None

    def dense_model_path(self) -> str:
        """The dense cloud's verdict model: --verdict-model, else the built-in one."""
        from mound.paths import REPO_ROOT

        return self.verdict_model or str(REPO_ROOT / "data" / "verdict_model_dense.json")

    def densify_options(self) -> DensifyOptions:
        """`mound_recon densify`'s options for the survey's dense clouds: the clouds its
        verdict model was trained on (the model's cloud_settings; --dense-size replaces the
        depth maps' size, which check() refuses unless the model records none); the tool's
        defaults for a model that records nothing (no dense cloud: --dense-size 0)."""
        from mound.recon.defaults import DENSE_SETTINGS
        from mound.recon.model_file import read_verdict_model

        c = read_verdict_model(self.dense_model_path()).cloud_settings or {}
        settings = {k: c[k] for k in DENSE_SETTINGS if k in c}
        if self.dense_size is not None:
            settings["max_image_size"] = self.dense_size
        return DensifyOptions(**settings)

    def _check_day(self) -> None:
        """--cards (a day battery by battery) and --reward value."""
        if self.cards is not None:
            if not self.learn:
                raise UsageError("--cards: the day battery by battery goes with --learn")
            if self.second_photos:
                raise UsageError("--cards: the second looks of a day on cards are flown in "
                                 "its batteries, not from --second-photos")
            if self.connect:
                raise UsageError("--connect: a day on cards uploads no mission; upload "
                                 "battery_K/mission.plan with `mound mission upload`")
            for k, card in enumerate(self.cards, start=1):
                if not Path(card).is_dir():
                    raise UsageError(f"--cards: battery {k}'s card {card} is not a folder")
            if len(self.cards) > self.flights:
                raise UsageError(f"--cards: {len(self.cards)} cards for --flights "
                                 f"{self.flights} batteries")
        if self.confusion and self.reward != "value":
            raise UsageError("--confusion goes with --reward value")
        if self.reward == "value":
            from mound.survey.reward import read_confusion

            if not self.confusion:
                raise UsageError("--reward value: needs --confusion (a verdict model with "
                                 "trained.confusion, or an eval-verdict report)")
            if not Path(self.confusion).is_file():
                raise UsageError(f"--confusion: {self.confusion} not found")
            try:
                read_confusion(self.confusion)
            except InputError as e:
                raise UsageError(f"--confusion: {e}") from None

    def _check_cloud_settings(self) -> None:
        """The dense clouds the survey will make are those its verdict model was trained
        on (the model's cloud_settings), else a usage error naming --dense-size before
        anything is flown."""
        from mound.recon.model_file import cloud_mismatch, read_verdict_model

        path = self.dense_model_path()
        model = read_verdict_model(path)
        if self.dense_size is None or model.cloud_settings is None:
            return  # the model's own settings, or a model that records none
        settings = {k: v for k, v in model.cloud_settings.items() if k != "cloud"}
        why = cloud_mismatch(model, "dense", {**settings, "max_image_size": self.dense_size})
        if why:
            raise UsageError(f"--dense-size {self.dense_size}: {why}; the verdict model "
                             f"({path}) judges only clouds like its training clouds")

    def _check_scene(self) -> None:
        assert self.scene
        if self.sites:
            raise UsageError("--scene and --sites: give one source of candidate sites")
        if not self.home:
            raise UsageError("--home: LAT,LON of the take-off point is needed with --scene")
        if bool(self.labels) == bool(self.scene_model):
            raise UsageError("--scene needs --labels (to learn the model) or --scene-model")
        for opt in ("labels", "scene_model", "aoi"):
            value = getattr(self, opt)
            if value and not Path(value).is_file():
                raise UsageError(f"--{opt.replace('_', '-')}: {value} not found")
        from mound.args import parse_lat_lon
        from mound.scene.raster import open_scene

        parse_lat_lon(self.home)
        for sp in self.scene:
            open_scene(sp)
