"""Issue 54: the readers added with the field work (DEMs, scenes, photo cards, verdict
models) and every number a user gives. Each bad input is built here and must be answered
with exit 2 and one line naming the file and field (or the flag), nothing written; each
of these failed before the fix (an exception, a runaway, a wrong name or a wrong datum)."""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rasterio
from rasterio.transform import Affine, from_origin

from mound import native
from mound.cli import build_parser as mound_parser
from mound.cli import main as mound_main
from mound.errors import InputError
from mound.geometry.dem import Dem, use_proj_grids
from mound.paths import REPO_ROOT
from mound.photos.sort import SortSpec
from mound.recon.model_file import DETECTOR_FEATURES, read_verdict_model
from mound.survey.driver import build_parser as survey_parser
from mound.survey.driver import main as survey_main

PLAN = {"schema": "mound.plan", "version": 1, "tour": ["home", "a", "home"], "closed": True,
        "budget_m": 1e7, "origin": {"lat": 46.05, "lon": 14.5, "alt_m": 300.0},
        "waypoints": [{"id": "home", "x_m": 0.0, "y_m": 0.0, "kind": "home"},
                      {"id": "a", "x_m": 60.0, "y_m": 40.0, "kind": "site",
                       "scan_cost_m": 400.0}]}


def one_line_exit_2(code: int, err: str, *must_name: str) -> None:
    assert code == 2, err
    assert err.count("\n") == 1, err
    for name in must_name:
        assert name in err, err
    assert "Traceback" not in err and "internal error" not in err, err


def write_dem(path: Path, transform: Affine, crs: Any = "EPSG:3794",
              z: np.ndarray | None = None) -> Path:
    z = np.full((60, 60), 300.0, np.float32) if z is None else z.astype(np.float32)
    kw: dict[str, Any] = {"crs": crs} if crs is not None else {}
    if transform is not None:
        kw["transform"] = transform
    with warnings.catch_warnings():  # rasterio warns of a file without a geotransform
        warnings.simplefilter("ignore")
        with rasterio.open(path, "w", driver="GTiff", width=z.shape[1], height=z.shape[0],
                           count=1, dtype="float32", **kw) as ds:
            ds.write(z[None])
    return path


def mission_build(tmp_path: Path, capsys: pytest.CaptureFixture[str], *extra: str,
                  plan: dict[str, Any] | None = None) -> tuple[int, str]:
    p = tmp_path / "plan.json"
    p.write_text(json.dumps(plan or PLAN))
    out = tmp_path / "m.plan"
    code = mound_main(["mission", "build", str(p), "--out", str(out), *extra])
    if code != 0:
        assert not out.exists() and not list(tmp_path.glob("m_*.plan"))
    return code, capsys.readouterr().err


# ------------------------------------------------------------------------------- DEMs

NAN, INF = math.nan, math.inf


@pytest.mark.parametrize("name, transform, must_name", [
    ("NaN pixel size", Affine(NAN, 0, 460000, 0, -1, 101000), "pixel size is not finite"),
    ("inf pixel size", Affine(1, 0, 460000, 0, -INF, 101000), "pixel size is not finite"),
    ("NaN tie point", Affine(1, 0, NAN, 0, -1, 101000), "tie point is not finite"),
    ("inf tie point", Affine(1, 0, 460000, 0, -1, INF), "tie point is not finite"),
    ("tie point 1e300", Affine(1, 0, 1e300, 0, -1, 101000), "reaches beyond"),
    ("a pixel 1e7 m wide", Affine(1e7, 0, 0, 0, -1e7, 5e8), "on the ground"),
])
def test_dem_with_a_bad_geotransform_is_refused(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str], name: str,
                                                transform: Affine, must_name: str) -> None:
    """Was: ValueError (cannot convert float NaN to integer) or OverflowError, exit 1."""
    dem = write_dem(tmp_path / "dem.tif", transform)
    code, err = mission_build(tmp_path, capsys, "--dem", str(dem), "--dem-vertical", "egm96")
    one_line_exit_2(code, err, str(dem), must_name)


