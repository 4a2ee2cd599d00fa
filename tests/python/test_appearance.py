"""Texture and shading of the site."""

from __future__ import annotations

import numpy as np
import pytest

from mound.errors import InputError
from mound.sim import appearance, terrain


@pytest.fixture(scope="module")
def hf() -> terrain.Heightfield:
    return terrain.build(terrain.preset("bin_tepe", resolution_m=0.5, ground_relief_m=0.0))


def test_texture_is_deterministic_and_has_detail_at_several_scales(hf) -> None:
    a = appearance.albedo(hf, seed=3)
    np.testing.assert_array_equal(a, appearance.albedo(hf, seed=3))
    assert not np.array_equal(a, appearance.albedo(hf, seed=4))
    assert a.min() >= 0 and a.max() <= 255
    grey = a.mean(axis=2)
    # Coarse detail: block means over 16 m differ; fine detail: neighbouring pixels differ.
    blocks = grey[: 320 // 32 * 32, : 320 // 32 * 32].reshape(10, 32, 10, 32).mean(axis=(1, 3))
    assert blocks.std() > 2.0
    assert np.abs(np.diff(grey, axis=1)).mean() > 0.5


def test_texture_built_in_blocks_is_the_whole_arrays_texture(hf, monkeypatch) -> None:
    """The texture is built in blocks of rows (cache-sized); the block size changes
    nothing, to the bit, with or without the light factor."""
    light = np.linspace(0.3, 1.0, 301 * 257, dtype=np.float32).reshape(301, 257)
    results = []
    for rows in (7, 32, 10_000):
        monkeypatch.setattr(appearance, "_BLOCK_ROWS", rows)
        results.append((appearance.albedo_grid((301, 257), 0.05, seed=2),
                        appearance.albedo_grid((301, 257), 0.05, seed=2, light=light)))
    for albedo, lit in results[1:]:
        np.testing.assert_array_equal(albedo, results[0][0])
        np.testing.assert_array_equal(lit, results[0][1])
    albedo, lit = results[0]
    assert lit.dtype == np.uint8
    np.testing.assert_array_equal(lit, np.clip(albedo * light[..., None], 0, 255).astype(np.uint8))


def test_lambertian_shading_follows_the_sun(hf) -> None:
    light = appearance.Lighting(sun_azimuth_rad=np.deg2rad(90), sun_elevation_rad=np.deg2rad(30))
    n = appearance.normals(hf)
    intensity = light.ambient + (1 - light.ambient) * np.clip(n @ light.sun_vector(), 0, None)
    row = len(hf.y_m) // 2
    east_flank = np.argmin(np.abs(hf.x_m - 20.0))  # faces the sun (east)
    west_flank = np.argmin(np.abs(hf.x_m + 20.0))
    assert intensity[row, east_flank] > intensity[row, west_flank] + 0.2
    flat = np.argmin(np.abs(hf.x_m - 70.0))
    assert intensity[row, flat] == pytest.approx(light.ambient + (1 - light.ambient) * 0.5,
                                                 abs=1e-6)  # sin 30 degrees
    rgb = appearance.shaded_colours(hf, light, seed=1)
    assert rgb.dtype == np.uint8 and rgb.shape == (*hf.z_m.shape, 3)


@pytest.mark.parametrize("kw", [{"sun_elevation_rad": 0.0}, {"sun_elevation_rad": -0.2},
                                {"ambient": 1.0}])
def test_bad_lighting_is_rejected(kw: dict) -> None:
    with pytest.raises(InputError):
        appearance.Lighting(**kw).sun_vector()
