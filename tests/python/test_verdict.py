"""mound_recon compare and verdict on small simulated sites (a tumulus and its flat
control, reconstructed from 12 images), and every bad input."""

from __future__ import annotations

import json
import math
import shutil
import struct
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from mound.cli import main as mound_main
from mound.ply import read_ply, read_ply_fields
from mound.recon.defaults import SIM_RECONSTRUCT


def run_recon(args: list[str]) -> subprocess.CompletedProcess[str]:
    from mound.paths import build_dir

    return subprocess.run([str(build_dir() / "mound_recon"), *args], capture_output=True, text=True,
                          timeout=600, check=False)


def reconstruct(tmp: pytest.TempPathFactory, mound: str) -> tuple[Path, Path]:
    site = tmp.mktemp(f"site_{mound}")
    assert mound_main(["sim", "site", "--mound", mound, "--seed", "5", "--pattern", "orbit",
                       "--orbit-images", "12", "--size", "640", "480", "--out", str(site)]) == 0
    out = tmp.mktemp(f"recon_{mound}")
    r = run_recon(["reconstruct", str(site / "images"), "--out", str(out), "--camera",
                   str(site / "camera.json"), "--gps", str(site / "poses.json"), "--threads", "2",
                   *SIM_RECONSTRUCT.argv()])
    assert r.returncode == 0, r.stderr
    return site, out


@pytest.fixture(scope="module")
def tumulus(tmp_path_factory: pytest.TempPathFactory, mound_recon: Path) -> tuple[Path, Path]:
    return reconstruct(tmp_path_factory, "tumulus")


@pytest.fixture(scope="module")
def flat(tmp_path_factory: pytest.TempPathFactory, mound_recon: Path) -> tuple[Path, Path]:
    return reconstruct(tmp_path_factory, "none")


@pytest.mark.slow
def test_reference_free_verdicts(tumulus: tuple[Path, Path], flat: tuple[Path, Path],
                                 tmp_path: Path) -> None:
    site, recon = tumulus
    r = run_recon(["verdict", str(recon), "--out", str(tmp_path / "v.json")])
    assert r.returncode == 0, r.stderr
    v = json.loads((tmp_path / "v.json").read_text())
    assert v["schema"] == "mound.verdict" and v["method"] == "reference_free_model"
    assert v["label"] == "mound", v["reason"]
    assert v["p_mound"] >= v["model"]["threshold"] and v["confidence"] == v["p_mound"]
    assert set(v["measurements"]["features"]) == set(DEFAULT_MODEL["features"])
    spec = json.loads((site / "site.json").read_text())["terrain"]
    rise = v["measurements"]["rise"]
    # The bin_tepe preset: 60 m across, 12 m high (eroded edges): measured within 20 %.
    assert abs(rise["height_m"] - spec["height_m"]) < 0.2 * spec["height_m"], rise
    assert abs(rise["base_diameter_m"] - spec["diameter_m"]) < 0.2 * spec["diameter_m"], rise
    assert math.hypot(*rise["centre_enu_m"]) < 3.0
    _, recon_flat = flat
    r = run_recon(["verdict", str(recon_flat), "--out", str(tmp_path / "f.json")])
    assert r.returncode == 0, r.stderr
    f = json.loads((tmp_path / "f.json").read_text())
    assert f["label"] == "no_mound", f["reason"]
    assert f["p_mound"] < f["model"]["threshold"]


DEFAULT_MODEL = json.loads((Path(__file__).resolve().parents[2] / "data" /
                            "verdict_model.json").read_text())
DENSE_MODEL = json.loads((Path(__file__).resolve().parents[2] / "data" /
                          "verdict_model_dense.json").read_text())


