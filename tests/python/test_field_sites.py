"""Sites that look like the field (issue 26): tumuli off centre, ploughed, trenched, on a
slope or on the real 1 m laser DEM; confusers; their ground truth; the grid's draws."""

from __future__ import annotations

import subprocess
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from mound.errors import InputError
from mound.formats.grid import GridLook
from mound.geometry.flight import DEFAULT_SITE_DIAMETER_M
from mound.grids import run as grid_run
from mound.sim import draws, looks, terrain
from mound.sim.dem_places import DemPlaces

DEM = "dem/TM1_564_146.tif"


def flat(**kw: object) -> terrain.TerrainSpec:
    return terrain.preset("bin_tepe", **{"resolution_m": 0.5, "ground_relief_m": 0.0, **kw})


def test_an_offset_mound_stands_where_its_truth_says() -> None:
    spec = flat(diameter_m=40.0, height_m=6.0, mound_x_m=12.0, mound_y_m=-7.0)
    hf = terrain.build(spec)
    i, j = np.unravel_index(np.argmax(hf.z_m), hf.z_m.shape)
    assert (hf.x_m[j], hf.y_m[i]) == pytest.approx((12.0, -7.0), abs=0.5)
    t = spec.truth()
    assert t["mound"] and t["kind"] == "tumulus" and t["centre_enu_m"] == [12.0, -7.0]
    with pytest.raises(InputError, match="fit on the site"):
        flat(diameter_m=150.0, mound_x_m=20.0)


def test_ploughed_top_is_flat_and_a_trench_cuts_through_the_top() -> None:
    hf = terrain.build(flat(profile="ploughed", diameter_m=60.0, height_m=5.0, erosion_m=0.0))
    near_top = hf.z_m[np.hypot(*np.meshgrid(hf.x_m, hf.y_m)) < 5]
    assert near_top.max() - near_top.min() < 0.3  # spread by the plough, flattened
    spec = flat(diameter_m=40.0, height_m=6.0, erosion_m=0.0, trench_width_m=4.0,
                trench_depth_m=3.0, trench_azimuth_deg=0.0)  # runs north-south
    hf = terrain.build(spec)
    whole = terrain.build(replace(spec, trench_depth_m=0.0))
    cut = whole.z_m - hf.z_m
    assert float(whole.height_at(0.0, 0.0) - hf.height_at(0.0, 0.0)) == pytest.approx(3.0, 0.01)
    assert float(whole.height_at(0.0, 15.0) - hf.height_at(0.0, 15.0)) > 0.5  # along it
    assert float(whole.height_at(5.0, 0.0) - hf.height_at(5.0, 0.0)) == 0.0  # beside it
    assert cut.min() >= 0 and (hf.z_m >= -1e-9).all()  # never below the ground


def test_slope_rises_towards_its_azimuth() -> None:
    hf = terrain.build(flat(mound=False, slope_deg=10.0, slope_azimuth_deg=90.0))
    east, west = float(hf.height_at(50.0, 0.0)), float(hf.height_at(-50.0, 0.0))
    assert east - west == pytest.approx(100 * np.tan(np.radians(10)), rel=1e-6)
    assert float(hf.height_at(0.0, 50.0)) == pytest.approx(0.0, abs=1e-9)



