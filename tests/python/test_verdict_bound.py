"""The oracle's ceiling for a shape verdict (`mound recon verdict-bound`): the matched
filter finds a tumulus told its centre and relief, not one where there is none; the
command reads a grid's true surfaces, judges them against the null of its sites without
a tumulus (or another report's thresholds) and refuses what is no grid."""

from __future__ import annotations

import json
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np
import pytest

from mound.cli import main as mound_main
from mound.sim import terrain
from mound.training import verdict_bound as vb

FLAT = terrain.TerrainSpec(size_m=80.0, resolution_m=0.5, ground_relief_m=0.3, mound=False,
                           seed=3)
CONE = replace(FLAT, mound=True, profile="conical", height_m=3.0, diameter_m=30.0,
               mound_x_m=4.0, mound_y_m=-3.0, erosion_m=1.0)
DISC = ((0.0, 0.0), 38.0)


def _tilted(hf: terrain.Heightfield) -> terrain.Heightfield:
    """The surface on a 10 % slope with a bowl of 2 m over the site (the quadratic ground
    the filter fits away)."""
    xx, yy = np.meshgrid(hf.x_m, hf.y_m)
    return terrain.Heightfield(hf.x_m, hf.y_m, hf.z_m + 0.1 * xx + 2.0 * (xx**2 + yy**2) / 40**2)


def test_the_filter_finds_a_tumulus_it_is_told_of_and_none_where_there_is_none() -> None:
    cone = _tilted(terrain.build(CONE))
    ground = _tilted(terrain.build(FLAT))
    at = (CONE.mound_x_m, CONE.mound_y_m)
    found = vb.filter_output(cone, CONE, at, *DISC)
    empty = vb.filter_output(ground, CONE, at, *DISC)
    assert found is not None and empty is not None
    assert found > 20 and abs(empty) < 5
    # a looted tumulus: the filter is told its trench too, and still finds it
    looted = replace(CONE, trench_width_m=4.0, trench_depth_m=2.0, trench_azimuth_deg=30.0)
    out = vb.filter_output(_tilted(terrain.build(looted)), looted, at, *DISC)
    assert out is not None and out > 20
    # the window off the scanned site: no output
    assert vb.filter_output(cone, CONE, (60.0, 60.0), (0.0, 0.0), 10.0) is None


def test_the_whitened_filter_finds_a_told_tumulus_against_the_ground_s_covariance() -> None:
    """Ground of one kind (the same undulation's statistics, other seeds): the whitened
    filter's output is large for a told cone standing on it, its null (the same window on
    other sites) is not, and a window off the site gives none."""
    rng = np.random.default_rng(0)
    rough = replace(FLAT, ground_relief_m=1.5)
    ground = [(_tilted(terrain.build(replace(rough, seed=s))), (0.0, 0.0)) for s in range(20, 34)]
    null = [(_tilted(terrain.build(replace(rough, seed=s))), (0.0, 0.0)) for s in range(40, 46)]
    cone = replace(rough, mound=True, profile="conical", height_m=2.0, diameter_m=24.0,
                   mound_x_m=4.0, mound_y_m=-3.0, erosion_m=1.0, seed=7)
    got = vb.whitened_output(_tilted(terrain.build(cone)), cone, *DISC, ground, null, rng)
    assert got is not None
    out, nulls = got
    assert len(nulls) == len(null) * vb.NULL_ROTATIONS
    assert out > 10 and max(abs(v) for v in nulls) < 6
    # a looted one: the filter is told its trench too
    looted = replace(cone, trench_width_m=3.0, trench_depth_m=1.5, trench_azimuth_deg=30.0)
    got = vb.whitened_output(_tilted(terrain.build(looted)), looted, *DISC, ground, null, rng)
    assert got is not None and got[0] > 10
    # the same ground without it
    empty = _tilted(terrain.build(replace(rough, seed=7)))
    got = vb.whitened_output(empty, cone, *DISC, ground, null, rng)
    assert got is not None and abs(got[0]) < 6
    # the window off the scanned site; too few ground windows for a covariance
    assert vb.whitened_output(empty, replace(cone, mound_x_m=60.0, mound_y_m=60.0),
                              (0.0, 0.0), 10.0, ground, null, rng) is None
    assert vb.whitened_output(empty, cone, *DISC, ground[:2], null, rng) is None
    # told the place only within 4 m: a centre told 3 m off is found as well as the true one
    off = replace(cone, mound_x_m=cone.mound_x_m + 3.0)
    site = _tilted(terrain.build(cone))
    near = vb.whitened_output(site, off, *DISC, ground, null, rng, place_within_m=4.0)
    blind = vb.whitened_output(site, off, *DISC, ground, null, rng)
    assert near is not None and blind is not None
    assert near[0] > 10 and near[0] > blind[0] and len(near[1]) == len(null) * vb.NULL_ROTATIONS


