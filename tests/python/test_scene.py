"""`mound scene train | score`: the coarse search on GeoTIFF scenes, read back with rasterio
and PROJ. Synthetic scenes (tests/python/scenes.py) with painted mounds on textured ground
are learned on two scenes and judged on a third; the paper's 3 x 3 features against
mound.classify on the same pixels; block-wise against whole-scene scoring; bad input."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rasterio
from pyproj import Transformer
from scenes import EPSG, NORTH, WEST, make_scene, to_lonlat, write_labels

from mound.cli import main as mound_main
from mound.geometry.flight import scan_for_site


@pytest.fixture(scope="module")
def learned(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    d = tmp_path_factory.mktemp("scene")
    mounds: list[tuple[float, float]] = []
    scenes = []
    for k in range(3):
        path = d / f"train{k}.tif"
        mounds += make_scene(path, seed=10 + k, west=WEST + 1000 * k)
        scenes.append(str(path))
    labels = write_labels(d / "known.geojson", mounds)
    model = d / "model.json"
    assert mound_main(["scene", "train", *scenes, "--labels", str(labels), "--out",
                       str(model), "--negatives-per-scene", "400", "--folds", "3"]) == 0
    test = d / "test.tif"
    test_mounds = make_scene(test, seed=99, west=WEST + 5000)
    out = d / "scored"
    assert mound_main(["scene", "score", str(test), "--model", str(model), "--out", str(out),
                       "--candidates", "6", "--min-separation-m", "25",
                       "--home", "42.65,25.40"]) == 0
    return {"dir": d, "model": model, "test": test, "mounds": test_mounds, "out": out,
            "labels": labels, "scenes": scenes}


@pytest.mark.slow
def test_model_records_what_it_learned(learned: dict[str, Any]) -> None:
    doc = json.loads(learned["model"].read_text())
    assert doc["schema"] == "mound.scene_model" and doc["version"] == 1
    assert [b["name"] for b in doc["bands"]] == ["blue", "green", "red", "nir"]
    assert doc["features"]["kind"] == "multiscale" and doc["features"]["ndvi"] is True
    assert len(doc["training"]["scenes"]) == 3
    assert all(len(s["sha256"]) == 64 for s in doc["training"]["scenes"])
    assert doc["training"]["labels"]["mounds_inside"] == 12
    cv = doc["cross_validation"]
    assert cv["folds"] == "leave-scenes-out" and cv["scenes"] == 3
    assert cv["l2"] in [r["l2"] for r in cv["l2_grid"]]
    # Painted mounds are easy: held-out scenes rank mound pixels far above background.
    assert cv["auc_mean"] > 0.95 and cv["recall_at_5"] >= 0.9
    assert 0 < doc["threshold"] < 1 and np.isfinite(doc["calibration"]["a"])


@pytest.mark.slow
def test_scores_rasters_and_candidates_on_an_unseen_scene(learned: dict[str, Any]) -> None:
    out = learned["out"]
    with rasterio.open(learned["test"]) as src, rasterio.open(out / "p_mound.tif") as p_ds, \
            rasterio.open(out / "reward.tif") as r_ds:
        for ds in (p_ds, r_ds):
            assert ds.crs.to_epsg() == EPSG and ds.transform == src.transform
            assert (ds.width, ds.height) == (src.width, src.height)
            assert ds.dtypes[0] == "float32" and ds.nodata == -9999.0
        p = p_ds.read(1, masked=True)
        h = r_ds.read(1, masked=True)
    assert (p.mask == h.mask).all() and 0 <= p.min() and p.max() <= 1
    q = np.clip(p.compressed().astype(np.float64), 1e-12, 1 - 1e-12)
    assert np.allclose(h.compressed(), -(q * np.log2(q) + (1 - q) * np.log2(1 - q)), atol=1e-5)
    # p on the mounds (3 m around the centres) well above the background's.
    rows, cols = np.mgrid[0:p.shape[0], 0:p.shape[1]]
    x, y = WEST + 5000 + cols + 0.5, NORTH - rows - 0.5
    d = np.min([np.hypot(x - mx, y - my) for mx, my in learned["mounds"]], axis=0)
    on, off = p.data[(d <= 3) & ~p.mask], p.data[(d > 40) & ~p.mask]
    assert np.median(on) > 0.5 > np.percentile(off, 95)
    gj = json.loads((out / "candidates.geojson").read_text())
    assert gj["features"][0]["properties"]["kind"] == "home"
    cands = gj["features"][1:]
    ps = [c["properties"]["p_mound"] for c in cands]
    assert ps == sorted(ps, reverse=True) and len(cands) == 6
    # Every painted mound (radius 9-13 m) is one of the first four candidates, which lies on
    # it, within 9 m of its centre (the shaded flank shifts the peak a few metres).
    to_utm = Transformer.from_crs("EPSG:4326", f"EPSG:{EPSG}", always_xy=True)
    for mx, my in learned["mounds"]:
        near = [k for k, c in enumerate(cands)
                if np.hypot(c["properties"]["x"] - mx, c["properties"]["y"] - my) <= 9.0]
        assert near and near[0] < 4
    for c in cands:
        pr = c["properties"]
        # WGS84 through PROJ: the point lands back on the candidate's x, y within 0.5 m,
        # and x, y is the centre of the candidate's cell of p_mound.tif.
        e, n = to_utm.transform(*c["geometry"]["coordinates"])
        assert np.hypot(e - pr["x"], n - pr["y"]) < 0.5
        assert pr["x"] == pytest.approx(WEST + 5000 + pr["col"] + 0.5)
        assert pr["y"] == pytest.approx(NORTH - pr["row"] - 0.5)
        assert pr["p_mound"] == pytest.approx(float(p[pr["row"], pr["col"]]), abs=1e-6)
        assert set(pr) >= {"id", "p_mound", "reward", "x", "y", "scene"}
    doc = json.loads((out / "scene.json").read_text())
    assert doc["schema"] == "mound.scene" and doc["status"] == "ok"
    assert doc["counts"]["candidates"] == 6 and doc["counts"]["scored"] > 0


@pytest.mark.slow
def test_candidates_are_sites_the_survey_reads(learned: dict[str, Any]) -> None:
    from mound.formats.sites import load_user_sites

    scan = scan_for_site(60.0, "raster")
    doc = load_user_sites(learned["out"] / "candidates.geojson", scan, None, 14_400.0,
                          need_truth=False)
    assert doc.origin is not None and doc.origin.lat_deg == pytest.approx(42.65)
    assert len(doc.sites) == 6
    assert all(s.p_mound is not None and 0 <= s.p_mound <= 1 for s in doc.sites)


@pytest.mark.slow
def test_blockwise_scoring_equals_whole_scene(learned: dict[str, Any]) -> None:
    d = learned["dir"]
    outs = {}
    for block in ("16", "4096"):
        out = d / f"block{block}"
        assert mound_main(["scene", "score", str(learned["test"]), "--model",
                           str(learned["model"]), "--out", str(out), "--block", block,
                           "--threads", "2", "--candidates", "30"]) == 0
        with rasterio.open(out / "p_mound.tif") as ds:
            p = ds.read(1)
        outs[block] = (p, json.loads((out / "candidates.geojson").read_text())["features"])
    (pa, ca), (pb, cb) = outs["16"], outs["4096"]
    assert np.allclose(pa, pb, atol=1e-6) and ((pa == -9999) == (pb == -9999)).all()
    assert [(c["properties"]["row"], c["properties"]["col"]) for c in ca] == \
        [(c["properties"]["row"], c["properties"]["col"]) for c in cb]


def test_stride_grid_and_nodata_border(tmp_path: Path, learned: dict[str, Any]) -> None:
    scene = tmp_path / "border.tif"
    mounds = make_scene(scene, seed=5, size=260, nodata_border=30, west=WEST + 9000)
    out = tmp_path / "o"
    assert mound_main(["scene", "score", str(scene), "--model", str(learned["model"]),
                       "--out", str(out), "--stride-m", "2", "--candidates", "4"]) == 0
    with rasterio.open(out / "p_mound.tif") as ds:
        assert ds.res == (2.0, 2.0) and (ds.width, ds.height) == (130, 130)
        assert ds.transform.c == WEST + 9000 and ds.transform.f == NORTH
        p = ds.read(1)
    assert (p[:15, :] == -9999).all() and (p[:, :15] == -9999).all()  # the nodata border
    cands = json.loads((out / "candidates.geojson").read_text())["features"]
    for mx, my in mounds:
        assert min(np.hypot(c["properties"]["x"] - mx, c["properties"]["y"] - my)
                   for c in cands) <= 9.0


def test_aoi_limits_the_scored_area(tmp_path: Path, learned: dict[str, Any]) -> None:
    x0, y0 = WEST + 5000 + 60, NORTH - 180
    ring = to_lonlat([(x0, y0), (x0 + 120, y0), (x0 + 120, y0 + 120), (x0, y0 + 120),
                      (x0, y0)])
    aoi = tmp_path / "aoi.geojson"
    aoi.write_text(json.dumps({"type": "Feature", "properties": {},
                               "geometry": {"type": "Polygon",
                                            "coordinates": [[list(c) for c in ring]]}}))
    out = tmp_path / "o"
    assert mound_main(["scene", "score", str(learned["test"]), "--model",
                       str(learned["model"]), "--out", str(out), "--aoi", str(aoi)]) == 0
    for c in json.loads((out / "candidates.geojson").read_text())["features"]:
        assert x0 - 1 <= c["properties"]["x"] <= x0 + 121
        assert y0 - 1 <= c["properties"]["y"] <= y0 + 121


def test_paper_features_give_the_classifier_p(tmp_path: Path) -> None:
    """A Statlog-shaped scene (4 bands of 8-bit values): the paper's 3 x 3 features through
    `mound scene score` give mound.classify's p of the same 36 pixel values."""
    from mound.classify import coarse, statlog
    from mound.jsonio import write_json
    from mound.scene.model import from_classifier

    rng = np.random.default_rng(3)
    size = 40
    bands = rng.integers(20, 160, (4, size, size)).astype(np.float32)
    path = tmp_path / "statlog_like.tif"
    with rasterio.open(path, "w", driver="GTiff", width=size, height=size, count=4,
                       dtype="float32", crs=f"EPSG:{EPSG}",
                       transform=rasterio.transform.from_origin(WEST, NORTH, 80, 80)) as ds:
        ds.write(bands)
    for band in (None, 1):
        clf = coarse.train(statlog.load("sat.trn"), band, solver="lbfgs")
        model = tmp_path / f"model_{band}.json"
        write_json(model, from_classifier(clf, [1, 2, 3, 4], 80.0, 80.0).to_doc())
        out = tmp_path / f"o{band}"
        assert mound_main(["scene", "score", str(path), "--model", str(model), "--out",
                           str(out)]) == 0
        with rasterio.open(out / "p_mound.tif") as ds:
            p = ds.read(1)
        rows = []
        for r in range(1, size - 1):
            for c in range(1, size - 1):
                patch = bands[:, r - 1:r + 2, c - 1:c + 2]          # (4, 3, 3)
                rows.append(patch.transpose(1, 2, 0).reshape(36))   # pixel-major, band-minor
        want = clf.predict(np.asarray(rows, dtype=np.float64)).reshape(size - 2, size - 2)
        assert np.allclose(p[1:-1, 1:-1], want, atol=2e-6)