def test_a_tumulus_s_relief_is_measured_over_the_ground_around_it() -> None:
    """terrain.mound_relief on the true surface: on flat ground a cone's prominence is the
    95th percentile of its heights within R / 2 (H (1 - sqrt(0.05) / 2)) and the ground's
    clutter nil; on a 10 degree slope the same (the ring's plane follows the slope); ground
    that undulates at the tumulus's own scale raises the clutter until the tumulus no longer
    stands clear of it; a ring off the surface gives no relief."""
    from mound.training.verdict_model import stands_clear

    cone = dict(profile="conical", diameter_m=40.0, height_m=6.0, erosion_m=0.0,
                mound_x_m=10.0, mound_y_m=-5.0)
    want = 6.0 * (1 - np.sqrt(0.05) / 2)
    for spec in (flat(**cone), flat(**cone, slope_deg=10.0, slope_azimuth_deg=30.0)):
        rel = terrain.mound_relief(terrain.build(spec), (10.0, -5.0), 40.0)
        assert rel is not None
        assert rel["prominence_m"] == pytest.approx(want, rel=0.03)
        assert rel["ground_clutter_m"] < 0.01
        assert stands_clear(rel)
    hf = terrain.build(flat(**cone))
    xx, yy = np.meshgrid(hf.x_m, hf.y_m)
    clutter = []
    for amp in (0.5, 2.0, 4.0):  # a swell of the tumulus's own width across the ground
        waves = terrain.Heightfield(hf.x_m, hf.y_m,
                                    hf.z_m + amp * np.sin(2 * np.pi * (xx + 0.5 * yy) / 45.0))
        rel = terrain.mound_relief(waves, (10.0, -5.0), 40.0)
        assert rel is not None
        clutter.append(rel["ground_clutter_m"])
        assert stands_clear(rel) == (rel["prominence_m"]
                                                 >= 5 * rel["ground_clutter_m"])
    assert clutter[0] < clutter[1] < clutter[2] and clutter[2] > 0.25 * 6.0
    assert not stands_clear(rel)  # the 4 m swell masks the 6 m cone
    assert stands_clear(None) is None
    assert terrain.mound_relief(hf, (0.0, 0.0), 400.0) is None  # its ring off the surface
    assert terrain.mound_relief(hf, (0.0, 0.0), 0.0) is None


@pytest.mark.parametrize("kind", terrain.CONFUSERS)
def test_confusers_stand_where_and_how_they_are_said(kind: str) -> None:
    c = terrain.Confuser(kind, x_m=10.0, y_m=5.0, length_m=30.0, width_m=8.0, height_m=4.0,
                         azimuth_deg=0.0, count=6, seed=3)
    spec = flat(mound=False, confusers=(c,))
    hf = terrain.build(spec)
    t = spec.truth()
    assert not t["mound"] and t["kind"] == kind and t["centre_enu_m"] == [10.0, 5.0]
    z = hf.z_m
    if kind == "ditch":
        assert z.min() == pytest.approx(-4.0, abs=0.01) and z.max() < 1e-9
        assert float(hf.height_at(10.0, -70.0)) == pytest.approx(-4.0, abs=0.01)  # whole site
    elif kind == "terrace":  # a step of 4 m across the line x = 10
        assert float(hf.height_at(30.0, 0.0) - hf.height_at(-10.0, 0.0)) == pytest.approx(4, 0.01)
    elif kind == "ridge":
        assert float(hf.height_at(10.0, -70.0)) == pytest.approx(4.0, abs=0.01)
    elif kind == "hillock":  # elongated north-south: 30 m long, 8 m wide
        assert float(hf.height_at(10.0, 5.0)) == pytest.approx(4.0, abs=0.01)
        assert float(hf.height_at(10.0, 13.0)) > 2 * float(hf.height_at(18.0, 5.0))
    elif kind == "building":  # vertical walls: full height 0.5 m inside, ground 0.5 m out
        assert float(hf.height_at(10.0, 5.0)) == pytest.approx(4.0)
        assert float(hf.height_at(13.5, 5.0)) == pytest.approx(4.0)
        assert float(hf.height_at(14.5, 5.0)) == pytest.approx(0.0)
    else:  # haystack, trees: steep crowns, nothing outside them
        assert 2.8 <= z.max() <= 4.0 + 1e-9
        assert z.min() >= -1e-9
        assert (z > 0.1).mean() < 0.05


