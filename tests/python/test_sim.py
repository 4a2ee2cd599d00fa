"""Site simulator end to end: python/mound/sim/site.py driving the real build/mound_render.

A small configuration (320x240 images, 0.5 m grid) keeps each render well under a second.
"""

from __future__ import annotations

import json
import subprocess
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mound.cli import main as mound_main
from mound.errors import InputError
from mound.geometry.camera import Camera, Pose, project
from mound.ply import read_ply
from mound.sim import site as sim
from mound.sim import terrain

DIST = (-0.12, 0.03, 0.0005, -0.0004, 0.0)


def small_spec(mound: bool = True, seed: int = 5, **kw: object) -> sim.SimSpec:
    t = terrain.preset("bin_tepe", resolution_m=0.5, mound=mound, seed=seed)
    base = sim.SimSpec(terrain=t, width_px=320, height_px=240, seed=seed, orbit_images=6,
                       dist=DIST)
    return replace(base, **kw)  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def pair(tmp_path_factory: pytest.TempPathFactory, mound_render: Path) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("sim")
    out = {}
    for name, mound in (("mound", True), ("flat", False)):
        sim.simulate(small_spec(mound), root / name)
        # Per-pixel geometry from the same job, through the real renderer.
        subprocess.run([str(mound_render), str(root / name / "render.json"), "--out",
                        str(root / name / "geometry"), "--geometry"], check=True,
                       capture_output=True)
        out[name] = root / name
    return out


def load_images(site: Path) -> list[np.ndarray]:
    import matplotlib.image as mpimg

    poses = json.loads((site / "poses.json").read_text())
    return [(mpimg.imread(site / im["file"]) * 255).round().astype(np.uint8)
            for im in poses["images"]]


def xyz_of(site: Path, k: int) -> np.ndarray:
    return np.load(site / "geometry" / "images" / f"{k:04d}.xyz.npy")


@pytest.mark.slow
def test_ground_truth_files_describe_the_scene(pair: dict[str, Path]) -> None:
    site = pair["mound"]
    cam_doc = json.loads((site / "camera.json").read_text())
    assert cam_doc["schema"] == "mound.camera" and cam_doc["width"] == 320
    assert cam_doc["dist_k1k2p1p2k3"] == list(DIST)
    poses = json.loads((site / "poses.json").read_text())
    assert poses["frame"] == "enu" and poses["origin"]["lat"] == pytest.approx(38.5705)
    patterns = [im["pattern"] for im in poses["images"]]
    assert patterns.count("orbit") == 6 and patterns.count("raster") >= 4
    offsets = []
    for im in poses["images"]:
        R = np.array(im["cam_from_world"]["R"])
        t = np.array(im["cam_from_world"]["t"])
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
        np.testing.assert_allclose(-R.T @ t, im["centre_enu_m"], atol=1e-9)
        assert (site / im["file"]).stat().st_size > 0
        offsets.append(np.subtract(im["gps_enu_m"], im["centre_enu_m"]))
    offsets = np.array(offsets)
    sigma = poses["gps_sigma_m"]
    assert 0.5 * sigma["horizontal"] < offsets[:, :2].std() < 1.6 * sigma["horizontal"]
    assert 0.4 * sigma["vertical"] < offsets[:, 2].std() < 1.8 * sigma["vertical"]
    # The reference surface: the heightfield array and the PLY hold the true terrain.
    hf = terrain.build(small_spec().terrain)
    z = np.load(site / "heightfield.npy")
    np.testing.assert_allclose(z, hf.z_m, atol=1e-5)
    xyz, rgb = read_ply(site / "reference.ply")
    np.testing.assert_allclose(xyz, hf.points(), atol=1e-4)
    assert rgb is not None and len(rgb) == len(xyz)
    doc = json.loads((site / "site.json").read_text())
    assert doc["heightfield"]["spacing_m"] == pytest.approx(0.5)
    assert doc["terrain"]["diameter_m"] == 60.0 and doc["mound"] is True


@pytest.mark.slow
def test_pixels_see_what_the_python_camera_projects(pair: dict[str, Path]) -> None:
    """The renderer and python/mound/geometry/camera.py agree: each pixel's ground point projects
    back onto that pixel's centre (with the distortion), for nadir and oblique views."""
    site = pair["mound"]
    poses = json.loads((site / "poses.json").read_text())
    cam_doc = json.loads((site / "camera.json").read_text())
    K = np.array(cam_doc["K"])
    cam = Camera(320, 240, K[0, 0], K[1, 1], K[0, 2], K[1, 2], tuple(cam_doc["dist_k1k2p1p2k3"]))
    for k in (0, len(poses["images"]) - 1):
        im = poses["images"][k]
        pose = Pose(np.array(im["cam_from_world"]["R"]), np.array(im["cam_from_world"]["t"]))
        xyz = xyz_of(site, k)
        v, u = np.nonzero(np.isfinite(xyz[..., 0]))
        assert len(u) > 0.5 * 320 * 240
        px, depth = project(cam, pose, xyz[v, u].astype(float))
        assert np.all(depth > 0)
        err = np.abs(px - np.stack([u, v], axis=1))
        assert np.percentile(err, 99) < 0.05 and err.max() < 0.2