@pytest.mark.slow
def test_the_verdict_model_file_round_trips(tumulus: tuple[Path, Path], tmp_path: Path) -> None:
    """The shipped model, written out and read back by mound_recon, gives the p that the
    Python side computes from the detector's features; a changed weight changes it as
    predicted; models for other features or with bad fields are refused naming the field."""
    from mound.training.verdict_model import VerdictModel, probability, rises_of

    _, recon = tumulus
    r = run_recon(["verdict", str(recon), "--out", str(tmp_path / "d.json")])
    assert r.returncode == 0, r.stderr
    default = json.loads((tmp_path / "d.json").read_text())
    row = rises_of(default["measurements"]["judged_rises"], "d.json")
    assert default["p_mound"] == pytest.approx(
        probability(VerdictModel.of(DEFAULT_MODEL), [row])[0], abs=1e-12)
    assert default["model"]["file"].startswith("built-in sparse")
    # another cloud (--cloud: densify's) is judged by the dense model unless --model says
    # otherwise; the same cloud gives the same rises, so the p differ by the model alone
    # (the sparse cloud stands in for a dense one here: a dense.json beside it says it was
    # made as the dense model's training clouds were, which the verdict checks: issue 67)
    stand_in = tmp_path / "dense_stand_in"
    stand_in.mkdir()
    shutil.copy(recon / "points.ply", stand_in / "dense.ply")
    (stand_in / "dense.json").write_text(json.dumps(
        {"schema": "mound.dense", "version": 1,
         "options": {"max_image_size": 320, "resolution_m": 0.25}}))
    cloud = ["--cloud", str(stand_in / "dense.ply")]
    r = run_recon(["verdict", str(recon), "--out", str(tmp_path / "dd.json"), *cloud])
    assert r.returncode == 0, r.stderr
    dense = json.loads((tmp_path / "dd.json").read_text())
    assert dense["model"]["file"].startswith("built-in dense")
    assert dense["model"]["threshold"] == DENSE_MODEL["threshold"]
    assert dense["p_mound"] == pytest.approx(
        probability(VerdictModel.of(DENSE_MODEL), [row])[0], abs=1e-12)
    # the sparse model on a dense cloud: another kind of cloud than it learned, refused
    r = run_recon(["verdict", str(recon), "--out", str(tmp_path / "ds.json"), *cloud,
                   "--model", "sparse"])
    assert r.returncode == 2 and "trained on sparse clouds" in r.stderr, r.stderr
    changed = json.loads(json.dumps(DEFAULT_MODEL))
    changed["weights"][0] += 0.5
    changed["bias"] -= 0.25
    (tmp_path / "m.json").write_text(json.dumps(changed))
    r = run_recon(["verdict", str(recon), "--out", str(tmp_path / "c.json"), "--model",
                   str(tmp_path / "m.json")])
    assert r.returncode == 0, r.stderr
    c = json.loads((tmp_path / "c.json").read_text())
    assert c["p_mound"] == pytest.approx(probability(VerdictModel.of(changed), [row])[0], abs=1e-12)
    # the other weights moved the score (its log-odds: a clear tumulus's p is near 1, where
    # p itself hardly moves)
    assert abs(math.log(c["p_mound"] / (1 - c["p_mound"]))
               - math.log(default["p_mound"] / (1 - default["p_mound"]))) > 0.1
    bad: dict[str, tuple[Any, str]] = {
        "other features": (lambda d: d["features"].__setitem__(0, "log_width"), "features"),
        "no bias": (lambda d: d.pop("bias"), "bias"),
        "std 0": (lambda d: d["std"].__setitem__(3, 0.0), "std"),
        "short weights": (lambda d: d["weights"].pop(), "weights"),
        "threshold": (lambda d: d.__setitem__("threshold", 2.0), "threshold"),
        "schema": (lambda d: d.__setitem__("schema", "mound.scene_model"), "schema"),
        "nan": (lambda d: d["mean"].__setitem__(0, "nan"), "mean"),
        "decreasing calibration": (lambda d: d.__setitem__(
            "calibration", {"method": "beta", "a": -1.0, "b": 1.0, "c": 0.0}), "calibration"),
    }
    for name, (edit, field) in bad.items():
        doc = json.loads(json.dumps(DEFAULT_MODEL))
        edit(doc)
        (tmp_path / "bad.json").write_text(json.dumps(doc))
        r = run_recon(["verdict", str(recon), "--out", str(tmp_path / "b.json"), "--model",
                       str(tmp_path / "bad.json")])
        assert r.returncode == 2, (name, r.stderr)
        assert field in r.stderr and r.stderr.count("\n") == 1, (name, r.stderr)
    (tmp_path / "bad.json").write_text("{not json")
    r = run_recon(["verdict", str(recon), "--out", str(tmp_path / "b.json"), "--model",
                   str(tmp_path / "bad.json")])
    assert r.returncode == 2 and "not JSON" in r.stderr, r.stderr


