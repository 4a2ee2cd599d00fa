"""mound_recon reconstruct on small simulated sites, against the simulator's ground truth,
and COLMAP (pycolmap) reading its text export."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from mound.cli import main as mound_main
from mound.geometry.align import apply, umeyama
from mound.ply import read_ply
from mound.recon.defaults import SIM_RECONSTRUCT
from mound.sim.terrain import load_site_heightfield


def run_recon(args: list[str]) -> subprocess.CompletedProcess[str]:
    from mound.paths import build_dir

    return subprocess.run([str(build_dir() / "mound_recon"), *args], capture_output=True, text=True,
                          timeout=600, check=False)


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory, mound_recon: Path) -> Path:
    out = tmp_path_factory.mktemp("recon_site")
    assert mound_main(["sim", "site", "--mound", "tumulus", "--seed", "3", "--pattern", "orbit",
                       "--orbit-images", "12", "--size", "640", "480", "--out", str(out)]) == 0
    return out


@pytest.fixture(scope="module")
def recon(site: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("recon_out")
    r = run_recon(["reconstruct", str(site / "images"), "--out", str(out), "--camera",
                   str(site / "camera.json"), "--gps", str(site / "poses.json"), "--threads", "2",
                   *SIM_RECONSTRUCT.argv()])
    assert r.returncode == 0, r.stderr
    return out


@pytest.mark.slow
def test_poses_scale_and_cloud_match_the_truth(site: Path, recon: Path) -> None:
    doc = json.loads((recon / "recon.json").read_text())
    poses = json.loads((site / "poses.json").read_text())
    assert doc["schema"] == "mound.recon" and doc["status"] == "ok"
    assert doc["registered"] == 12 and all(im["registered"] for im in doc["images"])
    assert doc["frame"] == "enu" and doc["scale"] == "metric"
    # the poses' origin, and what its height is above (issue 67: a poses file's origin is
    # ellipsoidal unless it says otherwise)
    assert doc["origin"] == {**poses["origin"], "alt_datum": "ellipsoid"}
    assert doc["reprojection_rmse_px"] < 0.5 and doc["points"] > 2000
    truth = {im["file"].split("/")[-1]: im for im in poses["images"]}
    est_c = np.array([im["centre"] for im in doc["images"]])
    true_c = np.array([truth[im["file"]]["centre_enu_m"] for im in doc["images"]])
    # In the GPS frame: off by about the GPS noise (sigma 1 m horizontal, 2 m vertical),
    # averaged over 12 images.
    assert np.sqrt(np.mean(np.sum((est_c - true_c) ** 2, axis=1))) < 2.5
    # Metric scale: distances between cameras within 2 % of the true ones.
    d_est = np.linalg.norm(est_c[:, None] - est_c[None], axis=2)
    d_true = np.linalg.norm(true_c[:, None] - true_c[None], axis=2)
    ratio = d_est[d_true > 0] / d_true[d_true > 0]
    assert abs(np.median(ratio) - 1) < 0.02
    # The shape, after a similarity to the truth: centres within 5 cm; relative rotations
    # between every two images (independent of the frame) within 0.25 degrees. At 640 px
    # (f = 457 px) over gently sloping ground, a rotation about an image-plane axis trades
    # off against a sideways shift (the bas-relief ambiguity): the worst pair of this
    # 12-image orbit measured 0.05-0.12 deg across small changes of the matcher, at a
    # reprojection RMSE of 0.19 px.
    s, rot, t = umeyama(est_c, true_c)
    aligned = apply(s, rot, t, est_c)
    assert np.max(np.linalg.norm(aligned - true_c, axis=1)) < 0.05
    r_est = [np.array(im["cam_from_world"]["R"]) for im in doc["images"]]
    r_true = [np.array(truth[im["file"]]["cam_from_world"]["R"]) for im in doc["images"]]
    for a in range(len(r_est)):
        for b in range(a + 1, len(r_est)):
            d = (r_est[a] @ r_est[b].T) @ (r_true[a] @ r_true[b].T).T
            angle = np.degrees(np.arccos(np.clip((np.trace(d) - 1) / 2, -1, 1)))
            assert angle < 0.25, (doc["images"][a]["file"], doc["images"][b]["file"], angle)
    # The cloud on the true surface: heights against the heightfield at each point.
    xyz, rgb = read_ply(recon / "points.ply")
    assert len(xyz) == doc["points"] and rgb is not None
    p = apply(s, rot, t, xyz)
    hf = load_site_heightfield(site)
    inside = hf.covers(p[:, 0], p[:, 1])
    err = np.abs(p[inside, 2] - hf.height_at(p[inside, 0], p[inside, 1]))
    assert inside.mean() > 0.95
    assert np.median(err) < 0.05 and np.percentile(err, 90) < 0.25


@pytest.mark.slow
def test_colmap_reads_the_export_and_agrees(recon: Path) -> None:
    pycolmap = pytest.importorskip("pycolmap")
    doc = json.loads((recon / "recon.json").read_text())
    r = pycolmap.Reconstruction(str(recon))
    assert r.num_reg_images() == doc["registered"] and r.num_points3D() == doc["points"]
    errors = []
    for image in r.images.values():
        cam = r.cameras[image.camera_id]
        for p2 in image.points2D:
            if p2.has_point3D():
                uv = cam.img_from_cam(image.cam_from_world() * r.points3D[p2.point3D_id].xyz)
                errors.append(np.linalg.norm(uv - p2.xy))
    # COLMAP's own camera model and pixel convention reproduce our residuals.
    rmse = np.sqrt(np.mean(np.square(errors)))
    assert rmse == pytest.approx(doc["reprojection_rmse_px"], rel=0.05)
    est = {im["file"]: np.array(im["centre"]) for im in doc["images"]}
    for image in r.images.values():
        assert np.linalg.norm(image.projection_center() - est[image.name]) < 1e-6


@pytest.mark.slow
def test_without_gps_the_frame_is_arbitrary_and_runs_repeat(site: Path, tmp_path: Path) -> None:
    sub = tmp_path / "images"
    sub.mkdir()
    for f in sorted((site / "images").iterdir())[:6]:
        shutil.copy(f, sub / f.name)
    r = run_recon(["reconstruct", str(sub), "--out", str(tmp_path / "out"), "--camera",
                   str(site / "camera.json"), "--threads", "2", *SIM_RECONSTRUCT.argv()])
    assert r.returncode == 0, r.stderr
    doc = json.loads((tmp_path / "out" / "recon.json").read_text())
    assert doc["frame"] == "arbitrary" and doc["scale"] == "unknown" and "origin" not in doc
    assert doc["registered"] == 6
    # The same seed gives the same model with two threads: the same points and tracks,
    # coordinates equal to 1e-9 (Ceres' threads may sum in another order).
    again = run_recon(["reconstruct", str(sub), "--out", str(tmp_path / "again"), "--camera",
                       str(site / "camera.json"), "--threads", "2", *SIM_RECONSTRUCT.argv()])
    assert again.returncode == 0, again.stderr
    for name in ("images.txt", "points3D.txt"):
        a = (tmp_path / "out" / name).read_text().split()
        b = (tmp_path / "again" / name).read_text().split()
        assert len(a) == len(b), name
        def numbers(words: list[str]) -> list[float]:
            return [float(w) for w in words if w.lstrip("-").replace(".", "", 1).replace(
                "e-", "", 1).replace("e+", "", 1).isdigit()]

        assert [w for w in a if not numbers([w])] == [w for w in b if not numbers([w])]
        np.testing.assert_allclose(numbers(a), numbers(b), rtol=1e-9, atol=1e-9)


@pytest.mark.slow
def test_retrieval_registers_an_unlocated_set_in_no_order(site: Path, tmp_path: Path) -> None:
    """Images without positions under names that say nothing of the capture order: pairs
    come from VLAD retrieval alone (no sequence window), fewer than every pair, they see
    the same ground, and every image is registered."""
    sub = tmp_path / "images"
    sub.mkdir()
    files = sorted((site / "images").iterdir())
    order = np.random.default_rng(5).permutation(len(files))
    for k, f in zip(order, files, strict=True):
        shutil.copy(f, sub / f"img_{k:02d}.png")
    r = run_recon(["reconstruct", str(sub), "--out", str(tmp_path / "out"), "--camera",
                   str(site / "camera.json"), "--matching", "retrieval", "--window", "0",
                   "--neighbours", "3", "--threads", "2", *SIM_RECONSTRUCT.argv()])
    assert r.returncode == 0, r.stderr
    doc = json.loads((tmp_path / "out" / "recon.json").read_text())
    n = len(files)
    assert doc["inputs"]["pairing"] == "sequential+retrieval"
    assert doc["inputs"]["pairs_matched"] <= 3 * n < n * (n - 1) // 2
    # Retrieved pairs see the same ground: all but one verified (of every pair of this
    # orbit, 48 of 66 are: a random choice would fail about a quarter).
    assert doc["inputs"]["pairs_verified"] >= doc["inputs"]["pairs_matched"] - 1
    assert doc["registered"] == n


def bad_inputs(site: Path, tmp: Path) -> list[tuple[str, list[str], int, str]]:
    images = site / "images"
    one = tmp / "one"
    one.mkdir()
    shutil.copy(images / "0000.png", one)
    broken = tmp / "broken"
    broken.mkdir()
    for f in ("0000.png", "0001.png"):
        shutil.copy(images / f, broken)
    (broken / "0002.png").write_bytes(b"not a png")
    sizes = tmp / "sizes"
    sizes.mkdir()
    shutil.copy(images / "0000.png", sizes)
    shutil.copy(site / "images" / "0001.png", sizes / "0001.png")
    import matplotlib.image as mpimg
    mpimg.imsave(sizes / "0002.png", np.zeros((100, 120, 3), dtype=np.uint8))
    cam = json.loads((site / "camera.json").read_text())
    cam["width"] = 1280
    wrong_cam = tmp / "wrong_camera.json"
    wrong_cam.write_text(json.dumps(cam))
    poses = json.loads((site / "poses.json").read_text())
    poses["images"].append({**poses["images"][0], "file": "images/9999.png"})
    ghost = tmp / "ghost_poses.json"
    ghost.write_text(json.dumps(poses))
    empty = tmp / "empty"
    empty.mkdir()
    return [
        ("no images", [str(empty)], 2, "at least 2"),
        ("one image", [str(one)], 2, "at least 2"),
        ("missing folder", [str(tmp / "nowhere")], 2, "not a directory"),
        ("unreadable image", [str(broken)], 2, "0002.png"),
        ("sizes differ", [str(sizes)], 2, "0002.png"),
        ("camera of other images", [str(images), "--camera", str(wrong_cam)], 2, "width x height"),
        ("GPS of a missing image", [str(images), "--gps", str(ghost)], 2, "9999.png"),
        ("bad option", [str(images), "--matching", "psychic"], 2, "--matching"),
        ("bad lens", [str(images), "--lens", "loose"], 2, "--lens"),
        ("lens of a calibrated camera", [str(images), "--camera", str(site / "camera.json"),
                                         "--lens", "free"], 2, "--lens"),
    ]


@pytest.mark.slow
def test_bad_input_is_refused_with_one_line(site: Path, tmp_path: Path) -> None:
    for name, args, code, message in bad_inputs(site, tmp_path):
        out = tmp_path / ("out_" + name.replace(" ", "_"))
        r = run_recon(["reconstruct", *args, "--out", str(out), "--threads", "2"])
        assert r.returncode == code, (name, r.stderr)
        assert message in r.stderr and r.stderr.count("\n") == 1, (name, r.stderr)
        assert not (out / "recon.json").exists(), name


def test_no_texture_is_no_result_with_a_reason(tmp_path: Path) -> None:
    import matplotlib.image as mpimg

    images = tmp_path / "images"
    images.mkdir()
    for k in range(4):  # a blank wall: no features, nothing to match
        mpimg.imsave(images / f"{k:04d}.png", np.full((240, 320, 3), 128, dtype=np.uint8))
    r = run_recon(["reconstruct", str(images), "--out", str(tmp_path / "out")])
    assert r.returncode == 3, r.stderr
    doc = json.loads((tmp_path / "out" / "recon.json").read_text())
    assert doc["status"] == "failed" and "too little motion or texture" in doc["reason"]
    assert not (tmp_path / "out" / "points.ply").exists()


@pytest.mark.slow
def test_figure_of_the_reconstruction(recon: Path, tmp_path: Path) -> None:
    import matplotlib.image as mpimg

    png = tmp_path / "recon.png"
    assert mound_main(["recon", "figure", str(recon), "--out", str(png)]) == 0
    img = mpimg.imread(png)
    assert img.shape[0] > 300 and img[..., :3].std() > 0.05  # a picture, not a blank page
