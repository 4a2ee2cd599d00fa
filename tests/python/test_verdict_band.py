"""Issue 56: the undecided band (chosen on out-of-fold p, nested figures, three answers on
held-out sites), the Kazanlak population the grid draws tumuli from, and terrain patches
placed inside any DEM's valid cells, train and held-out parts apart."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from mound.errors import InputError
from mound.grids import run as grid_run
from mound.recon import verdict_band as vb
from mound.recon.grid_site import sites_of
from mound.recon.model_file import VerdictModel, label_of
from mound.sim import draws, looks, terrain
from mound.sim.dem_places import DemPlaces
from mound.sim.population import parse_population, read_population


def _sites(n: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """p of n sites (10 splits), half tumuli (goal ones among them), calibrated-ish."""
    rng = np.random.default_rng(seed)
    y = rng.random(n) < 0.5
    goal = y & (rng.random(n) < 0.7)
    z = np.where(y, 2.5, -2.5) + np.where(goal, 1.0, 0.0) + rng.normal(0, 1.5, (10, n))
    return 1 / (1 + np.exp(-z)), y, goal


def test_the_band_meets_its_budgets_on_the_sites_it_was_chosen_on() -> None:
    p, y, goal = _sites(2000, 1)
    lo, hi = vb.choose_band(p, y, goal, 0.8, miss=0.01, fa=0.005)
    assert 0 < lo < hi < 1
    assert np.mean(p[:, goal] < lo) <= 0.01 and np.mean(p[:, ~y] >= hi) <= 0.005
    # the tightest such band: one step wider fails a budget
    assert np.mean(p[:, goal] < np.nextafter(lo, 1) + 1e-9) > 0.01 - 1e-3
    lab = vb.answers(p, (lo, hi))
    assert set(np.unique(lab)) == {vb.NO, vb.UNDECIDED, vb.MOUND}
    doc = vb.band_doc(p, y, goal, 0.8)
    o = doc["trained"]["out_of_fold"]
    assert doc["p_low"] <= doc["p_high"] and o["sites"] == 2000 and o["folds"] == 5
    # nested: near the chosen share of the budgets, not far beyond it
    assert o["confident_misses"] <= 2.5 * vb.BAND_SHARE * vb.MAX_MISS * goal.sum()
    assert o["confident_false_alarms"] <= 2.5 * vb.BAND_SHARE * vb.MAX_FA * (~y).sum()


def test_a_band_that_would_cross_shrinks_to_a_point_and_leaves_nothing_undecided() -> None:
    y = np.array([True] * 50 + [False] * 50)
    p = np.where(y, 0.95, 0.05)[None, :]
    lo, hi = vb.choose_band(p, y, y, 0.8)
    assert lo == hi == pytest.approx(0.8)
    assert not (vb.answers(p, (lo, hi)) == vb.UNDECIDED).any()


def test_three_answers_on_held_out_sites() -> None:
    truths = [{"mound": True, "height_m": 3.0, "diameter_m": 20.0, "dir": "a"},
              {"mound": True, "height_m": 1.5, "diameter_m": 12.0, "dir": "b"},
              {"mound": True, "height_m": 0.3, "diameter_m": 8.0, "trench": True,
               "dir": "c"},
              {"mound": False, "height_m": 0.0, "diameter_m": 0.0, "dir": "d"},
              {"mound": False, "height_m": 0.0, "diameter_m": 0.0, "dir": "e"}]
    p = np.array([0.99, 0.05, 0.5, 0.5, 0.96])
    t = vb.three_answers(p, sites_of([{"dir": d.pop("dir"), "truth": d} for d in truths]),
                         (0.1, 0.95), 0.8)
    assert t["confident_misses"]["count"] == 1 and t["confident_misses"]["of"] == 2
    assert t["confident_misses"]["sites"] == ["b"]
    assert t["confident_false_alarms"]["count"] == 1 and t["confident_false_alarms"]["of"] == 2
    u = t["undecided"]
    assert u["count"] == 2 and u["tumuli"] == 1 and u["mean_p"] == pytest.approx(0.5)
    lo, hi = u["rate_95ci"]
    assert lo < 0.4 < hi
    f = t["field_recall"]
    assert f["all"]["all"]["tumuli"] == 3 and f["all"]["all"]["confirmed"]["count"] == 1
    assert f["with_trench"]["by_height"]["0-0.5 m"]["undecided"]["count"] == 1
    assert f["all"]["by_height"]["2-5 m"]["two_answer_mound"]["count"] == 1
    # issue 68: sites on ground outside the model's terrain domain are undecided whatever
    # their p: here the confident miss (b) and the confident false alarm (e)
    sites = sites_of([{"dir": d, "truth": t} for d, t in zip("abcde", truths, strict=True)])
    outside = np.array([False, True, False, False, True])
    t = vb.three_answers(p, sites, (0.1, 0.95), 0.8, outside)
    assert t["confident_misses"]["count"] == 0 and t["confident_false_alarms"]["count"] == 0
    assert t["undecided"]["count"] == 4
    assert t["terrain"] == {"outside": 2, "tumuli_outside": 1, "sites_outside": ["b", "e"],
                            "would_be": {"mound": 1, "no_mound": 1, "undecided": 0}}
    assert t["frontier_inside_domain"]["undecided_at_goals"] >= 2 / 5
    # per kind of ground (the truth's slope, DEM, ridges): a 20 degree DEM patch holds the
    # confident miss, terraced ridges the undecided bare site; a truth without its ground
    # is "unknown"
    grounds = [{"slope_deg": 0.0, "dem": False}, {"slope_deg": 20.0, "dem": True},
               {"slope_deg": 3.0, "dem": False, "ridge_relief_m": 9.0,
                "terrace_step_m": 2.0}, {"slope_deg": 3.0, "dem": False, "ridge_relief_m": 9.0,
                                         "terrace_step_m": 2.0}, {}]
    sites = sites_of([{"dir": d, "truth": {**t, **g}}
                      for d, t, g in zip("abcde", truths, grounds, strict=True)])
    k = vb.three_answers(p, sites, (0.1, 0.95), 0.8)["by_terrain"]
    assert list(k) == ["dem, 15-35 deg", "ridges, terraced", "undulating, flat", "unknown"]
    assert k["dem, 15-35 deg"]["confident_misses"]["count"] == 1
    assert k["ridges, terraced"]["undecided"] == {**k["ridges, terraced"]["undecided"],
                                                  "count": 2, "of": 2}
    assert k["undulating, flat"]["confirmed_2m"]["count"] == 1
    assert k["unknown"]["confident_false_alarms"]["count"] == 1


def test_a_model_without_a_band_gives_two_answers_and_one_with_it_three() -> None:
    model = json.loads((Path(__file__).parents[2] / "data" / "verdict_model_dense.json")
                       .read_text())
    assert "undecided" not in model  # the shipped model of today
    t = model["threshold"]
    two = VerdictModel.of(model)
    assert label_of(two, t) == "mound" and label_of(two, t - 1e-9) == "no_mound"
    three = VerdictModel.of({**model, "undecided": {"p_low": 0.2, "p_high": 0.9}})
    assert [label_of(three, q) for q in (0.1, 0.2, 0.89, 0.9)] == [
        "no_mound", "undecided", "undecided", "mound"]
    assert label_of(three, 0.5, two_answer_at=0.5) == "mound"  # the paper's protocol


def test_bands_by_slope_where_steep_grounds_p_is_less_sure() -> None:
    """Issue 68: gentle sites' p well apart by class, steep sites' (slope >= 20 degrees)
    p spread: one band is as wide as the steep sites need everywhere; two bands, split at
    a slope chosen by the nested undecided, leave fewer sites undecided, each meeting its
    side's budgets; the model reads them and labels a site by its slope."""
    rng = np.random.default_rng(7)
    n = 1600
    slope = np.radians(rng.uniform(0, 35, n))
    steep = slope >= np.radians(20)
    y = rng.random(n) < 0.5
    goal = y & (rng.random(n) < 0.8)
    z = np.where(y, 3.5, -3.5) + rng.normal(0, np.where(steep, 3.0, 1.0), (10, n))
    p = 1 / (1 + np.exp(-z))
    doc = vb.band_doc(p, y, goal, 0.8, slope)
    split = doc["trained"]["by_slope"]
    low, high = doc["by_slope"]
    assert 16 <= math.degrees(low["site_slope_rad"][1]) <= 24  # near the true 20
    assert low["site_slope_rad"][0] == -math.pi / 2 and high["site_slope_rad"][1] == math.pi / 2
    o = split["out_of_fold"]
    assert o["undecided"] < 0.8 * o["one_band"]["undecided"]
    assert high["p_high"] - high["p_low"] > low["p_high"] - low["p_low"]  # steep: wider
    # without a slope, or when one band does as well, no bands by slope
    assert "by_slope" not in vb.band_doc(p, y, goal, 0.8)
    flat = vb.band_doc(p[:, ~steep], y[~steep], goal[~steep], 0.8, slope[~steep])
    assert "by_slope" not in flat or flat["trained"]["by_slope"]["out_of_fold"][
        "undecided"] < flat["trained"]["out_of_fold"]["undecided"]
    model = json.loads((Path(__file__).parents[2] / "data" / "verdict_model_dense.json")
                       .read_text())
    m = VerdictModel.of({**model, "undecided": doc})
    q = (low["p_low"] + high["p_low"]) / 2  # in the steep band, below the gentle one
    assert label_of(m, q, slope_rad=0.1) == "no_mound"
    assert label_of(m, q, slope_rad=0.5) == "undecided"
    assert m.band_for(None) == m.undecided == (doc["p_low"], doc["p_high"])