@pytest.mark.parametrize("crs", [
    'LOCAL_CS["arbitrary",UNIT["metre",1]]',
    'PROJCS["x",GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],'
    'PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433]],PROJECTION["Foo_Bar"],'
    'UNIT["metre",1]]'])
def test_dem_whose_crs_proj_cannot_use_is_refused(tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str],
                                                 crs: str) -> None:
    """Was: pyproj's ProjError, exit 1."""
    dem = write_dem(tmp_path / "dem.tif", from_origin(460000, 101000, 1, 1), crs=crs)
    code, err = mission_build(tmp_path, capsys, "--dem", str(dem), "--dem-vertical", "egm96")
    one_line_exit_2(code, err, str(dem), "PROJ cannot relate")


def _mound_process(*args: str) -> tuple[int, str]:
    """`python -m mound ARGS` in a process of its own: what a user's terminal shows (the
    tests' own warning capture is not there)."""
    r = subprocess.run([sys.executable, "-m", "mound", *args], capture_output=True,
                       text=True, timeout=120,
                       env={**os.environ, "PYTHONPATH": str(REPO_ROOT / "python")})
    return r.returncode, r.stderr


def test_file_without_a_geotransform_is_refused_in_one_line(tmp_path: Path) -> None:
    """Was: exit 2 in three lines, rasterio's NotGeoreferencedWarning first (a DEM and a
    scene alike)."""
    dem = write_dem(tmp_path / "dem.tif", None)  # type: ignore[arg-type]
    plan = tmp_path / "plan.json"
    plan.write_text(json.dumps(PLAN))
    code, err = _mound_process("mission", "build", str(plan), "--out", str(tmp_path / "m.plan"),
                               "--dem", str(dem), "--dem-vertical", "egm96")
    one_line_exit_2(code, err, str(dem), "no geotransform")
    labels = tmp_path / "labels.geojson"
    labels.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"kind": "mound"},
         "geometry": {"type": "Point", "coordinates": [25.2466, 42.6271]}}]}))
    code, err = _mound_process("scene", "train", str(dem), "--labels", str(labels), "--out",
                               str(tmp_path / "model.json"))
    one_line_exit_2(code, err, str(dem), "no geotransform")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dem.tif", "labels.geojson",
                                                          "plan.json"]


LJUBLJANA = (14.5, 46.05)


def _geographic_dem(tmp_path: Path, crs: str, z: np.ndarray) -> Path:
    return write_dem(tmp_path / f"{crs.replace(':', '_').replace('+', '_')}.tif",
                     from_origin(LJUBLJANA[0] - 0.003, LJUBLJANA[1] + 0.003, 1e-4, 1e-4),
                     crs=crs, z=z)


def _proj_to_egm96(crs: str, lon: np.ndarray, lat: np.ndarray, h: np.ndarray) -> np.ndarray:
    """PROJ's own conversion to EGM96 heights, its geoid grid required."""
    from pyproj.transformer import TransformerGroup

    use_proj_grids()
    group = TransformerGroup(crs, "EPSG:4326+5773", always_xy=True)
    assert group.best_available, "PROJ's EGM96 grid is not found (Debian's proj-data)"
    _, _, out = group.transformers[0].transform(lon, lat, h)
    return np.asarray(out)


