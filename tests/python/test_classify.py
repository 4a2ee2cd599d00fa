"""The coarse-search classifier on the real Statlog data."""

from __future__ import annotations

import numpy as np
import pytest

from mound.classify import coarse, logistic, metrics, statlog
from mound.classify.features import Standardizer, band_columns
from mound.classify.model import Model
from mound.errors import InputError


@pytest.fixture(scope="module")
def trn(shared_data) -> statlog.Split:
    return statlog.load_file(shared_data / "statlog" / "sat.trn")


@pytest.fixture(scope="module")
def tst(shared_data) -> statlog.Split:
    return statlog.load_file(shared_data / "statlog" / "sat.tst")


@pytest.mark.parametrize("l2", [0.0, 0.1])
def test_gradient_matches_finite_differences(l2: float) -> None:
    rng = np.random.default_rng(0)
    x = np.hstack([rng.normal(size=(50, 4)), np.ones((50, 1))])
    y = np.where(rng.random(50) < 0.4, 1.0, -1.0)
    w = rng.normal(size=5)
    _, grad = logistic.loss_and_grad(w, x, y, l2)
    h = 1e-6
    fd = np.array([
        (logistic.loss_and_grad(w + h * e, x, y, l2)[0]
         - logistic.loss_and_grad(w - h * e, x, y, l2)[0]) / (2 * h)
        for e in np.eye(5)
    ])
    np.testing.assert_allclose(grad, fd, rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("mix,tau", [(0.3, 0.25), (1.0, 1.0), (0.5, 0.05)])
def test_the_bag_loss_gradient_matches_finite_differences(mix: float, tau: float) -> None:
    rng = np.random.default_rng(3)
    x = np.hstack([rng.normal(size=(60, 4)), np.ones((60, 1))])
    bags = rng.integers(0, 12, 60)
    y = np.where(bags % 3 == 0, 1.0, -1.0)  # one label per bag
    w = rng.normal(size=5)
    _, grad = logistic.loss_and_grad_bags(w, x, y, bags, mix, tau, 1e-2)
    h = 1e-6
    fd = np.array([
        (logistic.loss_and_grad_bags(w + h * e, x, y, bags, mix, tau, 1e-2)[0]
         - logistic.loss_and_grad_bags(w - h * e, x, y, bags, mix, tau, 1e-2)[0]) / (2 * h)
        for e in np.eye(5)
    ])
    np.testing.assert_allclose(grad, fd, rtol=1e-5, atol=1e-8)


def test_the_bag_loss_scores_a_bag_by_its_highest_row() -> None:
    rng = np.random.default_rng(4)
    x = np.hstack([rng.normal(size=(40, 3)), np.ones((40, 1))])
    y = np.where(rng.random(40) < 0.5, 1.0, -1.0)
    w = rng.normal(size=4)
    # mix 0 is the plain loss; bags of one row give the plain loss whatever the mix
    plain = logistic.loss_and_grad(w, x, y, 0.1)
    for mix, bags in ((0.0, np.zeros(40, int) + (y > 0)), (0.7, np.arange(40))):
        mixed = logistic.loss_and_grad_bags(w, x, y, bags, mix, 0.5, 0.1)
        assert mixed[0] == pytest.approx(plain[0])
        np.testing.assert_allclose(mixed[1], plain[1], atol=1e-12)
    # one negative bag of every row: as tau -> 0 its loss is that of the highest row
    neg = -np.ones(40)
    top = float(np.max(x @ w))
    loss, _ = logistic.loss_and_grad_bags(w, x, neg, np.zeros(40, int), 1.0, 1e-3)
    assert loss == pytest.approx(np.logaddexp(0.0, top), abs=1e-2)
    fit = logistic.fit_bags(x, neg * np.sign(x[:, 0]), (x[:, 0] > 0).astype(int), 0.5, 0.25,
                            l2=1e-2)
    assert fit.converged or fit.grad_norm < 1e-5
    with pytest.raises(ValueError, match="one label"):
        logistic.fit_bags(x, y, np.zeros(40, int), 0.5, 0.25)
    with pytest.raises(ValueError, match="mix"):
        logistic.fit_bags(x, y, np.arange(40), 1.5, 0.25)


@pytest.mark.slow
def test_gradient_descent_and_lbfgs_reach_the_same_weights(trn: statlog.Split) -> None:
    x = trn.x[:, band_columns(coarse.DEFAULT_BAND)]
    design = Standardizer.fit(x).design(x)
    gd = logistic.fit_gd(design, trn.y, l2=coarse.DEFAULT_L2, tol=1e-6)
    lb = logistic.fit_lbfgs(design, trn.y, l2=coarse.DEFAULT_L2, tol=1e-6)
    # Both stop near |grad| = 1e-6 (L-BFGS's line search gives up just above it).
    assert gd.converged and lb.grad_norm < 2e-6
    # Stated tolerance: weights (of order 1) agree to 3e-3, the loss to 1e-8.
    assert np.abs(gd.w).max() > 0.5
    np.testing.assert_allclose(gd.w, lb.w, atol=3e-3)
    assert gd.loss == pytest.approx(lb.loss, abs=1e-8)
    # Every gradient step decreases the loss (step 1/L): the GD loss is at the optimum.
    assert gd.loss <= logistic.loss_and_grad(np.zeros_like(gd.w), design, trn.y,
                                             coarse.DEFAULT_L2)[0]


@pytest.mark.parametrize("band", [0, 1, 2, 3, None])
def test_classifier_beats_majority_baseline_on_test_set(
    trn: statlog.Split, tst: statlog.Split, band: int | None
) -> None:
    model = coarse.train(trn, band, solver="lbfgs")
    s = coarse.evaluate(model, tst)
    assert s["majority_accuracy"] == pytest.approx(1 - 224 / 2000)
    assert s["accuracy"] > s["majority_accuracy"]
    assert s["auc"] > 0.75
    assert sum(r["count"] for r in s["reliability"]) == 2000


def test_band_selection_uses_only_the_training_file(trn: statlog.Split) -> None:
    rows = coarse.select_band(trn)
    assert [r["band"] for r in rows] == [0, 1, 2, 3, None]
    best = max((r for r in rows if r["band"] is not None), key=lambda r: r["auc"])
    assert best["band"] == coarse.DEFAULT_BAND  # the documented choice is what the data say


def test_auc_and_log_loss_against_hand_computed_values() -> None:
    p = np.array([0.1, 0.4, 0.35, 0.8])
    y = np.array([-1.0, -1.0, 1.0, 1.0])
    assert metrics.roc_auc(p, y) == pytest.approx(0.75)  # 3 of 4 pairs ordered
    assert metrics.log_loss(np.array([0.5, 0.5]), np.array([1.0, -1.0])) == pytest.approx(
        np.log(2))
    assert metrics.accuracy(p, y) == pytest.approx(0.75)


def test_model_json_round_trip_and_validation(trn: statlog.Split, tst: statlog.Split) -> None:
    model = coarse.train(trn, 1, solver="lbfgs")
    back = Model.from_doc(model.to_doc(), "m.json")
    np.testing.assert_array_equal(back.predict(tst.x), model.predict(tst.x))
    doc = model.to_doc()
    doc["weights"] = doc["weights"][:-1]
    with pytest.raises(InputError, match="weights"):
        Model.from_doc(doc, "m.json")
    doc = model.to_doc()
    del doc["mean"]
    with pytest.raises(InputError, match="mean"):
        Model.from_doc(doc, "m.json")


def test_the_papers_decision_rule() -> None:
    """p(mound) >= 0.5 is a mound, in the one function every stage uses."""
    from mound.classify.metrics import says_mound

    assert says_mound(0.5) and says_mound(0.93)
    assert not says_mound(0.4999) and not says_mound(0.0)
    p, y = np.array([0.5, 0.49, 0.9]), np.array([1, -1, -1])
    assert metrics.accuracy(p, y) == pytest.approx(2 / 3)