# ---------------------------------------------------------------------------- bad input

def _bad(args: list[str], capsys: pytest.CaptureFixture, needle: str) -> None:
    assert mound_main(args) == 2, args
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and needle in err[0], err


def test_bad_scenes_labels_aois_and_models(tmp_path: Path, learned: dict[str, Any],
                                           capsys: pytest.CaptureFixture) -> None:
    model, test, labels = str(learned["model"]), str(learned["test"]), str(learned["labels"])
    no_crs = tmp_path / "no_crs.tif"
    make_scene(no_crs, 1, size=100, n_mounds=1, crs=False)
    no_tf = tmp_path / "no_tf.tif"
    make_scene(no_tf, 1, size=100, n_mounds=1, transform=False)
    text = tmp_path / "text.tif"
    text.write_text("not a raster\n")
    three = tmp_path / "three_bands.tif"
    with rasterio.open(three, "w", driver="GTiff", width=64, height=64, count=3,
                       dtype="float32", crs=f"EPSG:{EPSG}",
                       transform=rasterio.transform.from_origin(WEST, NORTH, 1, 1)) as ds:
        ds.write(np.ones((3, 64, 64), np.float32))
    far = write_labels(tmp_path / "far.geojson", [(WEST + 50_000, NORTH)])
    xy = learned["mounds"]
    only_neg = write_labels(tmp_path / "neg.geojson", [], not_mounds=xy)
    utm = write_labels(tmp_path / "utm.geojson", xy, extra={
        "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32635"}}})
    broken = tmp_path / "broken.geojson"
    broken.write_text('{"type": "FeatureCollection", "features": [{"type": "Feature", '
                      '"geometry": {"type": "Point", "coordinates": [25.3]}}]}')
    missing_aoi = tmp_path / "aoi_far.geojson"
    ring = [[0.0, 0.0], [0.1, 0.0], [0.1, 0.1], [0.0, 0.1], [0.0, 0.0]]
    missing_aoi.write_text(json.dumps({"type": "Polygon", "coordinates": [ring]}))
    out = tmp_path / "out"
    train = ["scene", "train", "--out", str(tmp_path / "m.json")]
    score = ["scene", "score", "--model", model, "--out", str(out)]
    cases = [
        ([*score, str(no_crs)], "no CRS"),
        ([*score, str(no_tf)], "geotransform"),
        ([*score, str(text)], "not a raster"),
        ([*score, str(tmp_path / "nothing.tif")], "no such file"),
        ([*score, str(three)], "band"),
        ([*train, test, "--labels", labels, "--bands", "swir"], "no band named 'swir'"),
        ([*train, test, "--labels", labels, "--bands", "7"], "band 7 does not exist"),
        ([*train, test, "--labels", str(far)], "none of the 1 labels falls inside"),
        ([*train, test, "--labels", str(only_neg)], "none of the labels inside"),
        ([*train, test, "--labels", str(utm)], "is not WGS84"),
        ([*train, test, "--labels", str(broken)], "expected [lon, lat]"),
        ([*score, test, "--aoi", str(missing_aoi)], "misses the scene"),
        ([*score, test, "--band-names", "a,b"], "--band-names: 2 names"),
        ([*score, test, "--stride-m", "-1"], "--stride-m"),
        ([*score, test, "--home", "95,10"], "--home"),
        (["scene", "score", test, "--model", str(labels), "--out", str(out)], "schema"),
    ]
    for args, needle in cases:
        _bad(args, capsys, needle)
    assert not out.exists() and not (tmp_path / "m.json").exists()