def test_a_dem_patch_is_the_real_ground(shared_data: Path) -> None:
    """The patch holds the DEM's heights (less its median) at the DEM's own cell centres,
    read independently with rasterio: north is up, east is right."""
    import rasterio

    path = str(shared_data / DEM)
    spec = flat(mound=False, dem_path=path, dem_x_m=564500.0, dem_y_m=146500.0,
                resolution_m=1.0)
    hf = terrain.build(spec)
    shifts = []
    with rasterio.open(path) as ds:
        dem = ds.read(1).astype(float)
        for dx, dy in ((30.0, 20.0), (-40.0, -50.0), (55.0, -61.0)):
            row, col = ds.index(564500.0 + dx, 146500.0 + dy)
            x, y = ds.xy(row, col)  # that cell's centre
            patch = float(hf.height_at(np.array([x - 564500.0]), np.array([y - 146500.0]))[0])
            shifts.append(patch - dem[row, col])
    assert abs(float(np.median(hf.z_m))) < 1e-6
    # the same shift everywhere (the patch's median): north up, east right, no flip
    assert max(shifts) - min(shifts) < 1e-3, shifts
    assert hf.z_m.max() - hf.z_m.min() > 5  # real relief
    with pytest.raises(InputError, match="lies off the DEM"):
        terrain.build(replace(spec, dem_x_m=564050.0))


def test_a_second_look_near_the_dem_edge_continues_the_ground_across_it(
        shared_data: Path) -> None:
    """The second look's wider site near the DEM's edge (looks.wider: dem_extend): inside the
    DEM it holds the DEM's heights, beyond the edge their point reflection about it (heights
    and slopes run on, no fold at the edge); the first look's spec still refuses the site,
    and a site whose centre is off the DEM is refused either way."""
    from mound.geometry.dem import Dem

    path = str(shared_data / DEM)
    axis = np.linspace(-150.0, 150.0, 301)  # 1 m cells; x0 - 150 lies 86.5 m off the DEM
    x0, y0 = 564064.0, 146500.0
    with pytest.raises(InputError, match="lies off the DEM"):
        terrain.dem_patch(path, x0, y0, axis, ground_m=0.0)
    z = terrain.dem_patch(path, x0, y0, axis, ground_m=0.0, extend=True)
    assert z.shape == (301, 301) and np.isfinite(z).all()
    inside = axis >= -64.0  # the DEM's cell centres reach 563,999.5 + 0.5 = 564,000 (x0 - 64)
    xx, yy = np.meshgrid(x0 + axis[inside], y0 + axis)
    read = Dem.at(path, x0, y0, "egm96", margin_m=300).height_crs(xx, yy).reshape(xx.shape)
    assert np.allclose(z[:, inside], read, atol=1e-9)  # the DEM itself where it holds
    e = int(np.flatnonzero(inside)[0])  # the edge column
    for d in (1, 10, 60):  # point reflection: z(e - d) + z(e + d) = 2 z(e) on every row
        assert np.allclose(z[:, e - d] + z[:, e + d], 2 * z[:, e], atol=1e-9)
    # no fold: the slope across the edge runs on (a mirror would turn it over)
    step_in, step_out = z[:, e + 1] - z[:, e], z[:, e] - z[:, e - 1]
    assert np.allclose(step_in, step_out, atol=1e-9)
    assert np.abs(step_in).max() > 0.05  # there is a slope to run on
    first = flat(mound=False, dem_path=path, dem_x_m=x0, dem_y_m=y0, resolution_m=2.0,
                 size_m=300.0)
    spec = looks.wider(replace(draws.draw(np.random.default_rng(0), 0, None, (320, 240)),
                              terrain=first))
    assert spec.terrain.dem_extend and not first.dem_extend
    assert np.isfinite(terrain.build(spec.terrain).z_m).all()
    with pytest.raises(InputError, match="lies off the DEM"):
        terrain.build(first)
    with pytest.raises(InputError, match="centre lies off the DEM"):
        terrain.dem_patch(path, 563990.0, y0, axis, ground_m=0.0, extend=True)
    flat_spec = draws.draw(np.random.default_rng(0), 0, None, (320, 240))
    assert not flat_spec.terrain.dem_path and not looks.wider(flat_spec).terrain.dem_extend


