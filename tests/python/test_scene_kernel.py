"""The compiled scoring kernel (`mound_scene`, cpp/scene/) against the numpy reference
(features.py, model.py): the same features and logits on blocks with and without NDVI, at
stride 1 and 3, with nodata holes and edges, float32 and float64 pixels; and the same
rasters and candidates from `mound scene score --engine native|numpy`. The streamed kernel
(`--serve`, what scoring uses) gives the bits of a job file's run, with AVX2 and without.
Bad kernel jobs exit 2 naming the field; a bad streamed job is refused and the next one
served."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest
import rasterio
from scenes import WEST, make_scene

from mound import native
from mound.classify.features import Standardizer
from mound.cli import main as mound_main
from mound.errors import ToolInputError
from mound.paths import build_dir
from mound.scene import kernel
from mound.scene.features import FeatureSpec
from mound.scene.model import Band, SceneModel


def _block(rng: np.random.Generator, bands: int, rows: int, cols: int) -> np.ndarray:
    yy, xx = np.mgrid[0:rows, 0:cols]
    base = 300 + 20 * np.sin(yy / 7.0) + 15 * np.cos(xx / 5.0)
    disc = np.hypot(yy - rows / 2, xx - cols / 2) < 8
    out = np.stack([base * (0.8 + 0.2 * b) + 5 * rng.standard_normal((rows, cols))
                    + 40 * disc for b in range(bands)])
    return out.astype(np.float32).astype(np.float64)


def _spec(labels: list[str]) -> FeatureSpec:
    return FeatureSpec("multiscale", radii_m=(2.0, 4.0, 8.0), background_m=16.0,
                       band_labels=labels)


def _model(spec: FeatureSpec, basis: str, rng: np.random.Generator, x: np.ndarray
           ) -> SceneModel:
    ok = np.isfinite(x).all(axis=1)
    mean, std = x[ok].mean(axis=0), x[ok].std(axis=0) * 0.3 + 1e-3  # some cells clip
    n = len(spec.names())
    w = rng.standard_normal(n * (3 if basis == "hinge" else 1) + 1)
    return SceneModel(bands=[Band(k + 1, b) for k, b in enumerate(spec.band_labels)],
                      spec=spec, basis=basis, scaler=Standardizer(mean, std), w=w, res_m=1.0)


CASES = [  # labels, stride, nodata, float64
    (["blue", "green", "red", "nir"], 1, False, False),
    (["blue", "green", "red", "nir"], 3, True, False),
    (["band1", "band2"], 1, True, True),
    (["pan"], 2, False, False),
]


@pytest.mark.parametrize(("labels", "stride", "nodata", "f64"), CASES)
def test_kernel_equals_the_numpy_reference(labels: list[str], stride: int, nodata: bool,
                                           f64: bool) -> None:
    rng = np.random.default_rng(len(labels) * 10 + stride)
    spec = _spec(labels)
    halo = spec.halo_px(1.0, stride)
    n, m = 9, 11
    rows, cols = n * stride + 2 * halo, m * stride + 2 * halo
    block = _block(rng, len(labels), rows, cols)
    if nodata:
        block[:, :7, :] = np.nan                 # a nodata edge: some cells lose windows
        block[:, rows // 2, cols // 2 + 3] = np.nan  # a hole at a cell's centre
        block[0, 30:33, 40:44] = np.nan          # a hole in one band only
    if f64:
        block += rng.uniform(0, 1e-3, block.shape)  # not float32-exact: sent as float64
    ref = spec.compute(block, 1.0, halo, stride, n, m)
    got = kernel.features(block, spec, 1.0, halo, stride, n, m)
    assert got.shape == ref.shape == (n * m, len(spec.names()))
    assert (np.isnan(got) == np.isnan(ref)).all()
    if nodata:
        assert np.isnan(ref).all(axis=1).any() and np.isfinite(ref).all(axis=1).any()
    ok = np.isfinite(ref)
    assert np.allclose(got[ok], ref[ok], rtol=1e-9, atol=1e-9)
    for basis in ("hinge", "none"):
        model = _model(spec, basis, rng, ref)
        want = model.logit(ref)
        lg = kernel.logits(block, model, 1.0, halo, stride, n, m).ravel()
        assert (np.isnan(lg) == np.isnan(want)).all()
        fin = np.isfinite(want)
        assert np.allclose(lg[fin], want[fin], rtol=1e-9, atol=1e-8)


@pytest.mark.parametrize("with_aoi", [False, True])
def test_engines_give_the_same_rasters_and_candidates(tmp_path: Path, with_aoi: bool) -> None:
    """`mound scene score` with the compiled kernel (its p, reward and local maxima computed
    in the kernel) and with the numpy reference, on a scene with a nodata border, with and
    without an area of interest cutting through it (the model: fitted on another scene)."""
    train = tmp_path / "train.tif"
    mounds = make_scene(train, seed=3)
    from scenes import NORTH, to_lonlat, write_labels

    labels = write_labels(tmp_path / "known.geojson", mounds)
    model = tmp_path / "model.json"
    assert mound_main(["scene", "train", str(train), "--labels", str(labels), "--out",
                       str(model), "--negatives-per-scene", "300", "--folds", "2",
                       "--l2", "0.1"]) == 0
    scene = tmp_path / "test.tif"
    make_scene(scene, seed=4, n_mounds=3, nodata_border=20, west=WEST + 3000)
    extra: list[str] = []
    if with_aoi:
        x0, y0 = WEST + 3000 + 40, NORTH - 200
        ring = to_lonlat([(x0, y0), (x0 + 150, y0 + 30), (x0 + 120, y0 + 190), (x0, y0)])
        aoi = tmp_path / "aoi.geojson"
        aoi.write_text(json.dumps({"type": "Feature", "properties": {}, "geometry": {
            "type": "Polygon", "coordinates": [[list(c) for c in ring]]}}))
        extra = ["--aoi", str(aoi)]
    out = {}
    for engine in ("native", "numpy"):
        d = tmp_path / engine
        assert mound_main(["scene", "score", str(scene), "--model", str(model), "--out",
                           str(d), "--engine", engine, "--candidates", "10", "--block",
                           "64", *extra]) == 0
        rasters = []
        for name in ("p_mound.tif", "reward.tif"):
            with rasterio.open(d / name) as ds:
                rasters.append(ds.read(1))
        cands = json.loads((d / "candidates.geojson").read_text())["features"]
        doc = json.loads((d / "scene.json").read_text())
        assert doc["timings"]["engine"] == engine
        out[engine] = (rasters, [(c["properties"]["row"], c["properties"]["col"])
                                 for c in cands],
                       [c["properties"]["p_mound"] for c in cands], doc)
    (rn, cn, pn, dn), (rr, cr, pr, dr) = out["native"], out["numpy"]
    for a, b in zip(rn, rr, strict=True):
        assert ((a == -9999) == (b == -9999)).all() and (a == -9999).any()
        assert np.allclose(a, b, atol=1e-6)
    assert cn == cr and len(cn) == 10 and np.allclose(pn, pr, atol=1e-6)
    assert dn["counts"] == dr["counts"] and abs(dn["p_mean"] - dr["p_mean"]) < 1e-9
    if with_aoi:  # the AOI left cells out that the border did not
        assert dn["counts"]["nodata"] > 2 * 20 * 240


def _tool(args: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(build_dir() / "mound_scene"), *args], cwd=cwd,
                          capture_output=True, text=True, timeout=60)


def test_bad_kernel_jobs_exit_2_naming_the_field(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    spec = _spec(["red", "nir"])
    block = _block(rng, 2, 60, 60)
    np.save(tmp_path / "block.npy", block.astype(np.float32))
    model = _model(spec, "hinge", rng, np.ones((4, len(spec.names()))))
    good = {**kernel._job(spec, 1.0, spec.halo_px(1.0, 1), 1, 2, 2, model),
            "block": "block.npy"}
    (tmp_path / "job.json").write_text(json.dumps(good))
    ok = _tool(["job.json", "--logits", "l.npy"], tmp_path)
    assert ok.returncode == 0, ok.stderr
    assert json.loads(ok.stdout)["cells"] == 4 and np.load(tmp_path / "l.npy").shape == (2, 2)

    def bad(edit: dict[str, object], field: str) -> None:
        job = json.loads(json.dumps(good))
        for path, value in edit.items():
            obj = job
            *parents, key = path.split(".")
            for p in parents:
                obj = obj[p]
            if value is None:
                del obj[key]
            else:
                obj[key] = value
        (tmp_path / "bad.json").write_text(json.dumps(job))
        r = _tool(["bad.json", "--logits", "out.npy"], tmp_path)
        assert r.returncode == 2, (edit, r.stderr)
        assert field in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
        assert not (tmp_path / "out.npy").exists()

    bad({"model.std": [1.0] * (len(spec.names()) - 1) + [0.0]}, "model.std")
    bad({"model.weights": [0.0] * 3}, "model.weights")
    bad({"model.basis": "cubic"}, "model.basis")
    bad({"features.radii_px": [4, 2]}, "features.radii_px")
    bad({"features.background_px": 3}, "features.background_px")
    bad({"features.nir_band": 5}, "features.nir_band")
    bad({"features.kind": "paper"}, "features.kind")
    bad({"cells.rows": 500}, "cells.rows")
    bad({"block": "missing.npy"}, "block")
    bad({"block": "."}, "block")
    bad({"schema": "mound.render"}, "schema")
    (tmp_path / "wrong.npy").write_bytes(b"\x93NUMPY\x01\x00garbage")
    bad({"block": "wrong.npy"}, "wrong.npy")
    r = _tool(["job.json"], tmp_path)
    assert r.returncode == 2 and "--logits" in r.stderr


def test_streamed_kernel_equals_the_per_block_kernel_on_a_nodata_border(tmp_path: Path
                                                                         ) -> None:
    """Every block of a scene with a nodata border, scored as `mound scene score` does (the
    long-lived `mound_scene --serve`, its tables reused from block to block, blocks of two
    sizes), equals the same block scored by a fresh `mound_scene JOB.json` run, bit for bit,
    with and without AVX2."""
    from mound.scene import score
    from mound.scene.raster import open_scene

    scene_path = tmp_path / "scene.tif"
    make_scene(scene_path, seed=5, size=260, n_mounds=2, nodata_border=25)
    info = open_scene(scene_path)
    spec = FeatureSpec("multiscale", radii_m=(3.0, 6.0, 12.0), background_m=24.0,
                       band_labels=["blue", "green", "red", "nir"])
    rng = np.random.default_rng(1)
    block0, halo = score.read_block(info, [1, 2, 3, 4], spec, 1, 60, 60, 40, 40)
    feats = spec.compute(block0, 1.0, halo, 1, 40, 40)
    model = _model(spec, "hinge", rng, feats)
    grid = score.OutGrid.of(info, model, None)
    simds = ["generic", "avx2"] if "avx2" in Path("/proc/cpuinfo").read_text() else ["generic"]
    native.close_servers()
    for block in (64, 48):  # two block sizes through the same servers
        for r0, c0, nr, nc in score.block_origins(grid, block):
            n, m = nr + 2, nc + 2
            pixels, halo = score.read_block(info, [1, 2, 3, 4], spec, 1, r0 - 1, c0 - 1, n, m)
            streamed = kernel.logits(pixels, model, 1.0, halo, 1, n, m)
            assert pixels.dtype == np.float32  # a float32 scene is handed over as float32
            np.save(tmp_path / "block.npy", pixels)
            job = {**kernel._job(spec, 1.0, halo, 1, n, m, model), "block": "block.npy"}
            (tmp_path / "job.json").write_text(json.dumps(job))
            for simd in simds:
                r = _tool(["job.json", "--logits", f"{simd}.npy", "--simd", simd], tmp_path)
                assert r.returncode == 0, r.stderr
                assert json.loads(r.stdout)["simd"] == simd
                once = np.load(tmp_path / f"{simd}.npy")
                assert np.array_equal(streamed, once, equal_nan=True), (block, r0, c0, simd)
            if r0 == 0 and c0 == 0:  # the corner block: its rows in the nodata border
                assert np.isnan(streamed[:26]).all() and np.isfinite(streamed).any()
    # the border has no logits, the inside has
    full, _ = score.logit_map(info, model)
    assert np.isnan(full[:25]).all() and np.isfinite(full[60:200, 60:200]).all()


def test_a_bad_streamed_job_is_refused_and_the_next_one_served(tmp_path: Path) -> None:
    """`mound_scene --serve`: a job with a bad field gets an error reply naming it (its
    block read past), the next job is served; a line that is not JSON ends the server with
    exit 2 naming the request; the end of input ends it with 0."""
    rng = np.random.default_rng(0)
    spec = _spec(["red", "nir"])
    block = _block(rng, 2, 60, 60).astype(np.float32)
    model = _model(spec, "hinge", rng, np.ones((4, len(spec.names()))))
    good = {**kernel._job(spec, 1.0, spec.halo_px(1.0, 1), 1, 2, 2, model), "want": "logits",
            "block": {"dtype": "<f4", "shape": list(block.shape)}}
    bad = json.loads(json.dumps(good))
    bad["model"]["std"][3] = 0.0
    short = json.loads(json.dumps(good))
    short["cells"]["rows"] = 500
    raw = block.tobytes()
    stream = b"".join(json.dumps(j).encode() + b"\n" + raw for j in (good, bad, short, good))
    r = subprocess.run([str(build_dir() / "mound_scene"), "--serve"], input=stream,
                       capture_output=True, timeout=60)
    assert r.returncode == 0, r.stderr
    out = r.stdout
    replies = []
    while out:
        line, _, out = out.partition(b"\n")
        head = json.loads(line)
        replies.append(head)
        out = out[head.get("bytes", 0):]
    assert [h["status"] for h in replies] == ["ok", "error", "error", "ok"]
    assert "request 2: model.std[3]" in replies[1]["message"]
    assert "request 3: cells.rows" in replies[2]["message"]
    assert replies[0]["shape"] == [2, 2] and replies[0]["bytes"] == 32
    r = subprocess.run([str(build_dir() / "mound_scene"), "--serve"],
                       input=json.dumps(good).encode() + b"\n" + raw + b"{not json\n",
                       capture_output=True, timeout=60)
    assert r.returncode == 2 and b"request 2" in r.stderr
    assert len(r.stderr.decode().strip().splitlines()) == 1
    r = subprocess.run([str(build_dir() / "mound_scene"), "--serve"],
                       input=json.dumps(good).encode() + b"\n" + raw[:100],
                       capture_output=True, timeout=60)
    assert r.returncode == 2 and b"block: the input ended" in r.stderr
    with pytest.raises(ToolInputError, match="model.std"):
        kernel._run(block, {k: v for k, v in bad.items() if k not in ("want", "block")},
                    "logits")
