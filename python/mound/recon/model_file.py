"""The Python reader of verdict model files (`mound.verdict_model` v1), the twin of the C++
one (`ParseVerdictModel`, cpp/terrain/verdict_model.cc): the same fields, the same bounds,
the same refusals, so that the two languages agree on what a valid model is (the tests feed
both the same corpus of bad files). A defect is an InputError naming the file and the
field, one line; the value returned is the document, its numbers checked.

Fields (n = the detector's 25 features, in any order, each once):
- `features`: the names; `mean`, `std`: n numbers (std in [1e-9, 1e9], mean within +-1e6);
- `basis`: "linear" (default), "hinge" or "hinge_products"; `weights`: n, 3n, or 3n plus
  one per product, within +-1e6; `products` (hinge_products only): pairs of two distinct
  model features, and `product_clip` in (0, 1e6];
- `z_clip`: absent, null, or in (0, 1e6]; `bias` within +-1e6; `threshold` in (0, 1);
  `p_no_rise` in [0, 1];
- `calibration` (optional): {"method": "beta", a, b >= 0 with a + b > 0, both <= 1e6, c
  within +-1e6};
- `second_look` (optional): {p_low in (0, threshold), threshold in (0, 1), scan_factor in
  (1, 100], combine: {first within +-1e6, second in (0, 1e6], bias within +-1e6}};
- `undecided` (optional): {p_low, p_high with 0 < p_low <= p_high < 1}: three answers,
  `label_of`; its optional `by_slope`: 2 to 8 bands {site_slope_rad: [low, high) within
  [-pi/2, pi/2], each from where the last ended, p_low, p_high as above}: the band of a
  site by its measured slope (`band_for`; beyond the first or last, the nearest);
- `cloud_settings` (optional): {"cloud": "dense" | "sparse", and for a dense model the
  densify options of its training clouds, finite numbers within +-1e9, at most 64}: how
  the clouds it was trained on were made; `mound_recon verdict` refuses a cloud made
  otherwise (exit 2 naming the setting);
- `detector` (optional): {"candidates": "site_ground" | "local_relief"}: the candidate rises
  its training sites were measured with (without it site_ground, the built-in models');
  a site measured with another set is `undecided` with reason `model`;
- `reasons` (optional): {cut_roughness, irregular_roughness with 0 < cut <= irregular <
  1000}: the rise's roughness that names an undecided site "cut", and "irregular" (as
  natural rises are), learned by train-verdict;
- `terrain_domain` (optional): {"ranges": {descriptor: [low, high] with low <= high, within
  +-1e9; at least one; names of TERRAIN_DESCRIPTORS}, optionally "neighbours": {k in 1..50,
  centre and scale (> 0): one number per TERRAIN_DESCRIPTORS, points: k to 100,000 sites'
  standardised descriptors, max_distance >= 0}, other fields free}: the ground the model
  was trained on; a site outside any range, or whose mean distance to its k nearest
  training sites exceeds max_distance, is `undecided` with reason `terrain`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple, TypeGuard

from mound.errors import InputError
from mound.jsonio import load_json
from mound.recon.defaults import CANDIDATES

SCHEMA = "mound.verdict_model"
VERSION = 1
BASES = ("linear", "hinge", "hinge_products")
# The detector's features (cpp/terrain/mound_detector.cc, VerdictFeatureNames); the C++
# build refuses a built-in model (data/verdict_model*.json) made for others, and a test
# holds this list to those files.
DETECTOR_FEATURES = (
    "log_height", "log_diameter", "log_aspect", "dome_r2", "roundness", "symmetry", "fill",
    "flank_slope", "clipped", "outside", "offset", "log_snr", "coverage", "log_rises",
    "site_sag", "site_ridge", "roughness", "ring_high", "ring_spread", "ground_slope",
    "shape_cone", "shape_drum", "flat_top", "point_top", "point_spread")

# The site's ground as the terrain domain reads it (TerrainDescriptorNames, same order).
TERRAIN_DESCRIPTORS = ("site_slope_rad", "site_relief_m", "site_sag_m", "site_ridge_m",
                       "ground_noise_m")


class Beta(NamedTuple):
    """The beta calibration of the Platt logit u: logit p = b softplus(u) - a softplus(-u)
    + c (verdict_fit._calibrated)."""

    a: float
    b: float
    c: float


@dataclass(frozen=True)
class SecondLookRule:
    """Fly again the sites whose first p lies in [p_low, threshold of the model); the second
    look's p = sigmoid(first logit p1 + second logit p2 + bias), a mound from `threshold`."""

    p_low: float
    threshold: float
    scan_factor: float
    first: float
    second: float
    bias: float