def test_grid_draws_are_seeded_and_span_the_field(shared_data: Path) -> None:
    dem = [DemPlaces.open(str(shared_data / DEM))]  # opened once: each open reads the DEM
    rng = np.random.default_rng([1, 2026])
    a = [draws.draw(rng, k, dem, (320, 240)) for k in range(300)]
    rng = np.random.default_rng([1, 2026])
    assert [draws.draw(rng, k, dem, (320, 240)) for k in range(3)] == a[:3]
    mounds = [s.terrain for s in a if s.terrain.mound]
    assert 0.4 < len(mounds) / len(a) < 0.6
    assert {m.profile for m in mounds} == set(terrain.PROFILES)
    assert min(m.height_m for m in mounds) < 1 and max(m.height_m for m in mounds) > 15
    assert any(m.diameter_m > 60 for m in mounds)  # wider than the 60 m scan
    assert max(np.hypot(m.mound_x_m, m.mound_y_m) for m in mounds) > 10
    quarter = DEFAULT_SITE_DIAMETER_M / 4
    assert all(np.hypot(m.mound_x_m, m.mound_y_m) <= quarter + 1e-9 for m in mounds)
    # no tumulus steeper than earth stands (many draws sit on the limit)
    share = [m.drum_height_m / m.height_m if m.profile == "drum" else 0.0 for m in mounds]
    assert all(m.height_m <= draws.max_height(m.profile, m.diameter_m, q) * (1 + 1e-9)
               for m, q in zip(mounds, share, strict=True))
    assert sum(m.height_m >= draws.max_height(m.profile, m.diameter_m, q) * (1 - 1e-9)
               for m, q in zip(mounds, share, strict=True)) > 10
    kinds = {s.terrain.confusers[0].kind for s in a if s.terrain.confusers}
    assert kinds == set(terrain.CONFUSERS)
    assert any(s.terrain.dem_path for s in a) and any(s.terrain.slope_deg > 0 for s in a)
    assert all(s.scan_diameter_m == DEFAULT_SITE_DIAMETER_M and s.pattern == "raster" for s in a)
    # the full flight draws the same sites, flown with the raster and the orbit
    rng = np.random.default_rng([1, 2026])
    full = [draws.draw(rng, k, dem, (320, 240), pattern="both") for k in range(3)]
    assert [replace(s, pattern="raster") for s in full] == a[:3]
    assert all(s.pattern == "both" for s in full)


def test_steep_ground_is_a_family_no_mixed_grid_draws(shared_data: Path) -> None:
    """Issue 68's held-out terrain: every site of a steep grid on a 15-35 degree slope,
    half of them over a DEM patch, half with a tumulus; the mixed grids' slopes stay at
    2-15 degrees."""
    dem = [DemPlaces.open(str(shared_data / DEM))]
    rng_m, rng_s = np.random.default_rng([3, 2026]), np.random.default_rng([3, 2026])
    mixed = [draws.draw(rng_m, k, dem, (320, 240)) for k in range(200)]
    steep = [draws.draw(rng_s, k, dem, (320, 240), ground="steep") for k in range(200)]
    assert all(s.terrain.slope_deg == 0 or 2 <= s.terrain.slope_deg <= 15 for s in mixed)
    assert all(draws.STEEP_DEG[0] <= s.terrain.slope_deg <= draws.STEEP_DEG[1] for s in steep)
    assert max(s.terrain.slope_deg for s in steep) > 32
    on_dem = sum(s.terrain.dem_path is not None for s in steep)
    assert 70 < on_dem < 130
    assert 0.4 < sum(s.terrain.mound for s in steep) / len(steep) < 0.6
    with pytest.raises(InputError, match="--ground"):
        draws.draw(np.random.default_rng(1), 0, dem, (320, 240), ground="alpine")