# ------------------------------------------------------------------- the population

def test_the_kazanlak_inventory_reads_as_a_population(shared_data: Path) -> None:
    pop = read_population(str(shared_data / "kazanlak" / "mounds.geojson"))
    assert len(pop.rows) == 772 and pop.levelled == 1
    assert all(r.length_m >= r.width_m > 0 and r.height_m > 0 for r in pop.rows)
    assert 0.45 < pop.trench_share < 0.6
    assert np.median([r.height_m for r in pop.rows]) == pytest.approx(0.8, abs=0.05)


@pytest.mark.parametrize("props, field", [
    ({"width_m": 5, "height_m": 1}, "length_m"),
    ({"length_m": "5", "width_m": 5, "height_m": 1}, "length_m"),
    ({"length_m": 5, "width_m": -1, "height_m": 1}, "width_m"),
    ({"length_m": 5, "width_m": 5, "height_m": 1e9}, "height_m"),
    ({"length_m": 0, "width_m": 5, "height_m": 1}, "length_m"),
    ({"length_m": 5, "width_m": 5, "height_m": 1, "robber_trench": "yes"}, "robber_trench"),
])
def test_a_bad_population_row_is_refused_naming_it(props: dict[str, object],
                                                   field: str) -> None:
    doc = {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"length_m": 9, "width_m": 8, "height_m": 1}},
        {"type": "Feature", "properties": props}]}
    with pytest.raises(InputError, match=rf"pop.geojson: features\[1\].* {field}"):
        parse_population(doc, "pop.geojson")