@dataclass(frozen=True)
class TerrainNeighbours:
    """terrain_domain.neighbours: the training sites' ground, each descriptor of
    TERRAIN_DESCRIPTORS less `centre` over `scale`; a site whose mean distance to its `k`
    nearest lies beyond `max_distance` is ground unlike the training sites'."""

    k: int
    centre: tuple[float, ...]
    scale: tuple[float, ...]
    points: tuple[tuple[float, ...], ...]
    max_distance: float

    @classmethod
    def of(cls, doc: Mapping[str, Any]) -> TerrainNeighbours:
        return cls(int(doc["k"]), tuple(float(v) for v in doc["centre"]),
                   tuple(float(v) for v in doc["scale"]),
                   tuple(tuple(float(v) for v in q) for q in doc["points"]),
                   float(doc["max_distance"]))

    def distance(self, terrain: Mapping[str, float]) -> float:
        """The mean distance of a site's ground to its k nearest training sites."""
        import numpy as np

        z = (np.array([float(terrain[n]) for n in TERRAIN_DESCRIPTORS])
             - np.array(self.centre)) / np.array(self.scale)
        d = np.sqrt(((np.array(self.points) - z) ** 2).sum(axis=1))
        return float(np.sort(d)[: self.k].mean())


@dataclass(frozen=True)
class VerdictModel:
    """A verdict model as the Python side scores with it (the fields of the module text);
    `of` takes a valid document: check_verdict_model's, or verdict_fit.train's own."""

    features: tuple[str, ...]
    mean: tuple[float, ...]
    std: tuple[float, ...]
    weights: tuple[float, ...]
    bias: float
    threshold: float
    p_no_rise: float
    basis: str = "linear"
    z_clip: float | None = None
    products: tuple[tuple[str, str], ...] = ()
    product_clip: float | None = None
    calibration: Beta | None = None
    second_look: SecondLookRule | None = None
    undecided: tuple[float, float] | None = None  # the band [p_low, p_high)
    cloud_settings: dict[str, Any] | None = None  # how its training clouds were made
    # terrain_domain's ranges: descriptor -> (low, high); empty: no domain
    terrain_ranges: tuple[tuple[str, float, float], ...] = ()
    # terrain_domain.neighbours: the training sites' standardised ground (None: none)
    terrain_neighbours: TerrainNeighbours | None = None
    # undecided.by_slope: (slope low, slope high, p_low, p_high), ascending; empty: none
    slope_bands: tuple[tuple[float, float, float, float], ...] = ()
    candidates: str = CANDIDATES[0]  # detector.candidates: the set it was trained on

    @classmethod
    def of(cls, doc: Mapping[str, Any]) -> VerdictModel:
        cal, sl, band = doc.get("calibration"), doc.get("second_look"), doc.get("undecided")
        z_clip, clip = doc.get("z_clip"), doc.get("product_clip")
        return cls(
            tuple(str(n) for n in doc["features"]), tuple(float(x) for x in doc["mean"]),
            tuple(float(x) for x in doc["std"]), tuple(float(x) for x in doc["weights"]),
            float(doc["bias"]), float(doc["threshold"]), float(doc["p_no_rise"]),
            str(doc.get("basis", "linear")), None if z_clip is None else float(z_clip),
            tuple((str(i), str(j)) for i, j in doc.get("products", [])),
            None if clip is None else float(clip),
            Beta(float(cal["a"]), float(cal["b"]), float(cal["c"])) if cal else None,
            SecondLookRule(*(float(sl[k]) for k in ("p_low", "threshold", "scan_factor")),
                           *(float(sl["combine"][k]) for k in ("first", "second", "bias")))
            if sl else None,
            (float(band["p_low"]), float(band["p_high"])) if band else None,
            dict(doc["cloud_settings"]) if "cloud_settings" in doc else None,
            tuple((str(k), float(v[0]), float(v[1]))
                  for k, v in doc.get("terrain_domain", {}).get("ranges", {}).items()),
            terrain_neighbours=TerrainNeighbours.of(doc["terrain_domain"]["neighbours"])
            if "neighbours" in doc.get("terrain_domain", {}) else None,
            slope_bands=tuple((float(b["site_slope_rad"][0]), float(b["site_slope_rad"][1]),
                               float(b["p_low"]), float(b["p_high"]))
                              for b in (band or {}).get("by_slope", [])),
            candidates=str(doc.get("detector", {}).get("candidates", CANDIDATES[0])))

    def band_for(self, slope_rad: float | None) -> tuple[float, float] | None:
        """The undecided band of a site whose measured slope is `slope_rad` (its
        `by_slope` band; the one band without them or without a slope):
        VerdictModel::BandFor."""
        return band_at(self.undecided, self.slope_bands, slope_rad)


