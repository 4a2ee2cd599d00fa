"""Rewards and the paper's fields of candidate sites."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mound.classify import coarse, statlog
from mound.classify.reward import binary_entropy_bits
from mound.cli import main as mound_main
from mound.plan.field import GRID, STANDARD_SEEDS, make_field, sites_document


def test_entropy_is_one_bit_at_half_and_zero_at_the_ends() -> None:
    assert binary_entropy_bits(0.5) == pytest.approx(1.0)
    h = binary_entropy_bits(np.array([0.0, 1.0, 1e-300, 1 - 1e-16, 0.11, 0.89]))
    assert not np.any(np.isnan(h))
    assert h[0] == 0.0 and h[1] == 0.0
    assert h[2] < 1e-290 and h[3] < 1e-14
    assert h[4] == pytest.approx(h[5]) == pytest.approx(0.4999, abs=1e-3)
    for bad in (-0.1, 1.5, float("nan")):
        with pytest.raises(ValueError):
            binary_entropy_bits(bad)


@pytest.fixture(scope="module")
def tst(shared_data: Path) -> statlog.Split:
    return statlog.load_file(shared_data / "statlog" / "sat.tst")


@pytest.fixture(scope="module")
def model(shared_data: Path) -> coarse.Model:
    return coarse.train(statlog.load_file(shared_data / "statlog" / "sat.trn"),
                        coarse.DEFAULT_BAND, solver="lbfgs")


def test_fields_have_size_positives_and_repeat_for_a_seed(tst: statlog.Split) -> None:
    seen = set()
    for seed in STANDARD_SEEDS:
        f = make_field(tst, seed)
        assert f.rows.shape == (GRID * GRID,)
        assert len(set(f.rows.tolist())) == 100  # no test example used twice
        k = int(f.positive.sum())
        assert 3 <= k <= 5
        assert np.all((tst.cls[f.rows] == 2) == f.positive)
        again = make_field(tst, seed)
        np.testing.assert_array_equal(f.rows, again.rows)
        seen.add(tuple(f.rows.tolist()))
    assert len(seen) == len(STANDARD_SEEDS)


def test_field_document_is_a_valid_plan_input(tst, model, tmp_path: Path) -> None:
    from mound import native

    doc = sites_document(make_field(tst, 3), tst, model, scan_cost_m=1.0,
                         budget_m=120.0).to_doc()
    xs = sorted({s["x_m"] for s in doc["sites"]})
    assert xs == [float(v) for v in range(1, 11)]
    rewards = np.array([s["reward"] for s in doc["sites"]])
    p = np.array([s["p_mound"] for s in doc["sites"]])
    np.testing.assert_allclose(rewards, binary_entropy_bits(p))
    assert doc["provenance"]["total_reward"] == pytest.approx(rewards.sum())
    path = tmp_path / "sites.json"
    path.write_text(json.dumps(doc))
    plan = native.run_json("mound_plan", [str(path)])  # the planner ignores "truth"
    assert plan["status"] == "ok" and plan["cost_m"] <= 120.0


def test_cli_train_eval_and_field(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    model_path = tmp_path / "model.json"
    assert mound_main(["classify", "train", "--solver", "lbfgs", "--out", str(model_path)]) == 0
    assert json.loads(model_path.read_text())["schema"] == "mound.classifier"
    assert mound_main(["classify", "eval", str(model_path), "--json",
                       str(tmp_path / "eval.json")]) == 0
    out = capsys.readouterr().out
    assert "majority baseline 0.8880" in out and "reliability" in out
    sites = tmp_path / "s.json"
    assert mound_main(["field", "make", "--seed", "4", "--model", str(model_path),
                       "--out", str(sites)]) == 0
    assert len(json.loads(sites.read_text())["sites"]) == 100


def test_cli_bad_input_exits_2_with_one_line(tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text('{"schema": "mound.classifier", "version": 9}')
    assert mound_main(["classify", "eval", str(bad)]) == 2
    assert mound_main(["field", "make", "--seed", "x", "--out", "o.json"]) == 2
    assert mound_main(["field", "make", "--seed", "1", "--scan-cost", "-1",
                       "--out", str(tmp_path / "o.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 3 and all(line.startswith("mound: ") for line in err)
    assert "version" in err[0]
    assert not (tmp_path / "o.json").exists()