def _grid(root: Path, specs: list[terrain.TerrainSpec]) -> Path:
    """A grid folder as `mound sim grid` writes it, without the flights: each site's true
    surface (sim/site.json + heightfield.npy), its truth and a verdict naming the scanned
    disc."""
    rows = []
    for k, spec in enumerate(specs):
        site = root / f"{k:04d}"
        (site / "sim").mkdir(parents=True)
        hf = terrain.build(spec)
        np.save(site / "sim" / "heightfield.npy", hf.z_m.astype(np.float32))
        (site / "sim" / "site.json").write_text(json.dumps({
            "schema": "mound.sim_site", "version": 1, "heightfield": {
            "npy": "heightfield.npy", "x0_m": float(hf.x_m[0]), "y0_m": float(hf.y_m[0]),
            "spacing_m": float(hf.x_m[1] - hf.x_m[0]), "shape": list(hf.z_m.shape)}}))
        truth = {"mound": spec.mound, "kind": "tumulus" if spec.mound else "flat",
                 "profile": spec.profile, "height_m": spec.height_m,
                 "diameter_m": spec.diameter_m, "centre_enu_m": [spec.mound_x_m, spec.mound_y_m],
                 "pit": False, "trench": False, "slope_deg": 0.0, "dem": False}
        (site / "verdict.json").write_text(json.dumps({
            "schema": "mound.verdict", "version": 1, "status": "ok", "label": "no_mound",
            "method": "reference_free_model", "measurements": {
                "site_centre_enu_m": list(DISC[0]), "site_radius_m": DISC[1],
                "judged_rises": []}}))
        terrain_doc = {**asdict(spec), "confusers": []}
        rows.append({"dir": site.name, "truth": truth, "status": "ok",
                     "spec": {"terrain": terrain_doc}})
    (root / "grid.json").write_text(json.dumps({"schema": "mound.verdict_grid",
                                                "version": 1, "rows": rows}))
    return root


def test_the_command_judges_a_grid_against_its_own_null_and_another_s(tmp_path: Path) -> None:
    tumuli = [replace(CONE, seed=s, mound_x_m=x) for s, x in ((4, 0.0), (5, 5.0), (6, -6.0))]
    empty = [replace(FLAT, seed=s) for s in range(10, 16)]
    grid = _grid(tmp_path / "grid", tumuli + empty)
    report = tmp_path / "bound.json"
    assert mound_main(["recon", "verdict-bound", str(grid), "--report", str(report),
                       "--placements", "4"]) == 0
    doc = json.loads(report.read_text())
    assert doc["schema"] == vb.SCHEMA and doc["version"] == vb.VERSION
    assert doc["null"]["synthetic"]["placements"] == 6 * 4
    assert doc["null"]["dem"]["placements"] == 0 and doc["null"]["dem"]["above_threshold"] is None
    assert set(doc["thresholds"]) == {"synthetic"} and not doc["thresholds_given"]
    g = doc["goal_tumuli"]
    assert g["all"] == g["on_synthetic"] == {"sites": 3, "found": 3}
    assert g["clear"] == {"sites": 3, "found": 3} and g["masked"]["sites"] == 0
    assert all(r["found"] and r["output"] > doc["thresholds"]["synthetic"]
               for r in doc["rows"])
    # judged against another report's thresholds: a threshold above every output finds none
    strict = tmp_path / "strict.json"
    strict.write_text(json.dumps({**doc, "thresholds": {"synthetic": 1e9}}))
    again = tmp_path / "again.json"
    assert mound_main(["recon", "verdict-bound", str(grid), "--report", str(again),
                       "--thresholds-from", str(strict)]) == 0
    doc2 = json.loads(again.read_text())
    assert doc2["thresholds_given"] and doc2["goal_tumuli"]["all"] == {"sites": 3, "found": 0}
    assert doc["filter"] == doc2["filter"] == "plain"