def band_at(one: tuple[float, float] | None,
            slope_bands: tuple[tuple[float, float, float, float], ...],
            slope_rad: float | None) -> tuple[float, float] | None:
    """The band of a site of slope `slope_rad` among `slope_bands` ((slope low, slope high,
    p_low, p_high), ascending; beyond the first or last, the nearest), or `one` without
    them or without a slope (VerdictModel.band_for)."""
    if not slope_bands or slope_rad is None or not math.isfinite(slope_rad):
        return one
    for _, hi, p_low, p_high in slope_bands:
        if slope_rad < hi:
            return p_low, p_high
    return slope_bands[-1][2], slope_bands[-1][3]


def _is_number(v: object) -> TypeGuard[int | float]:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def _number(doc: Mapping[str, object], key: str, at: str) -> float:
    if key not in doc:
        raise InputError(f"{at}: {key}: missing required field")
    v = doc[key]
    if not _is_number(v):
        raise InputError(f"{at}: {key}: expected a finite number")
    return float(v)


def _numbers(doc: Mapping[str, object], key: str, n: int, at: str) -> list[float]:
    if key not in doc:
        raise InputError(f"{at}: {key}: missing required field")
    v = doc[key]
    if not isinstance(v, list) or len(v) != n:
        raise InputError(f"{at}: {key}: expected {n} numbers")
    if not all(_is_number(x) for x in v):
        raise InputError(f"{at}: {key}: expected finite numbers")
    return [float(x) for x in v]


def _object(doc: Mapping[str, object], key: str) -> Mapping[str, object] | None:
    v = doc.get(key)
    return v if isinstance(v, dict) else None