def test_a_grid_of_the_population_draws_its_measured_tumuli(shared_data: Path) -> None:
    pop = read_population(str(shared_data / "kazanlak" / "mounds.geojson"))
    rows = {(r.length_m, r.width_m) for r in pop.rows}
    rng = np.random.default_rng([3, 2026])
    specs = [draws.draw(rng, k, None, (320, 240), population=pop) for k in range(300)]
    mounds = [s.terrain for s in specs if s.terrain.mound]
    assert 0.4 < len(mounds) / len(specs) < 0.6
    assert all((m.base_length_m, m.diameter_m) in rows for m in mounds)
    assert {m.profile for m in mounds} <= set(draws.POPULATION_PROFILES)
    assert all(m.height_m <= draws.max_height(m.profile, m.diameter_m) * (1 + 1e-9)
               for m in mounds)
    elongated = [m for m in mounds if m.length_m > 0]
    assert len(elongated) > 10 and len({round(m.mound_azimuth_deg) for m in elongated}) > 5
    assert sum(m.trench_width_m > 0 or m.pit_radius_m > 0 for m in mounds) > 0.3 * len(mounds)
    # the site holds the whole tumulus, its long axis included
    assert all(m.check() is None for m in mounds)


def test_an_elongated_tumulus_stretches_along_its_azimuth() -> None:
    spec = terrain.preset("bin_tepe", diameter_m=20.0, length_m=40.0, mound_azimuth_deg=90.0,
                          height_m=2.0, erosion_m=0.0, ground_relief_m=0.0)
    hf = terrain.build(spec)
    z = lambda x, y: float(hf.height_at(np.array([x]), np.array([y]))[0])  # noqa: E731
    assert z(0, 0) == pytest.approx(2.0, abs=0.05)
    assert z(15, 0) > 0.5 and z(0, 15) == pytest.approx(0.0, abs=1e-6)  # east-west long
    assert spec.truth()["diameter_m"] == pytest.approx(30.0)
    assert spec.truth()["length_m"] == 40.0 and spec.truth()["width_m"] == 20.0
    with pytest.raises(InputError, match="length_m"):
        terrain.preset("bin_tepe", diameter_m=20.0, length_m=10.0)


