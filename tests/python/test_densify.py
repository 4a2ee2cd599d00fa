"""mound_recon densify on a small simulated site (a 3 m tumulus, the nadir raster, 640 x 480
images): the dense cloud against the simulator's true heightfield and the mound's
footprint, its GeoTIFFs (orthophoto included) read back with rasterio, the verdict on it,
and bad input refused with one line."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import rasterio

from mound.cli import main as mound_main
from mound.geometry.align import apply, umeyama
from mound.ply import read_ply, read_ply_fields, write_ply
from mound.recon.defaults import SIM_RECONSTRUCT
from mound.sim.terrain import load_site_heightfield

DIAMETER_M, HEIGHT_M = 30.0, 3.0


def recon_tool(args: list[str]) -> subprocess.CompletedProcess[str]:
    from mound.paths import build_dir

    return subprocess.run([str(build_dir() / "mound_recon"), *args], capture_output=True,
                          text=True, timeout=600, check=False)


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory, mound_recon: Path) -> Path:
    out = tmp_path_factory.mktemp("dense_site")
    assert mound_main(["sim", "site", "--mound", "tumulus", "--diameter", str(DIAMETER_M),
                       "--height", str(HEIGHT_M), "--seed", "4", "--pattern", "raster",
                       "--size", "640", "480", "--threads", "2", "--out", str(out / "site")]) == 0
    r = recon_tool(["reconstruct", str(out / "site" / "images"), "--out", str(out / "recon"),
                    "--camera", str(out / "site" / "camera.json"), "--gps",
                    str(out / "site" / "poses.json"), "--threads", "2", *SIM_RECONSTRUCT.argv()])
    assert r.returncode == 0, r.stderr
    return out


@pytest.fixture(scope="module")
def dense(site: Path) -> Path:
    r = recon_tool(["densify", str(site / "recon"), "--out", str(site / "dense"),
                    "--max-image-size", "640", "--resolution-m", "0.1", "--threads", "2"])
    assert r.returncode == 0, r.stderr
    return site / "dense"


def aligned(site: Path, xyz: np.ndarray) -> np.ndarray:
    """The cloud in the simulator's frame: the similarity from the reconstructed camera
    centres onto the true ones (removes the GPS frame's own error)."""
    doc = json.loads((site / "recon" / "recon.json").read_text())
    truth = {Path(im["file"]).name: im["centre_enu_m"]
             for im in json.loads((site / "site" / "poses.json").read_text())["images"]}
    est = np.array([im["centre"] for im in doc["images"] if im["registered"]])
    tru = np.array([truth[im["file"]] for im in doc["images"] if im["registered"]])
    return apply(*umeyama(est, tru), xyz)


@pytest.mark.slow
def test_dense_cloud_lies_on_the_true_surface_and_covers_the_mound(site: Path,
                                                                    dense: Path) -> None:
    doc = json.loads((dense / "dense.json").read_text())
    assert doc["schema"] == "mound.dense" and doc["version"] == 1 and doc["status"] == "ok"
    assert len(doc["images"]) == 18 and all(len(im["sources"]) == 4 for im in doc["images"])
    f = read_ply_fields(dense / "dense.ply")
    assert {"x", "y", "z", "red", "green", "blue", "nx", "ny", "nz", "support"} <= set(f)
    assert len(f["x"]) == doc["points"] > 50_000
    xyz = aligned(site, np.stack([f["x"], f["y"], f["z"]], axis=1).astype(float))
    hf = load_site_heightfield(site / "site")
    err = np.abs(xyz[:, 2] - hf.height_at(xyz[:, 0], xyz[:, 1]))
    # Stated: median within 5 cm, 90 % within 15 cm of the true surface (2.2 cm pixels
    # at full size, depth maps at 640 px).
    assert np.median(err) < 0.05 and np.percentile(err, 90) < 0.15
    # Every 0.25 m cell of the mound's footprint holds points (>= 95 %).
    cell = 0.25
    r = DIAMETER_M / 2
    edges = np.arange(-r, r + cell, cell)
    h, _, _ = np.histogram2d(xyz[:, 1], xyz[:, 0], bins=[edges, edges])
    cx = 0.5 * (edges[:-1] + edges[1:])
    gx, gy = np.meshgrid(cx, cx)
    inside = np.hypot(gx, gy) < r
    assert (h[inside] > 0).mean() >= 0.95
    # Unit normals, facing up on this gentle terrain.
    n = np.stack([f["nx"], f["ny"], f["nz"]], axis=1)
    assert np.allclose(np.linalg.norm(n, axis=1)[np.linalg.norm(n, axis=1) > 0], 1, atol=1e-3)
    assert np.median(n[:, 2]) > 0.9
    # Far more of the footprint than the sparse cloud covers.
    s = read_ply_fields(site / "recon" / "points.ply")
    sp = aligned(site, np.stack([s["x"], s["y"], s["z"]], axis=1).astype(float))
    hs, _, _ = np.histogram2d(sp[:, 1], sp[:, 0], bins=[edges, edges])
    assert (h[inside] > 0).mean() > 3 * (hs[inside] > 0).mean()


@pytest.mark.slow
def test_rasters_and_verdict_of_the_dense_cloud(site: Path, dense: Path, tmp_path: Path) -> None:
    out = tmp_path / "rasters"
    assert mound_main(["recon", "rasters", str(site / "recon"), "--cloud",
                       str(dense / "dense.ply"), "--resolution-m", "0.5", "--out",
                       str(out)]) == 0
    doc = json.loads((out / "rasters.json").read_text())
    assert doc["files"]["orthophoto"] == "orthophoto.tif"
    with rasterio.open(out / "orthophoto.tif") as o, rasterio.open(out / "lrm.tif") as lrm:
        assert o.crs.to_epsg() == lrm.crs.to_epsg() == 32635
        assert o.transform == lrm.transform and (o.width, o.height) == (lrm.width, lrm.height)
        assert o.count == 4 and o.dtypes[0] == "uint8"
        rgba = o.read()
        relief = lrm.read(1, masked=True)
    assert (rgba[3] == 255).mean() > 0.9          # the images cover the site
    assert rgba[:3, rgba[3] == 255].std() > 10     # and carry its texture
    assert 0.75 * HEIGHT_M < float(relief.max()) < 1.3 * HEIGHT_M
    # Issue 67: this cloud (0.1 m voxels, 640 px depth maps) is not one the built-in dense
    # model was trained on: refused, naming the setting; a cloud made with densify's
    # defaults (as the survey and the grids make theirs) is judged.
    r = recon_tool(["verdict", str(site / "recon"), "--cloud", str(dense / "dense.ply"),
                    "--out", str(tmp_path / "verdict.json")])
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert "options.max_image_size is 640" in r.stderr and "--max-image-size 320" in r.stderr
    assert not (tmp_path / "verdict.json").exists()
    like = site / "dense_like_the_model"
    r = recon_tool(["densify", str(site / "recon"), "--out", str(like), "--threads", "2"])
    assert r.returncode == 0, r.stderr
    r = recon_tool(["verdict", str(site / "recon"), "--cloud", str(like / "dense.ply"),
                    "--out", str(tmp_path / "verdict.json")])
    assert r.returncode == 0, r.stderr
    v = json.loads((tmp_path / "verdict.json").read_text())
    assert v["label"] == "mound" and v["cloud"] == str(like / "dense.ply")
    assert abs(v["measurements"]["rise"]["height_m"] - HEIGHT_M) < 0.5
    # a cloud whose dense.json is gone cannot be told from another: refused
    lone = tmp_path / "lone"
    lone.mkdir()
    shutil.copy(like / "dense.ply", lone / "dense.ply")
    r = recon_tool(["verdict", str(site / "recon"), "--cloud", str(lone / "dense.ply"),
                    "--out", str(tmp_path / "v2.json")])
    assert r.returncode == 2 and "no dense.json beside" in r.stderr, r.stderr
    # the sparse model on the dense cloud: another kind of cloud, refused
    r = recon_tool(["verdict", str(site / "recon"), "--cloud", str(like / "dense.ply"),
                    "--model", "sparse", "--out", str(tmp_path / "v3.json")])
    assert r.returncode == 2 and "trained on sparse clouds" in r.stderr, r.stderr


@pytest.mark.slow
def test_a_cloud_without_ground_gives_no_terrain_model(site: Path, tmp_path: Path) -> None:
    """Issue 67: a cloud in which the ground filter finds (almost) no ground used to give a
    DTM of a few triangles and an LRM equal to the surface less a constant, with exit 0.
    Now: exit 3, rasters.json `status: failed` with why, no dtm.tif or lrm.tif, the DSM
    still written. The cloud: the site's extent filled with points whose heights scatter
    by metres from cell to cell (a noisy cloud, as at too fine a cell size; measured:
    0.1 % of the cells pass the filter)."""
    recon = tmp_path / "recon"
    shutil.copytree(site / "recon", recon)
    xyz, _ = read_ply(recon / "points.ply")
    lo, hi = np.percentile(xyz[:, :2], [5, 95], axis=0)
    rng = np.random.default_rng(7)
    gx, gy = np.meshgrid(np.arange(lo[0], hi[0], 0.5), np.arange(lo[1], hi[1], 0.5))
    z = rng.normal(0.0, 3.0, gx.shape)
    cloud = np.column_stack([gx.ravel(), gy.ravel(), z.ravel()])
    write_ply(recon / "points.ply", cloud)
    out = tmp_path / "rasters"
    r = subprocess.run([sys.executable, "-m", "mound", "recon", "rasters", str(recon),
                        "--resolution-m", "0.5", "--out", str(out), "--no-orthophoto"],
                       capture_output=True, text=True, check=False, timeout=300)
    assert r.returncode == 3, r.stderr
    assert "too little ground" in r.stderr and r.stderr.count("\n") == 1, r.stderr
    doc = json.loads((out / "rasters.json").read_text())
    assert doc["status"] == "failed" and "too little ground" in doc["reason"]
    assert doc["ground_share_of_observed"] < 0.02
    assert (out / "dsm.tif").is_file() and not (out / "dtm.tif").exists()
    assert not (out / "lrm.tif").exists() and set(doc["files"]) == {"dsm", "hillshade"}


@pytest.mark.slow
def test_bad_input_is_refused_with_one_line(site: Path, tmp_path: Path) -> None:
    def copy(**changes: object) -> Path:
        d = tmp_path / f"recon{len(list(tmp_path.iterdir()))}"
        shutil.copytree(site / "recon", d)
        doc = json.loads((d / "recon.json").read_text())
        doc.update(changes)
        (d / "recon.json").write_text(json.dumps(doc))
        return d

    cases = [
        (copy(status="failed", reason="too little motion"), [], "too little motion"),
        (copy(frame="arbitrary", scale="unknown"), [], "georeferenced"),
        (copy(frame=3, reason=None), [], "georeferenced"),
        (copy(status="failed", reason=7), [], "no reason given"),
        (copy(images_dir=str(tmp_path / "nowhere")), [], "images_dir"),
        (site / "recon", ["--resolution-m", "0"], "--resolution-m"),
        (site / "recon", ["--window", "4"], "--window"),
        (site / "recon", ["--images", str(tmp_path / "nowhere")], "--images"),
    ]
    empty = copy()
    (empty / "points.ply").write_bytes(
        b"ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\n"
        b"property float y\nproperty float z\nend_header\n")
    cases.append((empty, [], "points.ply"))
    for recon, extra, expect in cases:
        out = tmp_path / "out"
        r = recon_tool(["densify", str(recon), "--out", str(out), *extra])
        assert r.returncode == 2, (expect, r.stderr)
        assert len(r.stderr.strip().splitlines()) == 1 and expect in r.stderr, r.stderr
        assert not (out / "dense.ply").exists()