def check_verdict_model(doc: Any, source: str) -> VerdictModel:
    """The model of `doc` if it is a valid verdict model, else InputError naming `source`
    and the field (the C++ reader's checks, in its order)."""
    if not isinstance(doc, dict):
        raise InputError(f"{source}: expected a JSON object")
    if doc.get("schema") != SCHEMA:
        raise InputError(f'{source}: schema: expected "{SCHEMA}"')
    version = doc.get("version")
    if not (isinstance(version, int) and not isinstance(version, bool) and version == VERSION):
        raise InputError(f"{source}: version: expected {VERSION}")
    names = doc.get("features")
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
        raise InputError(f"{source}: features: expected a list of names")
    if sorted(names) != sorted(DETECTOR_FEATURES):
        raise InputError(f"{source}: features: made for other features than this detector's "
                         f"({','.join(DETECTOR_FEATURES)})")
    n = len(names)
    if "basis" in doc and doc["basis"] not in BASES:
        raise InputError(f'{source}: basis: expected "linear", "hinge" or "hinge_products"')
    basis = doc.get("basis", "linear")
    products: list[Any] = []
    if basis == "hinge_products":
        products = doc.get("products")  # type: ignore[assignment]
        if not isinstance(products, list) or not products:
            raise InputError(f"{source}: products: expected a list of pairs of feature names")
        for pair in products:
            if not (isinstance(pair, list) and len(pair) == 2
                    and all(isinstance(e, str) and e in names for e in pair)
                    and pair[0] != pair[1]):
                raise InputError(f"{source}: products: each a pair of two of the model's "
                                 "features")
        clip = _number(doc, "product_clip", source)
        if not 0 < clip <= 1e6:
            raise InputError(f"{source}: product_clip: must be > 0 (within 1e6)")
    elif "products" in doc:
        raise InputError(f'{source}: products: only with basis "hinge_products"')
    if doc.get("z_clip") is not None:
        z_clip = _number(doc, "z_clip", source)
        if not 0 < z_clip <= 1e6:
            raise InputError(f"{source}: z_clip: must be > 0 (within 1e6), or absent")
    _numbers(doc, "mean", n, source)
    std = _numbers(doc, "std", n, source)
    width = (3 * n if basis != "linear" else n) + len(products)
    weights = _numbers(doc, "weights", width, source)
    if not all(1e-9 <= s <= 1e9 for s in std):
        raise InputError(f"{source}: std: must be > 0 (within 1e-9 .. 1e9)")
    for key, values in (("mean", doc["mean"]), ("weights", weights)):
        if not all(abs(x) <= 1e6 for x in values):
            raise InputError(f"{source}: {key}: must be within +-1e6")
    if not abs(_number(doc, "bias", source)) <= 1e6:
        raise InputError(f"{source}: bias: must be within +-1e6")
    threshold = _number(doc, "threshold", source)
    p_no_rise = _number(doc, "p_no_rise", source)
    if not 0 < threshold < 1:
        raise InputError(f"{source}: threshold: must be in (0, 1)")
    if not 0 <= p_no_rise <= 1:
        raise InputError(f"{source}: p_no_rise: must be in [0, 1]")
    if "calibration" in doc:
        at = f"{source}: calibration"
        c = _object(doc, "calibration")
        if c is None or c.get("method") != "beta":
            raise InputError(f'{at}: expected {{"method": "beta", "a", "b", "c"}}')
        a, b, cc = (_number(c, k, at) for k in ("a", "b", "c"))
        if not (a >= 0 and b >= 0 and a + b > 0 and a <= 1e6 and b <= 1e6):
            raise InputError(f"{at}: a, b: must be >= 0 (within 1e6), a + b > 0")
        if not abs(cc) <= 1e6:
            raise InputError(f"{at}: c: must be within +-1e6")
    if "second_look" in doc:
        at = f"{source}: second_look"
        sl = _object(doc, "second_look")
        combine = None if sl is None else _object(sl, "combine")
        if sl is None or combine is None:
            raise InputError(f"{at}: expected {{p_low, threshold, scan_factor, combine: "
                             "{first, second, bias}}")
        p_low, thr, factor = (_number(sl, k, at) for k in ("p_low", "threshold",
                                                          "scan_factor"))
        first, second, bias = (_number(combine, k, f"{at}.combine")
                               for k in ("first", "second", "bias"))
        if not 0 < p_low < threshold:
            raise InputError(f"{at}: p_low: must be in (0, threshold)")
        if not 0 < thr < 1:
            raise InputError(f"{at}: threshold: must be in (0, 1)")
        if not 1 < factor <= 100:
            raise InputError(f"{at}: scan_factor: must be in (1, 100]")
        if not 0 < second <= 1e6:
            raise InputError(f"{at}.combine: second: must be in (0, 1e6]")
        if not (abs(first) <= 1e6 and abs(bias) <= 1e6):
            raise InputError(f"{at}.combine: first, bias: must be within +-1e6")
    if "undecided" in doc:
        at = f"{source}: undecided"
        u = _object(doc, "undecided")
        _ordered_pair(u, "p_low", "p_high", 1, at)
        if u is not None and "by_slope" in u:
            _check_slope_bands(u["by_slope"], f"{at}.by_slope")
    if "cloud_settings" in doc:
        at = f"{source}: cloud_settings"
        c = _object(doc, "cloud_settings")
        if c is None or c.get("cloud") not in ("dense", "sparse"):
            raise InputError(f'{at}: expected {{"cloud": "dense" | "sparse", options...}}')
        for name, v in c.items():
            if name != "cloud" and not (_is_number(v) and abs(v) <= 1e9):
                raise InputError(f"{at}: {name[:40]}: expected a finite number")
        if len(c) - 1 > 64:
            raise InputError(f"{at}: more than 64 settings")
        if c["cloud"] == "sparse" and len(c) > 1:
            raise InputError(f"{at}: a sparse cloud has no densify options")
    if "detector" in doc:
        at = f"{source}: detector"
        d = _object(doc, "detector")
        if d is None or len(d) != 1 or not isinstance(d.get("candidates"), str):
            raise InputError(f'{at}: expected {{"candidates": "site_ground" | "local_relief"}}')
        if d["candidates"] not in CANDIDATES:
            raise InputError(f"{at}.candidates: site_ground or local_relief")
    if "reasons" in doc:
        at = f"{source}: reasons"
        _ordered_pair(_object(doc, "reasons"), "cut_roughness", "irregular_roughness", 1000, at)
    if "terrain_domain" in doc:
        at = f"{source}: terrain_domain"
        t = _object(doc, "terrain_domain")
        ranges = _object(t, "ranges") if t is not None else None
        if not ranges:
            raise InputError(f'{at}: expected {{"ranges": {{descriptor: [low, high], ...}}}}')
        for name in ranges:
            if name not in TERRAIN_DESCRIPTORS:
                raise InputError(f"{at}.ranges: {name[:40]}: not a terrain descriptor of this "
                                 "detector")
            lo, hi = _numbers(ranges, name, 2, f"{at}.ranges")
            if not (lo <= hi and abs(lo) <= 1e9 and abs(hi) <= 1e9):
                raise InputError(f"{at}.ranges: {name}: expected [low, high], low <= high")
        if t is not None and "neighbours" in t:
            _check_neighbours(t["neighbours"], f"{at}.neighbours")
    return VerdictModel.of(doc)