@pytest.mark.slow
def test_flat_and_mound_images_differ_only_where_the_mound_is(pair: dict[str, Path]) -> None:
    spec = small_spec()
    # The mound's footprint: radius, plus the erosion blur (4 sigma), plus one grid cell of
    # smooth-shading interpolation on each side.
    region = spec.terrain.diameter_m / 2 + 4 * spec.terrain.erosion_m + 2 * 0.5
    mound_imgs, flat_imgs = load_images(pair["mound"]), load_images(pair["flat"])
    assert len(mound_imgs) == len(flat_imgs)
    differing = 0
    for k, (a, b) in enumerate(zip(mound_imgs, flat_imgs, strict=True)):
        xyz = xyz_of(pair["mound"], k)
        r = np.hypot(xyz[..., 0], xyz[..., 1])
        outside = ~(r <= region)  # sky (NaN) counts as outside
        assert np.array_equal(a[outside], b[outside]), f"image {k}: a change off the mound"
        diff = np.any(a != b, axis=-1)
        differing += int(diff.sum())
        assert np.all(r[diff] <= region)
    assert differing > 20000  # the mound is visible


def test_a_point_behind_the_mound_is_hidden_from_a_low_oblique_view(
        tmp_path: Path, mound_render: Path) -> None:
    spec = small_spec(pattern="orbit", orbit_radius_m=70.0, orbit_altitude_m=6.0,
                      orbit_images=4, dist=(0.0,) * 5)
    sim.simulate(spec, tmp_path)
    subprocess.run([str(mound_render), str(tmp_path / "render.json"), "--out",
                    str(tmp_path / "geometry"), "--geometry"], check=True, capture_output=True)
    poses = json.loads((tmp_path / "poses.json").read_text())
    im = poses["images"][0]  # at (70, 0, 6), looking west at the mound
    pose = Pose(np.array(im["cam_from_world"]["R"]), np.array(im["cam_from_world"]["t"]))
    hf = terrain.build(spec.terrain)
    behind = np.array([[-45.0, 0.0, float(hf.height_at(-45.0, 0.0))]])  # west of the mound
    cam = spec.camera()
    px, depth = project(cam, pose, behind)
    u, v = np.round(px[0]).astype(int)
    assert 0 <= u < 320 and 0 <= v < 240
    seen = np.load(tmp_path / "geometry" / "images" / "0000.xyz.npy")[v, u]
    assert seen[2] > 3.0 and seen[0] > 0, "the pixel must show the mound's near flank"
    seen_depth = np.load(tmp_path / "geometry" / "images" / "0000.depth.npy")[v, u]
    assert seen_depth < depth[0] - 50


@pytest.mark.slow
def test_same_seed_same_images_other_seed_other_images(tmp_path: Path) -> None:
    spec = small_spec(pattern="orbit", orbit_images=3)
    for name, s in (("a", spec), ("b", spec), ("c", replace(spec, seed=6))):
        sim.simulate(s, tmp_path / name)
    for k in range(3):
        a, b, c = ((tmp_path / n / "images" / f"{k:04d}.png").read_bytes() for n in "abc")
        assert a == b
        assert a != c


@pytest.mark.parametrize("argv, message", [
    (["--diameter", "-3"], "--diameter: expected a number in (0, 2000] m"),
    (["--height", "0"], "height_m must be > 0"),
    (["--altitude", "8"], "below the ground"),
    (["--hfov-deg", "190"], "--hfov-deg: expected a number in [1, 179] deg"),
    (["--vignetting", "1.5"], "vignetting"),
    (["--noise-sigma", "-1"], "--noise-sigma"),
    (["--size", "0", "240"], "--size: expected an integer 16"),
    (["--orbit-images", "2"], "--orbit-images: expected an integer 3"),
    (["--pit", "5", "1", "40"], "looters' pit"),
])
def test_impossible_parameters_are_rejected(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                            argv: list[str], message: str) -> None:
    out = tmp_path / "site"
    code = mound_main(["sim", "site", "--out", str(out), "--resolution", "1.0", *argv])
    assert code == 2
    assert message in capsys.readouterr().err
    assert not (out / "images").exists()