def test_ridged_ground_is_ridges_and_terraces_no_other_grid_draws() -> None:
    """Issue 68's second held-out terrain family: ridge and valley on every site (crests
    60-160 m apart, flanks of at most 32 degrees before the regional slope), terraced on
    half; the built ground has the drawn relief, and a terrace's tread is flat."""
    rng = np.random.default_rng([5, 2026])
    ridged = [draws.draw(rng, k, None, (320, 240), ground="ridged") for k in range(200)]
    t = [s.terrain for s in ridged]
    assert all(60 <= g.ridge_wavelength_m <= 160 for g in t)
    assert all(3 <= g.ridge_relief_m <= g.ridge_wavelength_m / 5 for g in t)
    assert 70 < sum(g.terrace_step_m > 0 for g in t) < 130
    assert all(g.dem_path is None and 0 <= g.slope_deg <= 10 for g in t)
    assert 0.4 < sum(g.mound for g in t) / len(t) < 0.6
    # no mixed or steep draw has ridges or terraces
    rng = np.random.default_rng([5, 2026])
    for ground in ("mixed", "steep"):
        assert all(draws.draw(rng, k, None, (320, 240), ground=ground).terrain.ridge_relief_m
                   == 0 for k in range(50))
    # the ground as built: bare ridges span their relief plus the regional slope's rise
    bare = replace(t[0], mound=False, confusers=(), terrace_step_m=0.0, resolution_m=0.5,
                   slope_deg=0.0, ground_relief_m=0.0)
    hf = terrain.build(bare)
    assert hf.z_m.max() - hf.z_m.min() == pytest.approx(bare.ridge_relief_m, rel=0.05)
    assert bare.truth()["ridge_relief_m"] == bare.ridge_relief_m
    # terraces: 2 m steps on a 10 degree slope; most of the ground is flat tread
    steps = terrain.build(replace(bare, ridge_relief_m=0.0, slope_deg=10.0,
                                  terrace_step_m=2.0, terrace_riser=0.25))
    gy, gx = np.gradient(steps.z_m, 0.5)
    flat = np.hypot(gx, gy) < 1e-9
    assert 0.6 < flat.mean() < 0.8
    assert np.unique(np.round(steps.z_m[flat] / 2.0, 6)).size == np.unique(
        np.round(steps.z_m[flat] / 2.0)).size  # every tread at a whole number of steps


@pytest.mark.parametrize("profile", terrain.PROFILES)
def test_the_highest_tumulus_drawn_has_flanks_at_the_angle_of_repose(profile: str) -> None:
    """max_height's closed forms against the simulator's own radial profile: at that height
    the steepest flank (a drum's vertical wall aside) is the angle of repose."""
    d, share = 40.0, 0.3
    h = draws.max_height(profile, d, share)
    spec = terrain.preset("bin_tepe", profile=profile, diameter_m=d, height_m=h,
                          drum_height_m=share * h, erosion_m=0.0)
    r = np.linspace(0.0, d / 2 - 1e-6, 200_001)
    z = terrain._radial_profile(spec, r)
    slope = np.degrees(np.arctan(np.abs(np.diff(z) / np.diff(r))))
    assert abs(float(slope.max()) - draws.REPOSE_DEG) < 0.3, (profile, float(slope.max()))