def _check_neighbours(doc: object, at: str) -> None:
    """terrain_domain.neighbours (see the module text): ParseTerrainNeighbours's twin."""
    n = len(TERRAIN_DESCRIPTORS)
    if not isinstance(doc, dict):
        raise InputError(f"{at}: expected {{k, centre, scale, points, max_distance}}")
    k = doc.get("k")
    if not (isinstance(k, int) and not isinstance(k, bool) and 1 <= k <= 50):
        raise InputError(f"{at}: k: expected an integer in 1..50")
    centre = _numbers(doc, "centre", n, at)
    scale = _numbers(doc, "scale", n, at)
    if not all(abs(c) <= 1e9 for c in centre) or not all(1e-9 <= v <= 1e9 for v in scale):
        raise InputError(f"{at}: centre within +-1e9, scale in [1e-9, 1e9]")
    points = doc.get("points")
    if not isinstance(points, list) or not k <= len(points) <= 100_000:
        raise InputError(f"{at}: points: expected k to 100,000 points")
    for j, q in enumerate(points):
        if not (isinstance(q, list) and len(q) == n
                and all(_is_number(v) and abs(v) <= 1e9 for v in q)):
            raise InputError(f"{at}: points[{j}]: expected {n} finite numbers")
    d = _number(doc, "max_distance", at)
    if not 0 <= d <= 1e9:
        raise InputError(f"{at}: max_distance: must be in [0, 1e9]")


def _ordered_pair(doc: Mapping[str, object] | None, low_key: str, high_key: str,
                  ceiling: float, at: str) -> tuple[float, float]:
    """Two numbers of an object with 0 < low <= high < ceiling: OrderedPair's twin."""
    if doc is None:
        raise InputError(f"{at}: expected {{{low_key}, {high_key}}}")
    lo, hi = _number(doc, low_key, at), _number(doc, high_key, at)
    if not 0 < lo <= hi < ceiling:
        raise InputError(f"{at}: {low_key}, {high_key}: must be 0 < {low_key} <= {high_key} "
                         f"< {ceiling:g}")
    return lo, hi