def test_compound_geographic_dem_with_egm96_heights_is_read_as_egm96(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """EPSG:4326+5773 was taken for ellipsoidal heights (its 3-axis geographic test ran
    before the vertical part was read): refused, and with the geoid grid found it would
    have been shifted by the geoid height, 46 m here. Its heights are EGM96 ones, as the
    file says; an ellipsoidal DEM of the same place is converted as PROJ converts it."""
    rng = np.random.default_rng(3)
    z = 290 + 20 * rng.random((60, 60))
    dem = _geographic_dem(tmp_path, "EPSG:4326+5773", z)
    d = Dem.open(str(dem), _origin(), None, around=np.zeros((1, 2)), margin_m=50)
    assert d.vertical == "egm96"
    lon, lat = LJUBLJANA
    col = (lon - (LJUBLJANA[0] - 0.003)) / 1e-4 - 0.5
    row = (LJUBLJANA[1] + 0.003 - lat) / 1e-4 - 0.5
    c0, r0 = int(col), int(row)
    fc, fr = col - c0, row - r0
    want = ((z[r0, c0] * (1 - fc) + z[r0, c0 + 1] * fc) * (1 - fr)
            + (z[r0 + 1, c0] * (1 - fc) + z[r0 + 1, c0 + 1] * fc) * fr)
    assert d.height(np.zeros((1, 2)))[0] == pytest.approx(want, abs=1e-3)
    # --dem-vertical egm96 agrees with the file; ellipsoid contradicts it
    assert Dem.open(str(dem), _origin(), "egm96", around=np.zeros((1, 2))).vertical == "egm96"
    with pytest.raises(InputError, match="egm96 heights, --dem-vertical says ellipsoid"):
        Dem.open(str(dem), _origin(), "ellipsoid", around=np.zeros((1, 2)))
    # the same place's heights above the ellipsoid (EPSG:4979): PROJ's conversion, the geoid
    # height (about 47 m) taken off
    ell = _geographic_dem(tmp_path, "EPSG:4979", z)
    e = Dem.open(str(ell), _origin(), None, around=np.zeros((1, 2)), margin_m=50)
    assert e.vertical == "ellipsoid"
    rr, cc = np.mgrid[0:e.z.shape[0], 0:e.z.shape[1]]
    xs = LJUBLJANA[0] - 0.003 + (cc + e.col0 + 0.5) * 1e-4
    ys = LJUBLJANA[1] + 0.003 - (rr + e.row0 + 0.5) * 1e-4
    raw = z[e.row0:e.row0 + e.z.shape[0], e.col0:e.col0 + e.z.shape[1]]
    np.testing.assert_allclose(e.z, _proj_to_egm96("EPSG:4979", xs, ys, raw), atol=1e-6)
    assert 40 < float(np.mean(raw - e.z)) < 55  # the geoid height, not a zero fallback
    # and the mission over the compound DEM flies its heights
    code, err = mission_build(tmp_path, capsys, "--dem", str(dem), "--pattern", "raster",
                              "--site-diameter", "20", "--altitude", "40")
    assert code == 0, err


def _origin() -> Any:
    from mound.geometry.geodesy import Origin

    return Origin(LJUBLJANA[1], LJUBLJANA[0])


def test_a_site_diameter_no_survey_reaches_is_refused_before_any_work(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """--site-diameter 1e5 with a DEM ran for over a minute and past 12 GB."""
    dem = _geographic_dem(tmp_path, "EPSG:4326+5773", np.full((60, 60), 300.0))
    code, err = mission_build(tmp_path, capsys, "--dem", str(dem), "--site-diameter", "1e5")
    one_line_exit_2(code, err, "--site-diameter", "(0, 2000] m")
    # the same in a plan's own scan
    plan = {**PLAN, "scan": {"pattern": "raster", "site_diameter_m": 1e5}}
    code, err = mission_build(tmp_path, capsys, "--dem", str(dem), plan=plan)
    one_line_exit_2(code, err, "scan.site_diameter_m")


def test_a_files_old_name_of_the_site_diameter_is_read_never_ignored() -> None:
    """Files until 2026-11-30 name the scan's diameter `scale_m` (a scan) and `scan_m` (a
    row's second look); an unknown key is ignored, so without the alias an old plan's 40 m
    scan would silently become the default 60 m."""
    from mound.formats.site_row import SecondLookRecord
    from mound.geometry.flight import LEGACY_DIAMETER as LEGACY
    from mound.geometry.flight import ScanSpec

    assert ScanSpec.from_doc({"pattern": "raster", "scale_m": 40.0}).site_diameter_m == 40.0
    same = {"pattern": "raster", "scale_m": 40.0, "site_diameter_m": 40.0}
    assert ScanSpec.from_doc(same).site_diameter_m == 40.0
    with pytest.raises(InputError, match="plan: scan: site_diameter_m and its old name"):
        ScanSpec.from_doc({**same, "scale_m": 50.0}, "plan: scan")
    assert "scale_m" not in ScanSpec.from_doc(same).to_doc()
    old = SecondLookRecord.from_doc({"flown": True, "scan_m": 120.0}, "row.second_look")
    assert old.site_diameter_m == 120.0 and not old.extra
    assert old.to_doc() == {"flown": True, "site_diameter_m": 120.0}
    with pytest.raises(InputError, match="row.second_look: site_diameter_m and its old name "
                       "scan_m differ"):
        SecondLookRecord.from_doc({"scan_m": 120.0, "site_diameter_m": 60.0}, "row.second_look")
    # a run begun before the rename keeps its stages: the field stage digests the old name
    from mound.survey.stages.field import scan_as_before

    scan = ScanSpec(site_diameter_m=40.0).to_doc()
    material: dict[str, Any] = {"scan": scan, "sites": {"scan": scan, "sites": []}}
    scan_as_before(material)
    for held in (material["scan"], material["sites"]["scan"]):
        assert held["scale_m"] == 40.0 and "site_diameter_m" not in held
        assert list(held) == [LEGACY if k == "site_diameter_m" else k for k in scan]


# ----------------------------------------------------------------------------- scenes

def _scene(path: Path, transform: Affine) -> Path:
    with rasterio.open(path, "w", driver="GTiff", width=64, height=64, count=2,
                       dtype="uint16", crs="EPSG:32635", transform=transform) as ds:
        ds.write(np.arange(2 * 64 * 64, dtype=np.uint16).reshape(2, 64, 64) + 1)
    return path


def test_scene_flags_nan_and_negative_seed(tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    """--stride-m nan was rounded before its range check and --seed -1 reached numpy:
    both exit 1."""
    scene = _scene(tmp_path / "s.tif", from_origin(366000, 4727000, 1, 1))
    code = mound_main(["scene", "score", str(scene), "--model", "m.json", "--out",
                       str(tmp_path / "out"), "--stride-m", "nan"])
    one_line_exit_2(code, capsys.readouterr().err, "--stride-m")
    code = mound_main(["scene", "train", str(scene), "--labels", "l.geojson", "--out",
                       str(tmp_path / "m.json"), "--seed", "-1"])
    one_line_exit_2(code, capsys.readouterr().err, "--seed")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.tif"]


@pytest.mark.parametrize("transform", [
    Affine(1, 0, NAN, 0, -1, 4727000), Affine(1, 0, 366000, 0, -1, NAN),
    Affine(1, 0, 1e300, 0, -1, 4727000)])
def test_scene_whose_origin_is_no_place_is_refused_on_opening(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], transform: Affine) -> None:
    """A NaN origin passed the opening checks and failed later naming an output field
    (features[0].geometry...) in two lines."""
    from mound.scene.raster import open_scene

    scene = _scene(tmp_path / "s.tif", transform)
    with pytest.raises(InputError, match="geotransform"):
        open_scene(scene)
    model = tmp_path / "m.json"
    model.write_text("{}")
    code = mound_main(["scene", "score", str(scene), "--model", str(model), "--out",
                       str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1, err
    assert not (tmp_path / "out").exists()


# ------------------------------------------------------------------------ photo cards

def test_photos_sort_names_the_flag_it_has(tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    """--site-diameter nan was reported as --site-diameter-m, a flag that does not exist."""
    (tmp_path / "card").mkdir()
    code = mound_main(["photos", "sort", str(tmp_path / "card"), "--sites", "s.json", "--out",
                       str(tmp_path / "out"), "--site-diameter", "nan"])
    err = capsys.readouterr().err
    one_line_exit_2(code, err, "--site-diameter")
    assert "--site-diameter-m" not in err
    with pytest.raises(InputError, match=r"^--site-diameter: ") as e:
        SortSpec(site_diameter_m=math.nan).check()
    assert "--site-diameter-m" not in str(e.value)
    with pytest.raises(InputError, match=r"^--blur-ratio: "):
        SortSpec(blur_ratio=math.inf).check()


# ------------------------------------------------------- every number of every command

def _leaves(parser: argparse.ArgumentParser, path: tuple[str, ...] = ()
            ) -> Iterator[tuple[tuple[str, ...], argparse.ArgumentParser]]:
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if not subs:
        yield path, parser
    for a in subs:
        for name, p in a.choices.items():
            yield from _leaves(p, (*path, name))


def _numeric_options(parser: argparse.ArgumentParser) -> Iterator[tuple[str, Any, int]]:
    """(flag, its bound, how many values) of every option that takes numbers."""
    for path, leaf in _leaves(parser):
        for a in leaf._actions:
            if not a.option_strings or a.type is None or a.type is str:
                continue
            assert a.type not in (int, float) or a.choices is not None, (
                f"{' '.join(path)} {a.option_strings[0]}: a number without a bound "
                "(use mound.bounds)")
            if getattr(a.type, "bound", None) is None:
                continue
            n = a.nargs if isinstance(a.nargs, int) else 1
            yield " ".join(path) + " " + a.option_strings[-1], a.type.bound, n


def test_every_number_a_user_gives_has_a_bound() -> None:
    flags = [f for f, _, _ in _numeric_options(mound_parser())]
    flags += [f for f, _, _ in _numeric_options(survey_parser())]
    assert len(flags) > 90
    assert any(f.endswith("mission build --site-diameter") for f in flags)


@pytest.mark.parametrize("prog, parser, main", [
    ("mound", mound_parser, mound_main), ("mission.py", survey_parser, survey_main)])
def test_every_numeric_flag_refuses_nan_inf_and_sizes_no_survey_reaches(
        capsys: pytest.CaptureFixture[str], prog: str, parser: Callable[[], Any],
        main: Callable[[list[str]], int]) -> None:
    checked = 0
    for where, bound, n in _numeric_options(parser()):
        words = where.split()
        path, flag = words[:-1], words[-1]
        ok = str(int(bound.lo) + 1 if bound.integer else (bound.lo + bound.hi) / 2)
        bad = (["nan", "1" + "0" * 30] if bound.integer
               else ["nan", "inf", "-inf", "1e300", "-1e300"])
        for b in bad:
            for at in range(n):  # each of a flag's values
                values = [ok] * n
                values[at] = b
                code = main([*path, flag, *values])
                one_line_exit_2(code, capsys.readouterr().err, flag)
                checked += 1
    assert checked > 60  # mound: 300 or so, mission.py 77


# --------------------------------------------------------------------- verdict models

def _valid_model() -> dict[str, Any]:
    doc = json.loads((REPO_ROOT / "data" / "verdict_model_dense.json").read_text())
    doc["second_look"] = {"p_low": 0.3, "threshold": 0.6, "scan_factor": 2.0,
                          "combine": {"first": 0.5, "second": 1.0, "bias": -0.2}}
    doc["reasons"] = {"cut_roughness": 0.06, "irregular_roughness": 0.15}
    doc["detector"] = {"candidates": "local_relief"}
    doc["undecided"] = {"p_low": 0.2, "p_high": 0.9, "by_slope": [
        {"site_slope_rad": [-math.pi / 2, 0.3], "p_low": 0.35, "p_high": 0.95},
        {"site_slope_rad": [0.3, math.pi / 2], "p_low": 0.1, "p_high": 0.9}]}
    doc["terrain_domain"] = {"ranges": {"site_slope_rad": [0.0, 0.4], "site_relief_m": [0, 30]},
                             "sites": 320, "neighbours": {
                                 "k": 2, "centre": [0.1, 2, 0.5, 0.5, 0.3],
                                 "scale": [0.1, 3, 1, 1, 0.2], "max_distance": 1.5,
                                 "points": [[0, 0, 0, 0, 0], [1, -1, 0.5, 0, 2]]}}
    return doc


def _set(path: tuple[Any, ...], value: Any) -> Callable[[dict[str, Any]], None]:
    def edit(d: dict[str, Any]) -> None:
        for k in path[:-1]:
            d = d[k]
        d[path[-1]] = value
    return edit


def _drop(path: tuple[Any, ...]) -> Callable[[dict[str, Any]], None]:
    def edit(d: dict[str, Any]) -> None:
        for k in path[:-1]:
            d = d[k]
        del d[path[-1]]
    return edit


# Each required field missing, and each of the wrong type or out of range: (name of the
# case, the edit, the field both readers must name).
REQUIRED = ("schema", "version", "features", "mean", "std", "weights", "bias", "threshold",
            "p_no_rise", "products", "product_clip")
BAD_MODELS: list[tuple[str, Callable[[dict[str, Any]], None], str]] = [
    *[(f"{k} missing", _drop((k,)), k) for k in REQUIRED],
    *[(f"calibration.{k} missing", _drop(("calibration", k)), "calibration") for k in "abc"],
    *[(f"second_look.{k} missing", _drop(("second_look", k)), "second_look")
      for k in ("p_low", "threshold", "scan_factor", "combine")],
    *[(f"second_look.combine.{k} missing", _drop(("second_look", "combine", k)),
       "second_look.combine") for k in ("first", "second", "bias")],
    ("schema a number", _set(("schema",), 7), "schema"),
    ("version a string", _set(("version",), "1"), "version"),
    ("version 1.0", _set(("version",), 1.0), "version"),
    ("version 2", _set(("version",), 2), "version"),
    ("features a string", _set(("features",), "log_height"), "features"),
    ("features with a number", _set(("features", 3), 5), "features"),
    ("a feature renamed", _set(("features", 0), "log_heights"), "features"),
    ("a feature twice", _set(("features", 1), "log_height"), "features"),
    ("basis a number", _set(("basis",), 3), "basis"),
    ("basis unknown", _set(("basis",), "cubic"), "basis"),
    ("basis null", _set(("basis",), None), "basis"),
    ("products a dict", _set(("products",), {"a": "b"}), "products"),
    ("products empty", _set(("products",), []), "products"),
    ("a product of one feature", _set(("products", 0), ["log_height", "log_height"]),
     "products"),
    ("a product of an unknown feature", _set(("products", 0), ["log_height", "x"]),
     "products"),
    ("a product a string", _set(("products", 0), "log_height"), "products"),
    ("product_clip a string", _set(("product_clip",), "3"), "product_clip"),
    ("product_clip 0", _set(("product_clip",), 0), "product_clip"),
    ("z_clip a list", _set(("z_clip",), [3]), "z_clip"),
    ("z_clip negative", _set(("z_clip",), -1), "z_clip"),
    ("mean a number", _set(("mean",), 0.5), "mean"),
    ("mean one short", lambda d: d["mean"].pop(), "mean"),
    ("mean with a string", _set(("mean", 2), "0.1"), "mean"),
    ("mean with a bool", _set(("mean", 2), True), "mean"),
    ("mean 1e7", _set(("mean", 2), 1e7), "mean"),
    ("std with null", _set(("std", 0), None), "std"),
    ("std 0", _set(("std", 0), 0.0), "std"),
    ("weights one short", lambda d: d["weights"].pop(), "weights"),
    ("weights with a dict", _set(("weights", 5), {}), "weights"),
    ("weights 1e7", _set(("weights", 5), -1e7), "weights"),
    ("bias a string", _set(("bias",), "-8"), "bias"),
    ("bias a bool", _set(("bias",), False), "bias"),
    ("bias 1e7", _set(("bias",), 1e7), "bias"),
    ("threshold 1", _set(("threshold",), 1.0), "threshold"),
    ("threshold a list", _set(("threshold",), [0.5]), "threshold"),
    ("p_no_rise -0.1", _set(("p_no_rise",), -0.1), "p_no_rise"),
    ("p_no_rise null", _set(("p_no_rise",), None), "p_no_rise"),
    ("calibration a list", _set(("calibration",), [1, 1, 0]), "calibration"),
    ("calibration's method", _set(("calibration", "method"), "platt"), "calibration"),
    ("calibration.a a string", _set(("calibration", "a"), "1"), "calibration"),
    ("calibration a = b = 0", lambda d: d["calibration"].update(a=0, b=0), "calibration"),
    ("second_look a string", _set(("second_look",), "yes"), "second_look"),
    ("second_look.combine a list", _set(("second_look", "combine"), [1, 1, 0]),
     "second_look"),
    ("second_look.p_low above the threshold", _set(("second_look", "p_low"), 0.9),
     "second_look"),
    ("second_look.scan_factor 1", _set(("second_look", "scan_factor"), 1.0), "second_look"),
    ("second_look.combine.second 0", _set(("second_look", "combine", "second"), 0),
     "second_look.combine"),
    ("undecided a number", _set(("undecided",), 0.5), "undecided"),
    ("undecided.p_high missing", _drop(("undecided", "p_high")), "undecided"),
    ("undecided.p_low a string", _set(("undecided", "p_low"), "0.2"), "undecided"),
    ("undecided out of order", _set(("undecided", "p_low"), 0.95), "undecided"),
    ("undecided.p_low 0", _set(("undecided", "p_low"), 0.0), "undecided"),
    ("undecided.p_high 1", _set(("undecided", "p_high"), 1.0), "undecided"),
    ("undecided.by_slope one band", _set(("undecided", "by_slope"), [
        {"site_slope_rad": [-1.5, 0.3], "p_low": 0.35, "p_high": 0.95}]), "undecided.by_slope"),
    ("undecided.by_slope a gap", _set(("undecided", "by_slope", 1, "site_slope_rad"),
                                      [0.4, 1.5]), "undecided.by_slope[1]"),
    ("undecided.by_slope reversed", _set(("undecided", "by_slope", 1, "site_slope_rad"),
                                         [0.3, 0.2]), "undecided.by_slope[1]"),
    ("undecided.by_slope beyond pi/2", _set(("undecided", "by_slope", 1, "site_slope_rad"),
                                            [0.3, 2.0]), "undecided.by_slope[1]"),
    ("undecided.by_slope a band out of order", _set(("undecided", "by_slope", 0, "p_low"),
                                                    0.99), "undecided.by_slope[0]"),
    ("undecided.by_slope without p_high", _drop(("undecided", "by_slope", 0, "p_high")),
     "undecided.by_slope[0]"),
    ("terrain_domain a list", _set(("terrain_domain",), [0, 1]), "terrain_domain"),
    ("terrain_domain without ranges", _drop(("terrain_domain", "ranges")), "terrain_domain"),
    ("terrain_domain.ranges empty", _set(("terrain_domain", "ranges"), {}), "terrain_domain"),
    ("terrain_domain: an unknown descriptor", _set(("terrain_domain", "ranges", "slope"),
                                                   [0, 1]), "terrain_domain.ranges: slope"),
    ("terrain_domain: a range reversed", _set(("terrain_domain", "ranges", "site_slope_rad"),
                                              [0.5, 0.1]), "terrain_domain.ranges"),
    ("terrain_domain: a range of three", _set(("terrain_domain", "ranges", "site_relief_m"),
                                              [0, 1, 2]), "terrain_domain.ranges"),
    ("terrain_domain: a range with a string",
     _set(("terrain_domain", "ranges", "site_relief_m"), [0, "9"]), "terrain_domain.ranges"),
    ("detector a string", _set(("detector",), "local_relief"), "detector"),
    ("detector.candidates unknown", _set(("detector", "candidates"), "ridges"),
     "detector.candidates"),
    ("detector with another field", _set(("detector", "cell_m"), 0.5), "detector"),
    ("reasons a number", _set(("reasons",), 1), "reasons"),
    ("reasons without irregular_roughness", _drop(("reasons", "irregular_roughness")),
     "reasons: irregular_roughness"),
    ("reasons out of order", _set(("reasons", "cut_roughness"), 0.9), "reasons"),
    ("reasons.cut_roughness 0", _set(("reasons", "cut_roughness"), 0.0), "reasons"),
    ("neighbours a list", _set(("terrain_domain", "neighbours"), []),
     "terrain_domain.neighbours"),
    ("neighbours.k 0", _set(("terrain_domain", "neighbours", "k"), 0),
     "terrain_domain.neighbours: k"),
    ("neighbours.k more than its points", _set(("terrain_domain", "neighbours", "k"), 3),
     "terrain_domain.neighbours: points"),
    ("neighbours.scale 0", _set(("terrain_domain", "neighbours", "scale"), [0, 1, 1, 1, 1]),
     "terrain_domain.neighbours"),
    ("neighbours.centre short", _set(("terrain_domain", "neighbours", "centre"), [0, 1]),
     "terrain_domain.neighbours: centre"),
    ("neighbours.points a short point", _set(("terrain_domain", "neighbours", "points", 1),
                                             [1, 2]), "terrain_domain.neighbours: points[1]"),
    ("neighbours.max_distance negative",
     _set(("terrain_domain", "neighbours", "max_distance"), -1.0),
     "terrain_domain.neighbours: max_distance"),
    ("top level a list", lambda d: d.clear(), "expected a JSON object"),
]


def _model_file(tmp_path: Path, name: str, edit: Callable[[dict[str, Any]], None]) -> Path:
    doc = _valid_model()
    edit(doc)
    path = tmp_path / (name.replace(" ", "_").replace("/", "_") + ".json")
    path.write_text("[]" if not doc else json.dumps(doc))
    return path


def _cpp_verdict(model: Path, tmp_path: Path) -> tuple[int, str]:
    """mound_recon verdict reading `model` (its options are read before the folder)."""
    r = subprocess.run([str(native.tool_path("mound_recon")), "verdict",
                        str(tmp_path / "no_recon"), "--model", str(model), "--out",
                        str(tmp_path / "verdict.json")], capture_output=True, text=True,
                       timeout=60)
    assert not (tmp_path / "verdict.json").exists()
    return r.returncode, r.stderr


@pytest.mark.parametrize("name, edit, field", BAD_MODELS, ids=[c[0] for c in BAD_MODELS])
def test_both_readers_refuse_the_same_bad_verdict_models(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str,
        edit: Callable[[dict[str, Any]], None], field: str) -> None:
    """Python read these with KeyError, TypeError or UFuncTypeError (exit 1) where the C++
    reader said exit 2; now both refuse each file naming the same field."""
    path = _model_file(tmp_path, name, edit)
    with pytest.raises(InputError) as e:
        read_verdict_model(path)
    py = str(e.value)
    assert str(path) in py and field in py and "\n" not in py, py
    code, err = _cpp_verdict(path, tmp_path)
    assert code == 2, err
    last = err.strip().splitlines()[-1]
    assert str(path) in last and field in last, err
    # the Python command that reads a model: one line, exit 2
    code = mound_main(["recon", "eval-verdict", str(tmp_path / "no_grid"), "--model",
                       str(path)])
    one_line_exit_2(code, capsys.readouterr().err, field)


def test_both_readers_take_the_valid_models(tmp_path: Path) -> None:
    """The built-in models, one with a second look, and one whose features come in
    another order (the readers map them by name)."""
    shuffled = _valid_model()
    order = np.random.default_rng(1).permutation(len(shuffled["features"]))
    for key in ("features", "mean", "std"):
        shuffled[key] = [shuffled[key][k] for k in order]
    shuffled.pop("products"), shuffled.pop("product_clip")
    shuffled["basis"] = "hinge"
    shuffled["weights"] = shuffled["weights"][:3 * len(order)]
    paths = [REPO_ROOT / "data" / "verdict_model.json",
             REPO_ROOT / "data" / "verdict_model_dense.json"]
    for k, doc in enumerate((_valid_model(), shuffled)):
        paths.append(tmp_path / f"ok{k}.json")
        paths[-1].write_text(json.dumps(doc))
    for path in paths:
        assert sorted(read_verdict_model(path).features) == sorted(DETECTOR_FEATURES)
        code, err = _cpp_verdict(path, tmp_path)
        assert code == 2 and "recon.json" in err and str(path) not in err, err


def test_python_knows_the_detectors_features() -> None:
    """DETECTOR_FEATURES is the C++ detector's list: the built-in models, which the C++
    build holds to that list, have exactly these."""
    for name in ("verdict_model.json", "verdict_model_dense.json"):
        doc = json.loads((REPO_ROOT / "data" / name).read_text())
        assert sorted(doc["features"]) == sorted(DETECTOR_FEATURES)
