"""Site terrain (heightfield with a tumulus) and the PLY writer."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mound.errors import InputError
from mound.ply import read_ply, write_ply
from mound.sim import terrain


def test_mound_and_flat_control_differ_only_where_the_mound_is() -> None:
    spec = terrain.preset("bin_tepe", resolution_m=1.0, seed=4)
    with_mound = terrain.build(spec)
    flat = terrain.build(replace(spec, mound=False))
    diff = with_mound.z_m - flat.z_m
    xx, yy = np.meshgrid(with_mound.x_m, with_mound.y_m)
    r = np.hypot(xx, yy)
    outside = r > spec.diameter_m / 2 + 4 * spec.erosion_m
    assert np.abs(diff[outside]).max() < 1e-9
    centre = diff[np.unravel_index(np.argmin(r), r.shape)]
    assert centre == pytest.approx(spec.height_m, rel=0.02)  # erosion rounds the top a little
    assert diff.min() >= -1e-9  # a mound without a pit only adds height


@pytest.mark.parametrize("profile", terrain.PROFILES)
def test_profiles_fall_from_the_centre(profile: str) -> None:
    # Without erosion the shapes are exact: apex at height_m, zero at the rim.
    spec = terrain.preset("bin_tepe", resolution_m=0.5, profile=profile, ground_relief_m=0.0,
                          erosion_m=0.0)
    hf = terrain.build(spec)
    row = hf.z_m[len(hf.y_m) // 2, len(hf.x_m) // 2:]
    assert np.all(np.diff(row) <= 1e-9)
    assert row[0] == pytest.approx(spec.height_m, rel=1e-9)
    assert float(hf.height_at(spec.diameter_m / 2 + 0.5, 0.0)) == pytest.approx(0.0, abs=1e-9)


def test_looters_pit_is_a_depression_on_the_mound() -> None:
    base = terrain.preset("bin_tepe", resolution_m=0.5, ground_relief_m=0.0)
    pit = replace(base, pit_radius_m=4.0, pit_depth_m=3.0, pit_offset_m=10.0)
    a, b = terrain.build(base), terrain.build(pit)
    assert float(a.height_at(10.0, 0.0) - b.height_at(10.0, 0.0)) == pytest.approx(3.0, abs=0.1)
    assert float(a.height_at(-10.0, 0.0)) == pytest.approx(float(b.height_at(-10.0, 0.0)))


def test_same_seed_same_ground_and_lab_preset_scale() -> None:
    spec = terrain.preset("lab")
    a, b = terrain.build(spec), terrain.build(spec)
    np.testing.assert_array_equal(a.z_m, b.z_m)
    assert terrain.build(replace(spec, seed=1)).z_m.tolist() != a.z_m.tolist()
    assert a.z_m.max() == pytest.approx(0.15, rel=0.05)


@pytest.mark.parametrize("bad", [
    {"diameter_m": -5.0}, {"height_m": 0.0}, {"size_m": -1.0}, {"profile": "pyramid"},
    {"resolution_m": 0.0}, {"diameter_m": 500.0}, {"profile": "drum", "drum_height_m": 20.0},
    {"pit_radius_m": 5.0, "pit_depth_m": 1.0, "pit_offset_m": 40.0},
])
def test_impossible_terrain_is_rejected(bad: dict) -> None:
    with pytest.raises(InputError):
        terrain.preset("bin_tepe", **bad)


def test_ply_round_trip_and_errors(tmp_path: Path) -> None:
    hf = terrain.build(terrain.preset("lab", resolution_m=0.05))
    pts = hf.points()
    rgb = np.tile(np.array([[10, 200, 30]], dtype=np.uint8), (len(pts), 1))
    path = tmp_path / "ref.ply"
    write_ply(path, pts, rgb, comment="mound.reference v1")
    xyz, back = read_ply(path)
    np.testing.assert_allclose(xyz, pts, atol=1e-6)
    np.testing.assert_array_equal(back, rgb)
    assert b"comment mound.reference v1" in path.read_bytes()[:200]
    path.write_bytes(path.read_bytes()[:-7])
    with pytest.raises(InputError, match="truncated"):
        read_ply(path)
    with pytest.raises(InputError):
        write_ply(tmp_path / "nan.ply", np.array([[0.0, np.nan, 1.0]]))
    assert not (tmp_path / "nan.ply").exists()