def _check_slope_bands(bands: object, at: str) -> None:
    """undecided.by_slope: 2 to 8 bands, ascending and contiguous in [-pi/2, pi/2]."""
    if not isinstance(bands, list) or not 2 <= len(bands) <= 8:
        raise InputError(f"{at}: expected 2 to 8 bands")
    end = -math.pi / 2
    for k, b in enumerate(bands):
        where = f"{at}[{k}]"
        if not isinstance(b, dict):
            raise InputError(f"{where}: expected {{site_slope_rad, p_low, p_high}}")
        r = _numbers(b, "site_slope_rad", 2, where)
        if not -math.pi / 2 - 1e-9 <= r[0] < r[1] <= math.pi / 2 + 1e-9:
            raise InputError(f"{where}: site_slope_rad: must be low < high within "
                             "[-pi/2, pi/2]")
        if k and abs(r[0] - end) > 1e-9:
            raise InputError(f"{where}: site_slope_rad: must start where the last ended")
        end = r[1]
        _ordered_pair(b, "p_low", "p_high", 1, where)


def outside_terrain(model: VerdictModel, terrain: Mapping[str, float]) -> list[str]:
    """The descriptors of a site's ground (verdict.json's `measurements.terrain`) outside
    the model's terrain domain: VerdictModel::OutsideTerrain. A descriptor the domain
    names and `terrain` lacks is an InputError naming it."""
    missing = [name for name, _, _ in model.terrain_ranges if name not in terrain]
    if missing:
        raise InputError(f"measurements.terrain: {missing[0]}: missing (the model's "
                         "terrain_domain ranges it; remeasure the site)")
    out = [name for name, lo, hi in model.terrain_ranges
           if not lo <= float(terrain[name]) <= hi]
    nb = model.terrain_neighbours
    if nb is not None:
        missing = [n for n in TERRAIN_DESCRIPTORS if n not in terrain]
        if missing:
            raise InputError(f"measurements.terrain: {missing[0]}: missing (the model's "
                             "terrain_domain neighbours need it; remeasure the site)")
        if not nb.distance(terrain) <= nb.max_distance:
            out.append("training_distance")
    return out


def cloud_mismatch(model: VerdictModel, cloud: str, options: Mapping[str, object]) -> str | None:
    """What differs between how a cloud was made (`cloud` dense or sparse, densify's
    options) and the model's training clouds (None: nothing, or the model records none):
    the twin of the C++ CheckCloudSettings, for callers that check before they run."""
    c = model.cloud_settings
    if c is None:
        return None
    if cloud != c["cloud"]:
        return f"a {cloud} cloud, and the model was trained on {c['cloud']} clouds"
    for name, want in c.items():
        if name == "cloud":
            continue
        got = options.get(name)
        if not _is_number(got) or abs(got - want) > 1e-9 * max(1.0, abs(want)):
            return (f"{name} {got!r}, the model was trained on clouds made with {want:g} "
                    f"(mound_recon densify --{name.replace('_', '-')} {want:g})")
    return None


def label_of(model: VerdictModel, p: float, two_answer_at: float | None = None,
             slope_rad: float | None = None) -> str:
    """The answer of a (checked) model for p: by its undecided band (for a site of
    `slope_rad`, band_for), "no_mound" below it, "undecided" in [p_low, p_high), "mound"
    from p_high; without a band (or with `two_answer_at` given, the paper's protocol)
    "mound" at p >= that threshold (default the model's): VerdictModel::Label."""
    band = model.band_for(slope_rad)
    if band is not None and two_answer_at is None:
        return "mound" if p >= band[1] else "no_mound" if p < band[0] else "undecided"
    at = model.threshold if two_answer_at is None else two_answer_at
    return "mound" if p >= at else "no_mound"


def read_verdict_model(path: str | Path) -> VerdictModel:
    """The verdict model in `path`, checked (InputError naming the file and field)."""
    return check_verdict_model(load_json(path), str(path))
