"""Table I: error rates on a hand-made field, the paper setting, the bench command."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from mound.classify import coarse, logistic, statlog
from mound.classify.features import Standardizer, band_columns
from mound.cli import main as mound_main
from mound.formats.sites import Site, Truth
from mound.plan.field import STANDARD_SEEDS, make_field
from mound.plan.table1 import ALGOS, PAPER, error_rates, mean_total_reward, paper_classifier


def site(sid: str, mound: bool, p: float) -> Site:
    return Site(sid, 0.0, 0.0, 1.0, p_mound=p, truth=Truth(mound))


def test_visited_sites_are_correct_and_unvisited_keep_the_classifier_label() -> None:
    doc = [
        site("a", True, 0.2),   # mound the classifier misses
        site("b", True, 0.9),   # mound the classifier finds
        site("c", False, 0.7),  # false alarm of the classifier
        site("d", False, 0.1),
        site("e", False, 0.6),  # another false alarm
    ]
    # Nothing visited: the classifier alone. MD = 1/2, FA = 2/3.
    assert error_rates(doc, set()) == pytest.approx((0.5, 2 / 3))
    # Visiting a and c fixes both of those; e remains a false alarm.
    assert error_rates(doc, {"a", "c"}) == pytest.approx((0.0, 1 / 3))
    # Visiting everything leaves no error.
    assert error_rates(doc, {"a", "b", "c", "d", "e"}) == (0.0, 0.0)


def test_fractional_gradient_descent_stops_part_way_along_the_last_step(shared_data) -> None:
    trn = statlog.load_file(shared_data / "statlog" / "sat.trn")
    x = Standardizer.fit(trn.x[:, band_columns(1)]).design(trn.x[:, band_columns(1)])
    w13 = logistic.fit_gd(x, trn.y, max_iter=13).w
    w14 = logistic.fit_gd(x, trn.y, max_iter=14).w
    w = logistic.fit_gd(x, trn.y, max_iter=13.25).w
    np.testing.assert_allclose(w, w13 + 0.25 * (w14 - w13), rtol=1e-12, atol=1e-15)


@pytest.mark.slow
def test_paper_setting_matches_the_papers_total_reward(shared_data) -> None:
    test = statlog.load_file(shared_data / "statlog" / "sat.tst")
    trn = statlog.load_file(shared_data / "statlog" / "sat.trn")
    fields = [make_field(test, s) for s in STANDARD_SEEDS]
    model, t, total = paper_classifier(trn, test, fields)
    assert total == pytest.approx(PAPER.total_reward_per_field, abs=1e-3)
    assert mean_total_reward(model, test, fields) == pytest.approx(total, abs=1e-12)
    assert 13 < t < 14  # docs/results.md, Table I: between 10 and 30 iterations
    converged = coarse.train(trn, coarse.DEFAULT_BAND)
    assert mean_total_reward(converged, test, fields) < 15  # ours: about 12 bits


@pytest.mark.slow
def test_bench_table1_paper_with_proven_optima(tmp_path: Path) -> None:
    """`mound bench table1 --paper` at a small budget: every field proven optimal by SCIP,
    the optimum at or above every planner's plan, and ALNS-OP at the optimum there."""
    out = tmp_path / "t1"
    assert mound_main(["bench", "table1", "--paper", "--budgets", "12",
                       "--exact-time-limit", "60", "--out-dir", str(out)]) == 0
    doc = json.loads((out / "table1.json").read_text())
    assert doc["setting"]["paper"] and 13 < doc["setting"]["gd_iterations"] < 14
    assert len(doc["exact"]) == len(STANDARD_SEEDS)
    for e in doc["exact"]:
        assert e["status"] == "optimal" and e["reward"] == pytest.approx(e["bound"])
        assert all(r <= e["reward"] + 1e-9 for r in e["best_heuristic"].values())
        assert e["best_heuristic"]["alns"] == pytest.approx(e["reward"], abs=1e-9)
        assert e["tour"][0] == e["tour"][-1] == "home"
    rows = {r["algo"]: r for r in doc["rows"]}
    assert set(rows) == {*ALGOS, "exact"} and rows["exact"]["proven"] == 10
    with open(out / "table1.csv", newline="") as f:
        assert len(list(csv.DictReader(f))) == len(ALGOS) + 1
    assert (out / "reward_vs_budget.png").stat().st_size > 0
    assert mound_main(["bench", "table1", "--budgets", "nan", "--out-dir", str(out)]) == 2