# ------------------------------------------------------------------- DEM places

@pytest.mark.parametrize("name", ["TM1_564_146.tif", "bolasco_1m.tif"])
def test_patches_lie_on_valid_cells_and_the_parts_share_none(shared_data: Path,
                                                             name: str) -> None:
    path = str(shared_data / "dem" / name)
    train, held = DemPlaces.open(path, "train"), DemPlaces.open(path, "heldout")
    assert not (train.valid & held.valid).any()
    whole = DemPlaces.open(path)
    assert (train.valid | held.valid).sum() == whole.valid.sum()
    rng = np.random.default_rng(0)
    for part in (train, held):
        for _ in range(20):
            x, y = part.draw(rng, 164.0)
            inv = ~part.transform  # type: ignore[operator]
            c, r = inv @ (x, y)
            h = part.half_px(164.0)
            win = part.valid[int(r) - h:int(r) + h + 1, int(c) - h:int(c) + h + 1]
            assert win.shape == (2 * h + 1, 2 * h + 1) and win.all()
            # and the terrain built there reads no nodata
            spec = terrain.preset("bin_tepe", mound=False, dem_path=path, dem_x_m=x,
                                  dem_y_m=y, size_m=160.0, resolution_m=2.0)
            assert np.isfinite(terrain.build(spec).z_m).all()
    assert not train.fits(10_000.0)
    with pytest.raises(InputError, match="no 10000 m square"):
        train.draw(rng, 10_000.0)


def test_the_bolasco_wider_look_fills_nodata_and_off_dem(shared_data: Path) -> None:
    """A second look's wider site on the park: its square reaches past the DEM's irregular
    outline (nodata) and its edge; the patch takes the nearest valid heights there."""
    path = str(shared_data / "dem" / "bolasco_1m.tif")
    x, y = DemPlaces.open(path, "heldout").draw(np.random.default_rng(1), 164.0)
    spec = terrain.preset("bin_tepe", mound=False, dem_path=path, dem_x_m=x, dem_y_m=y,
                          size_m=324.0, resolution_m=2.0, dem_extend=True)
    z = terrain.build(spec).z_m
    assert np.isfinite(z).all() and float(np.ptp(z)) < 40