@pytest.mark.slow
def test_paper_test_and_compare(tumulus: tuple[Path, Path], flat: tuple[Path, Path],
                                tmp_path: Path) -> None:
    site, recon = tumulus
    ref = site / "reference.ply"
    r = run_recon(["compare", str(recon / "points.ply"), str(ref), "--out", str(tmp_path / "c")])
    assert r.returncode == 0, r.stderr
    c = json.loads((tmp_path / "c" / "compare.json").read_text())
    assert c["schema"] == "mound.compare" and c["status"] == "ok" and c["converged"]
    # Both clouds are in the site's ENU frame: ICP corrects the GPS-sized error only.
    assert abs(c["reference_from_cloud"]["scale"] - 1) < 0.05
    assert c["distance_m"]["median"] < 0.1
    xyz, _ = read_ply(tmp_path / "c" / "aligned.ply")
    assert len(xyz) == c["points"]["cloud"]
    verdicts = {}
    for name, rd in (("tumulus", recon), ("flat", flat[1])):
        out = tmp_path / f"{name}.json"
        r = run_recon(["verdict", str(rd), "--reference", str(ref), "--out", str(out)])
        assert r.returncode == 0, r.stderr
        verdicts[name] = json.loads(out.read_text())
    m, f = verdicts["tumulus"]["measurements"], verdicts["flat"]["measurements"]
    assert verdicts["tumulus"]["label"] == "mound" and verdicts["flat"]["label"] == "no_mound"
    assert m["mu_m"] < m["threshold_m"] < f["mu_m"]


def write(path: Path, data: bytes) -> Path:
    path.write_bytes(data)
    return path


@pytest.mark.slow
def test_bad_inputs(tumulus: tuple[Path, Path], tmp_path: Path) -> None:
    site, recon = tumulus
    ref = str(site / "reference.ply")
    header = b"ply\nformat binary_little_endian 1.0\nelement vertex 20\n" \
             b"property float x\nproperty float y\nproperty float z\nend_header\n"
    cases = {
        "empty": (write(tmp_path / "empty.ply", b""), "not a PLY file"),
        "not ply": (write(tmp_path / "x.ply", b"solid stl\n"), "not a PLY file"),
        "truncated": (write(tmp_path / "t.ply", header + b"\0" * 100), "truncated"),
        "nan": (write(tmp_path / "n.ply", header + struct.pack("<3f", 1, math.nan, 2) * 20),
                "non-finite"),
    }
    for name, (path, words) in cases.items():
        r = run_recon(["compare", str(path), ref, "--out", str(tmp_path / "o")])
        assert r.returncode == 2, (name, r.stderr)
        assert words in r.stderr and r.stderr.count("\n") == 1, (name, r.stderr)
    # No overlap: a cloud 10 km away in the same frame.
    xyz, _ = read_ply(recon / "points.ply")
    far = xyz + np.array([1e4, 0, 0])
    body = b"".join(struct.pack("<3f", *p) for p in far.astype(np.float32))
    hdr = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(far)}\nproperty float x\n"
           "property float y\nproperty float z\nend_header\n").encode()
    r = run_recon(["compare", str(write(tmp_path / "far.ply", hdr + body)), ref, "--init", "none",
                   "--out", str(tmp_path / "far")])
    assert r.returncode == 3, r.stderr
    doc = json.loads((tmp_path / "far" / "compare.json").read_text())
    assert doc["status"] == "failed" and "overlap" in doc["reason"]
    # Verdict: a directory without recon.json; a model without GPS for the reference-free test.
    r = run_recon(["verdict", str(tmp_path), "--out", str(tmp_path / "v.json")])
    assert r.returncode == 2 and "recon.json" in r.stderr
    bare = tmp_path / "bare"
    bare.mkdir()
    doc = json.loads((recon / "recon.json").read_text())
    doc["frame"], doc["scale"] = "arbitrary", "unknown"
    (bare / "recon.json").write_text(json.dumps(doc))
    (bare / "points.ply").write_bytes((recon / "points.ply").read_bytes())
    r = run_recon(["verdict", str(bare), "--out", str(tmp_path / "v.json")])
    assert r.returncode == 3, r.stderr
    v = json.loads((tmp_path / "v.json").read_text())
    assert v["status"] == "failed" and "georeferenced" in v["reason"]
    r = run_recon(["verdict", str(recon), "--out", str(tmp_path / "v.json"), "--radius", "-1"])
    assert r.returncode == 2 and "--radius" in r.stderr