@pytest.mark.slow
def test_eval_tells_how_far_each_found_mound_lies_from_its_candidate(
        tmp_path: Path, learned: dict[str, Any], capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "eval.json"
    assert mound_main(["scene", "eval", *learned["scenes"], "--labels", str(learned["labels"]),
                       "--folds", "3", "--json", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["schema"] == "mound.scene_eval" and set(doc["kinds"]) == {
        "paper", "multiscale", "chance"}
    ms = doc["kinds"]["multiscale"]
    rows = ms["per_mound"]
    assert len(rows) == ms["mounds"] == 12
    assert {r["scene"] for r in rows} == {Path(s).name for s in learned["scenes"]}
    for r in rows:
        # An offset exactly when a candidate lies within the found radius (15 m) of it.
        assert (r["offset_m"] is None) == (r["rank"] is None)
        if r["rank"] is not None:
            # The painted mounds' peak sits on the disc (radius 9-13 m), a few metres off
            # centre towards the bright flank.
            assert 0 <= r["offset_m"] <= 9.0
    top5 = [r["offset_m"] for r in rows if r["rank"] is not None and r["rank"] <= 5]
    o = ms["offset_at_5"]
    assert o["mounds"] == len(top5) == round(ms["recall_at_5"] * 12) >= 10
    assert o["median_m"] == pytest.approx(float(np.median(top5)))
    assert o["max_m"] == max(top5) and o["within_10_m"] == len(top5)
    assert o["within_2_m"] <= o["within_5_m"] <= o["within_10_m"]
    assert f"mounds found in the top 5: median {o['median_m']:.1f} m" in capsys.readouterr().out