def test_the_whitened_command_learns_the_ground_from_other_grids(tmp_path: Path) -> None:
    """--whiten on a grid's own sites without a tumulus (half learn the covariance, half the
    null), then a second grid judged with the first's ground (--ground-from) and
    thresholds."""
    rough = replace(FLAT, ground_relief_m=1.5)
    cone = replace(CONE, ground_relief_m=1.5, height_m=2.5)
    train = _grid(tmp_path / "train", [replace(cone, seed=s, mound_x_m=x)
                                       for s, x in ((4, 0.0), (5, 5.0), (6, -6.0))]
                  + [replace(rough, seed=s) for s in range(10, 38)])
    report = tmp_path / "white.json"
    assert mound_main(["recon", "verdict-bound", str(train), "--whiten", "--report",
                       str(report)]) == 0
    doc = json.loads(report.read_text())
    assert doc["filter"] == "whitened" and "whitened" in doc["method"]
    assert doc["place_within_m"] == 0
    assert doc["null"]["synthetic"]["placements"] == 3 * 14 * vb.NULL_ROTATIONS
    assert doc["goal_tumuli"]["all"] == {"sites": 3, "found": 3}
    held = _grid(tmp_path / "held", [replace(cone, seed=s, mound_y_m=y)
                                     for s, y in ((50, 4.0), (51, -5.0))]
                 + [replace(rough, seed=s) for s in range(60, 64)])
    out = tmp_path / "held.json"
    assert mound_main(["recon", "verdict-bound", str(held), "--whiten", "--ground-from",
                       str(train), "--thresholds-from", str(report), "--report",
                       str(out)]) == 0
    doc2 = json.loads(out.read_text())
    assert doc2["thresholds"] == doc["thresholds"] and doc2["thresholds_given"]
    assert doc2["null"]["synthetic"]["placements"] == 2 * 4 * vb.NULL_ROTATIONS
    assert doc2["goal_tumuli"]["all"] == {"sites": 2, "found": 2}


def test_the_command_refuses_what_is_no_grid(tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    assert mound_main(["recon", "verdict-bound", str(tmp_path)]) == 2
    assert "grid.json" in capsys.readouterr().err
    grid = _grid(tmp_path / "g", [replace(FLAT, seed=s) for s in range(3)])
    assert mound_main(["recon", "verdict-bound", str(grid)]) == 2  # no tumulus to judge
    assert "needs measured sites" in capsys.readouterr().err
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"schema": vb.SCHEMA, "version": 1, "thresholds": {"dem": "x"}}))
    grid2 = _grid(tmp_path / "g2", [CONE, FLAT])
    assert mound_main(["recon", "verdict-bound", str(grid2), "--thresholds-from",
                       str(bad)]) == 2
    assert "thresholds.dem: expected a finite number" in capsys.readouterr().err
    bad.write_text(json.dumps({"schema": vb.SCHEMA, "version": 1,
                               "thresholds": {"marsh": 3.0}}))
    assert mound_main(["recon", "verdict-bound", str(grid2), "--thresholds-from",
                       str(bad)]) == 2
    assert "thresholds.marsh" in capsys.readouterr().err
    assert mound_main(["recon", "verdict-bound", str(grid2), "--placements", "0"]) == 2
    # the whitened filter: never against the plain one's thresholds, and --ground-from
    # only with it
    capsys.readouterr()
    bad.write_text(json.dumps({"schema": vb.SCHEMA, "version": 1, "filter": "plain",
                               "thresholds": {"synthetic": 3.0}}))
    assert mound_main(["recon", "verdict-bound", str(grid2), "--whiten", "--thresholds-from",
                       str(bad)]) == 2
    assert "filter" in capsys.readouterr().err
    assert mound_main(["recon", "verdict-bound", str(grid2), "--ground-from",
                       str(grid2)]) == 2
    assert "--ground-from" in capsys.readouterr().err
    assert mound_main(["recon", "verdict-bound", str(grid2), "--place-within", "4"]) == 2
    assert "--place-within" in capsys.readouterr().err
    assert mound_main(["recon", "verdict-bound", str(grid2), "--whiten", "--place-within",
                       "40"]) == 2
    assert "--place-within" in capsys.readouterr().err
    bad.write_text(json.dumps({"schema": vb.SCHEMA, "version": 1, "filter": "whitened",
                               "thresholds": {"synthetic": 3.0}}))
    assert mound_main(["recon", "verdict-bound", str(grid2), "--whiten", "--place-within",
                       "4", "--thresholds-from", str(bad)]) == 2
    assert "place_within_m" in capsys.readouterr().err
    # a grid with one site without a tumulus: none left to learn the covariance from
    assert mound_main(["recon", "verdict-bound", str(grid2), "--whiten"]) == 2
    assert "covariance" in capsys.readouterr().err