def test_distance_statistics_of_a_constructed_case(tmp_path: Path, mound_recon: Path) -> None:
    """A plane z = 0 sampled on a 0.25 m grid and points above and below it at known
    distances (uniform in [0, 1] m, signs alternating, so that ICP has nothing to correct):
    the statistics are those of the uniform distribution."""
    g = np.arange(-20, 20.001, 0.25)
    xx, yy = np.meshgrid(g, g)
    ref = np.column_stack([xx.ravel(), yy.ravel(), np.zeros(xx.size)])
    rng = np.random.default_rng(4)
    n = 4000
    d = (np.arange(n) + 0.5) / n  # exactly uniform
    rng.shuffle(d)
    xy = rng.uniform(-15, 15, (n, 2))
    sign = np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    cloud = np.column_stack([xy, sign * d])

    def ply(path: Path, xyz: np.ndarray) -> Path:
        hdr = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(xyz)}\n"
               "property float x\nproperty float y\nproperty float z\nend_header\n").encode()
        path.write_bytes(hdr + xyz.astype("<f4").tobytes())
        return path

    r = run_recon(["compare", str(ply(tmp_path / "c.ply", cloud)),
                   str(ply(tmp_path / "r.ply", ref)), "--out", str(tmp_path / "o")])
    assert r.returncode == 0, r.stderr
    doc = json.loads((tmp_path / "o" / "compare.json").read_text())
    dm = doc["distance_m"]
    assert doc["init"] == "none"
    assert dm["mean"] == pytest.approx(0.5, abs=0.01)
    assert dm["std"] == pytest.approx(1 / math.sqrt(12), abs=0.01)
    assert dm["median"] == pytest.approx(0.5, abs=0.01)
    assert dm["p90"] == pytest.approx(0.9, abs=0.01)
    assert dm["max"] == pytest.approx(1.0, abs=0.01)
    # N(mu, sigma) below the 99th percentile: uniform on [0, 0.99].
    assert dm["normal_fit"]["mu"] == pytest.approx(0.495, abs=0.01)
    assert dm["normal_fit"]["sigma"] == pytest.approx(0.99 / math.sqrt(12), abs=0.01)
    h = dm["histogram"]
    assert sum(h["counts"]) + h["above_last_bin"] == n
    assert max(h["counts"]) - min(h["counts"]) < 0.02 * n  # flat
    fields = read_ply_fields(tmp_path / "o" / "aligned.ply")
    assert np.sort(fields["distance"]) == pytest.approx(np.sort(d), abs=0.01)