def test_a_grid_without_its_dem_is_refused_not_drawn_otherwise(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
        mound_recon: Path, mound_render: Path) -> None:
    """A quarter of a grid's draws are patches of the laser DEM: where the default DEM is
    in neither data folder, `mound sim grid` exits 2 naming --dem (before, the same seed
    quietly drew another grid without terrain patches) and makes no grid; `--dem none`
    draws that other grid on purpose, and grid.json says it has no DEM."""
    import json

    from mound.cli import main

    monkeypatch.setenv("MOUND_DATA", str(tmp_path / "cache"))
    monkeypatch.setenv("MOUND_SHARED_DATA", str(tmp_path / "shared"))
    out = tmp_path / "g"
    assert main(["sim", "grid", "--out", str(out), "--sites", "1", "--seed", "7"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--dem" in err and "--dem none" in err, err
    assert not out.exists()
    assert main(["sim", "grid", "--out", str(out), "--sites", "1", "--seed", "7", "--dem",
                 "none", "--workers", "1", "--threads", "2"]) == 0
    assert json.loads((out / "grid.json").read_text())["dem"] is None


def test_a_grid_in_which_no_site_was_measured_is_no_result(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
        mound_recon: Path) -> None:
    """Until issue 57 a grid whose every site failed (a seed mound_render refused) printed
    "0 of 2 sites measured" and exited 0: now grid.json says `status: failed` and the
    command exits 3 with one line naming why."""
    import json

    from mound.cli import main

    def failing(out: Path, spec: Any, *args: Any) -> GridLook:
        return GridLook("failed",
                        reason="mound_render failed (exit 2: bad input): --seed: too large")

    monkeypatch.setattr(grid_run, "_site", failing)
    out = tmp_path / "g"
    assert main(["sim", "grid", "--out", str(out), "--sites", "2", "--seed", "7", "--dem",
                 "none", "--workers", "1"]) == 3
    err = capsys.readouterr().err
    why = err.splitlines()[0]  # (the command's time follows on its own line)
    assert "no site was measured" in why and "--seed" in why, err
    doc = json.loads((out / "grid.json").read_text())
    assert doc["status"] == "failed" and doc["measured"] == 0


@pytest.mark.slow
def test_a_grid_of_the_full_flight_from_the_card_judged_on_its_dense_cloud(
        tmp_path: Path, mound_recon: Path, mound_render: Path) -> None:
    """`mound sim grid --pattern both --dense --card`: each site flown with the raster and
    the orbit, its images JPEGs with EXIF reconstructed as from the aircraft's card (EXIF
    GPS and focal length), densified, and judged on the dense cloud; the grid says so, and
    --remeasure judges the same dense cloud again without flying or densifying anew."""
    import json

    from mound.cli import main

    out = tmp_path / "g"
    assert main(["sim", "grid", "--out", str(out), "--sites", "1", "--seed", "7",
                 "--pattern", "both", "--dense", "--workers", "1", "--threads", "2",
                 "--dem", str(tmp_path / "none.tif")]) == 2  # a DEM that is not there
    assert main(["sim", "grid", "--out", str(out), "--sites", "1", "--seed", "7",
                 "--pattern", "both", "--dense", "--card", "--workers", "1", "--threads",
                 "2"]) == 0
    doc = json.loads((out / "grid.json").read_text())
    assert doc["flight"]["pattern"] == "both" and doc["cloud"] == "dense"
    assert doc["camera"] == "exif"
    recon = json.loads((out / "0000" / "recon" / "recon.json").read_text())
    assert recon["inputs"]["gps_source"] == "exif"
    assert recon["inputs"]["camera_source"].startswith("exif")
    patterns = {im["pattern"] for im in json.loads(
        (out / "0000" / "sim" / "poses.json").read_text())["images"]}
    assert patterns == {"raster", "orbit"}, patterns
    v = json.loads((out / "0000" / "verdict.json").read_text())
    assert v["status"] == "ok" and v["cloud"].endswith("dense/dense.ply")
    dense_points = v["measurements"]["cells_with_points"]
    # densified as the built-in dense model's training clouds were (densify's defaults)
    from mound.paths import REPO_ROOT
    from mound.recon.model_file import read_verdict_model

    opts = json.loads((out / "0000" / "dense" / "dense.json").read_text())["options"]
    c = read_verdict_model(REPO_ROOT / "data" / "verdict_model_dense.json").cloud_settings
    assert c is not None
    assert (opts["max_image_size"], opts["resolution_m"]) == (c["max_image_size"],
                                                              c["resolution_m"])
    stamp = (out / "0000" / "dense" / "dense.ply").stat().st_mtime_ns
    assert main(["sim", "grid", "--out", str(out), "--sites", "1", "--seed", "7",
                 "--pattern", "both", "--dense", "--card", "--remeasure", "--workers",
                 "1"]) == 0
    again = json.loads((out / "0000" / "verdict.json").read_text())
    assert again["cloud"] == v["cloud"]
    assert again["measurements"]["cells_with_points"] == dense_points
    assert (out / "0000" / "dense" / "dense.ply").stat().st_mtime_ns == stamp
    assert "densify" in again["grid_times_s"] and "reconstruct" in again["grid_times_s"]
    # issue 68: the grid's ground as a model's terrain domain (one site: each range a
    # point), read by both readers; the site lies inside it, and outside once the slope's
    # range is moved off it
    from mound.recon.model_file import TERRAIN_DESCRIPTORS

    ground = again["measurements"]["terrain"]
    assert sorted(ground) == sorted(TERRAIN_DESCRIPTORS)  # the C++ detector's names
    model = tmp_path / "domain.json"
    assert main(["recon", "terrain-domain", str(out), "--model",
                 str(REPO_ROOT / "data" / "verdict_model_dense.json"), "--out",
                 str(model)]) == 0
    m = read_verdict_model(model)
    assert {n: (lo, hi) for n, lo, hi in m.terrain_ranges} == {
        n: (ground[n], ground[n]) for n in TERRAIN_DESCRIPTORS}
    site = out / "0000"

    def judged(model_path: Path) -> dict[str, Any]:
        r = subprocess.run([str(mound_recon), "verdict", str(site / "recon"), "--cloud",
                            str(site / "dense" / "dense.ply"), "--model", str(model_path),
                            "--out", str(tmp_path / "v.json")], capture_output=True, text=True,
                           timeout=600, check=False)
        assert r.returncode == 0, r.stderr
        return dict(json.loads((tmp_path / "v.json").read_text()))

    assert judged(model)["terrain"] == {"status": "inside", "outside": []}
    doc = json.loads(model.read_text())
    slope = ground["site_slope_rad"]
    doc["terrain_domain"]["ranges"]["site_slope_rad"] = [slope + 0.1, slope + 0.2]
    model.write_text(json.dumps(doc))
    v = judged(model)
    assert v["label"] == "undecided" and v["terrain"]["status"] == "outside"
    assert v["undecided"]["reasons"][0]["code"] == "terrain"
    assert v["p_mound"] == again["p_mound"]  # the model's p, reported, not acted on
    # a grid whose verdicts predate the terrain measurements gives no domain (exit 2)
    del again["measurements"]["terrain"]
    (site / "verdict.json").write_text(json.dumps(again))
    assert main(["recon", "terrain-domain", str(out), "--model", str(model), "--out",
                 str(tmp_path / "none.json")]) == 2
    assert not (tmp_path / "none.json").exists()


@pytest.mark.slow
def test_a_dense_grid_from_a_sparse_grids_flights(
        tmp_path: Path, mound_recon: Path, mound_render: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    """`mound sim grid --dense --flights-from GRID`: the sites of a sparse grid densified and
    judged on their dense clouds without flying or reconstructing them again; a grid of
    other draws is refused naming the field."""
    import json

    from mound.cli import main

    sparse, dense = tmp_path / "s", tmp_path / "d"
    common = ["--sites", "1", "--workers", "1", "--threads", "2"]
    assert main(["sim", "grid", "--out", str(sparse), "--seed", "5", *common]) == 0
    capsys.readouterr()
    assert main(["sim", "grid", "--out", str(dense), "--seed", "6", *common, "--dense",
                 "--flights-from", str(sparse)]) == 2  # other draws
    err = capsys.readouterr().err
    assert "--flights-from" in err and "seed is 5" in err and err.count("\n") == 1, err
    assert not dense.exists()
    assert main(["sim", "grid", "--out", str(dense), "--seed", "5", *common, "--dense",
                 "--flights-from", str(sparse)]) == 0
    assert (dense / "0000" / "recon").is_symlink()
    assert (dense / "0000" / "recon").resolve() == (sparse / "0000" / "recon").resolve()
    v = json.loads((dense / "0000" / "verdict.json").read_text())
    assert v["status"] == "ok" and v["cloud"].endswith("dense/dense.ply")
    assert v["model"]["trained"]["cloud"] == "dense"
    assert set(v["grid_times_s"]) == {"densify", "verdict"}  # nothing flown again
    doc = json.loads((dense / "grid.json").read_text())
    assert doc["cloud"] == "dense"
    # judged by a copy of this build's mound_recon, taken when the grid started (a rebuild
    # meanwhile changes nothing in it), and the grid names that build
    from mound.datasets import sha256_of

    assert doc["tools"] == {"mound_recon": {"sha256": sha256_of(mound_recon)}}
    ran = [ln for ln in (dense / "0000" / "log.txt").read_text().splitlines()
           if ln.startswith("[native] pid") and " verdict " in ln]
    assert ran and str(mound_recon) not in ran[0] and "/mound-tools-" in ran[0], ran
    # resumed by another build without --remeasure: the earlier verdicts stay, and it says so
    doc["tools"]["mound_recon"]["sha256"] = "0" * 64
    (dense / "grid.json").write_text(json.dumps(doc))
    capsys.readouterr()
    assert main(["sim", "grid", "--out", str(dense), "--seed", "5", *common, "--dense",
                 "--flights-from", str(sparse)]) == 0
    again = json.loads((dense / "grid.json").read_text())
    assert again["earlier_tools"] == {"mound_recon": {"sha256": "0" * 64}}
    assert "another build of mound_recon" in capsys.readouterr().err
    assert main(["sim", "grid", "--out", str(dense), "--seed", "5", *common, "--dense",
                 "--flights-from", str(sparse)]) == 0  # resumed again: still mixed
    assert json.loads((dense / "grid.json").read_text())["earlier_tools"] == again[
        "earlier_tools"]
    assert main(["sim", "grid", "--out", str(dense), "--seed", "5", *common, "--dense",
                 "--flights-from", str(sparse), "--remeasure"]) == 0
    assert "earlier_tools" not in json.loads((dense / "grid.json").read_text())
    # resumed with another candidate set: every verdict measured again with it (issue 68),
    # the grid and its sites say which
    from mound.training import verdict_model as vm

    assert vm.load_grid(dense)[0].candidates == "site_ground"
    assert main(["sim", "grid", "--out", str(dense), "--seed", "5", *common, "--dense",
                 "--flights-from", str(sparse), "--candidates", "local_relief"]) == 0
    v = json.loads((dense / "0000" / "verdict.json").read_text())
    assert v["measurements"]["candidates"] == "local_relief"
    assert v["model"]["candidates"] == "site_ground"  # the built-in model: not its set
    assert v["label"] == "undecided" and v["undecided"]["reasons"][0]["code"] == "model"
    assert json.loads((dense / "grid.json").read_text())["candidates"] == "local_relief"
    assert vm.load_grid(dense)[0].candidates == "local_relief"


@pytest.mark.slow
def test_a_grid_flies_a_second_look_at_the_sites_its_first_leaves_undecided(
        tmp_path: Path, mound_recon: Path, mound_render: Path) -> None:
    """`mound sim grid --second-look`: a site whose first p_mound lies in SECOND_LOOK_P is
    flown again in NNNN/second/ with the same terrain, light and lens and a scan twice as
    wide; the others are not; load_grid carries the second look's rises."""
    import json

    from mound.cli import main
    from mound.training import verdict_model as vm

    out = tmp_path / "g"
    assert main(["sim", "grid", "--out", str(out), "--sites", "2", "--seed", "7", "--dem",
                 "none", "--workers", "1", "--threads", "2", "--second-look"]) == 0
    doc = json.loads((out / "grid.json").read_text())
    assert doc["second_look"]["scan_factor"] == looks.SECOND_LOOK_FACTOR
    rows = {r.dir: r for r in vm.load_grid(out)}
    flown = 0
    for k in range(2):
        site = out / f"{k:04d}"
        p = json.loads((site / "verdict.json").read_text())["p_mound"]
        undecided = looks.SECOND_LOOK_P[0] <= p < looks.SECOND_LOOK_P[1]
        assert (site / "second" / "verdict.json").is_file() == undecided, (k, p)
        assert ("second" in doc["rows"][k]) == undecided
        assert doc["rows"][k]["p_mound"] == p  # the first look's, read once
        if not undecided:
            assert rows[site.name].second is None
            continue
        flown += 1
        first = json.loads((site / "sim" / "site.json").read_text())
        second = json.loads((site / "second" / "sim" / "site.json").read_text())
        assert second["sim"]["scan_diameter_m"] == 2 * first["sim"]["scan_diameter_m"]
        assert second["terrain"]["size_m"] >= looks.SITE_PER_SCAN * 2 * DEFAULT_SITE_DIAMETER_M
        for key in ("seed", "mound", "ground_relief_m"):
            assert second["terrain"][key] == first["terrain"][key]
        assert second["lighting"] == first["lighting"]
        v2 = json.loads((site / "second" / "verdict.json").read_text())
        assert v2["status"] == "ok"
        assert v2["measurements"]["site_radius_m"] > 1.5 * json.loads(
            (site / "verdict.json").read_text())["measurements"]["site_radius_m"]
        assert rows[site.name].second == vm.rises_of(v2["measurements"]["judged_rises"], "v2")
        assert len(rows[site.name].second or ()) == len(v2["measurements"]["judged_rises"])
    assert flown >= 1