def test_zero_overlap_is_rejected() -> None:
    with pytest.raises(InputError, match="front_overlap"):
        sim.shots(small_spec(front_overlap=0.0))


def edit_job(site: Path, tmp: Path, change: dict) -> Path:
    job = json.loads((site / "render.json").read_text())
    for key in ("heightfield", "texture"):
        job[key]["npy"] = str(site / job[key]["npy"])
    job["images"] = job["images"][:1]
    for path, value in change.items():
        target = job
        keys = path.split(".")
        for key in keys[:-1]:
            target = target[int(key)] if key.isdigit() else target[key]
        target[keys[-1]] = value
    out = tmp / "job.json"
    out.write_text(json.dumps(job))
    return out


ROTATION = "images[0].cam_from_world.R"


@pytest.mark.parametrize("change, field", [
    ({"images.0.cam_from_world.R": [[1, 0, 0], [0, 1, 0], [0, 0, 2]]}, ROTATION),
    ({"images.0.cam_from_world.R": [[1, 0, 0], [0, 1, 0], [0, 0, -1]]}, ROTATION),
    ({"images.0.cam_from_world.t": [0, 0, -10]}, "below the ground"),
    ({"images.0.file": "../escape.png"}, "images[0].file"),
    ({"images.0.file": "a.tif"}, "images[0].file"),
    ({"camera.K": [[-5, 0, 1], [0, 5, 1], [0, 0, 1]]}, "camera.K"),
    ({"camera.width": 0}, "camera.width"),
    ({"camera.width": 20000, "camera.height": 20000}, "64 megapixels"),
    ({"heightfield.spacing_m": 0}, "heightfield.spacing_m"),
    ({"texture.npy": "/nonexistent.npy"}, "/nonexistent.npy"),
    ({"heightfield.npy": "TEXTURE"}, "heightfield.npy"),
    ({"vignetting": 1.0}, "vignetting"),
    ({"schema": "mound.plan"}, "schema"),
])
def test_mound_render_rejects_bad_jobs(pair: dict[str, Path], tmp_path: Path, mound_render: Path,
                                       change: dict, field: str) -> None:
    site = pair["mound"]
    if change.get("heightfield.npy") == "TEXTURE":
        change = {"heightfield.npy": str(site / "texture.npy")}
    job = edit_job(site, tmp_path, change)
    proc = subprocess.run([str(mound_render), str(job), "--out", str(tmp_path / "o")],
                          capture_output=True, text=True)
    assert proc.returncode == 2, proc.stderr
    assert field in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
    assert not any((tmp_path / "o").rglob("*.png"))


def test_corrupt_heightfield_npy_is_rejected(pair: dict[str, Path], tmp_path: Path,
                                             mound_render: Path) -> None:
    raw = (pair["mound"] / "heightfield.npy").read_bytes()
    bad = tmp_path / "hf.npy"
    bad.write_bytes(raw[:-100])
    job = edit_job(pair["mound"], tmp_path, {"heightfield.npy": str(bad)})
    proc = subprocess.run([str(mound_render), str(job), "--out", str(tmp_path / "o")],
                          capture_output=True, text=True)
    assert proc.returncode == 2 and "hf.npy" in proc.stderr and "bytes" in proc.stderr


@pytest.mark.parametrize("bad", [0.0, -0.1, float("nan"), float("inf")])
def test_range_checks_refuse_nan_as_well_as_out_of_range(bad: float) -> None:
    """Issue 57: a check written `x <= 0` lets NaN through; these are written so that it
    fails (`not x > 0`): the texture's texel, the camera's image size, the mission's budget
    slack and the simulator's texel each refuse 0, a negative, NaN and inf with an
    InputError naming the value."""
    from mound.sim.appearance import Lighting, shaded_texture
    from mound.sim.site import SimSpec
    from mound.sim.terrain import Heightfield, preset
    from mound.uav.mission_items import MissionSpec

    axis = np.linspace(0.0, 4.0, 5)
    hf = Heightfield(axis, axis.copy(), np.zeros((5, 5)))
    with pytest.raises(InputError, match="texel_m"):
        shaded_texture(hf, Lighting(0.5, 0.7), bad)
    if bad != float("inf"):  # an infinite image is refused by the next check (the fov)
        with pytest.raises(InputError, match="image size"):
            Camera.from_fov(bad, 480, 1.0)  # type: ignore[arg-type]
    if not bad == 0.0:  # no slack is a valid slack
        with pytest.raises(InputError, match="budget_slack"):
            MissionSpec(budget_slack=bad).check()
    if bad != float("inf"):
        with pytest.raises(InputError, match="texel_m"):
            SimSpec(terrain=preset("bin_tepe"), texel_m=bad).check()