def test_a_dem_in_degrees_is_refused_for_patches(tmp_path: Path) -> None:
    import rasterio
    from rasterio.transform import from_origin

    path = tmp_path / "deg.tif"
    with rasterio.open(path, "w", driver="GTiff", width=50, height=50, count=1,
                       dtype="float32", crs="EPSG:4326",
                       transform=from_origin(25.0, 42.0, 1e-4, 1e-4)) as ds:
        ds.write(np.zeros((1, 50, 50), dtype=np.float32))
    with pytest.raises(InputError, match="not in metres"):
        DemPlaces.open(str(path))


def test_a_running_grid_is_judged_by_the_cloud_its_verdicts_name(tmp_path: Path) -> None:
    """A dense grid still running has no grid.json: its cloud comes from its verdicts
    (it was taken for sparse, and judged with the sparse model); with neither, an error."""
    from mound.training import verdict_model as vm

    with pytest.raises(InputError, match="which cloud"):
        vm.grid_cloud(tmp_path)
    (tmp_path / "0000").mkdir()
    (tmp_path / "0000" / "verdict.json").write_text(json.dumps(
        {"schema": "mound.verdict", "version": 1, "status": "ok", "label": "no_mound",
         "method": "reference_free_model",
         "cloud": str(tmp_path / "0000" / "dense" / "dense.ply")}))
    assert vm.grid_cloud(tmp_path) == "dense"
    (tmp_path / "grid.json").write_text(json.dumps({"schema": "mound.verdict_grid",
                                                    "version": 1}))
    assert vm.grid_cloud(tmp_path) == "sparse"  # made before grids said so


def test_the_lower_second_look_flies_the_same_scan_from_half_the_height() -> None:
    """The other second look (mound sim grid --second-look-kind lower): the same site and
    scan area, the raster half as high, so nearly three times the images."""
    from mound.sim import site as sim

    spec = draws.draw(np.random.default_rng(0), 0, None, (320, 240))
    low = looks.lower(spec)
    assert low.terrain == spec.terrain and low.site_diameter_m == spec.site_diameter_m
    assert low.raster_altitude_m == pytest.approx(spec.site_diameter_m / 2)
    assert len(sim.shots(low)) > 2.5 * len(sim.shots(spec))  # 78 against 28
    assert looks.second_look_spec(spec, "wider") == looks.wider(spec)
    with pytest.raises(InputError, match="--second-look-kind"):
        grid_run.make_grid(Path("/nonexistent/g"), 1, 1, second_look_kind="higher")


def test_the_frontier_is_the_best_any_band_does_on_the_sites_themselves() -> None:
    """verdict_band.frontier against every band [a, b) of the sites' own p (brute force):
    the least undecided share that meets both confident-error goals, and the least errors
    (in multiples of the goals) within the undecided allowance."""
    rng = np.random.default_rng(5)
    n = 300
    y = rng.random(n) < 0.45
    goal = y & (rng.random(n) < 0.7)
    p = np.clip(np.where(y, rng.beta(5, 2, n), rng.beta(2, 5, n)), 1e-6, 1 - 1e-6)
    fr = vb.frontier(p, y, goal)
    cuts = np.unique(np.concatenate([p, [1.0]]))
    best_und, best_times = 1.0, np.inf
    for i, a in enumerate(cuts):
        for b in cuts[i:]:
            lab = vb.answers(p, (a, b))
            und = float((lab == vb.UNDECIDED).mean())
            miss = float((lab[goal] == vb.NO).mean())
            fa = float((lab[~y] == vb.MOUND).mean())
            if miss <= vb.MAX_MISS and fa <= vb.MAX_FA:
                best_und = min(best_und, und)
            if und <= vb.MAX_UNDECIDED:
                best_times = min(best_times, max(miss / vb.MAX_MISS, fa / vb.MAX_FA))
    assert fr["undecided_at_goals"] == pytest.approx(best_und)
    assert fr["best_within_undecided"]["times_the_goals"] == pytest.approx(best_times)
    assert fr["goals_reachable"] == (best_und <= vb.MAX_UNDECIDED)
