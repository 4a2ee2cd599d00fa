"""The value of a visit given the verdict's measured three-answer confusion (issue 69):
read from a real eval-verdict report, and Bayes' rule for what an answer says."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mound.errors import InputError
from mound.paths import REPO_ROOT
from mound.recon import visit_value as vv

REPORT = REPO_ROOT / "docs" / "results" / "verdict_three_answers_kazanlak.json"


def test_the_confusion_is_the_reports_counts() -> None:
    doc = json.loads(REPORT.read_text())
    c = vv.Confusion.from_report(doc, str(REPORT))
    t = doc["three_answers"]
    big = t["field_recall"]["all"]["by_height"]["2-5 m"]
    assert c.tumulus["2-5 m"] == pytest.approx(
        (big["confirmed"]["count"] / big["tumuli"], big["undecided"]["count"] / big["tumuli"],
         big["no_mound"]["count"] / big["tumuli"]))
    for rates in (*c.tumulus.values(), c.none):
        assert sum(rates) == pytest.approx(1.0) and min(rates) >= 0
    neg = t["confident_false_alarms"]["of"]
    assert c.none[0] == pytest.approx(t["confident_false_alarms"]["count"] / neg)
    assert c.none[1] == pytest.approx((t["undecided"]["count"] - t["undecided"]["tumuli"]) / neg)
    # a tall tumulus is confirmed more often than a low one
    assert c.tumulus[">= 5 m"][0] > c.tumulus["0.5-1 m"][0] > c.tumulus["0-0.5 m"][0]
    with pytest.raises(InputError, match="not an eval-verdict report"):
        vv.Confusion.from_report({"auc": 0.9}, "r.json")


def test_value_and_what_an_answer_says() -> None:
    tum, none = np.array([0.8, 0.15, 0.05]), (0.01, 0.3, 0.69)
    p = np.array([0.0, 0.1, 0.5, 0.9, 1.0])
    v = vv.visit_value(p, tum, none)
    assert v[0] == pytest.approx(-0.01) and v[-1] == pytest.approx(0.8)
    assert np.all(np.diff(v) > 0)  # the likelier a tumulus, the more a visit is worth
    # an undecided answer is likelier from a bare site here: p falls, and never leaves [0, 1]
    q = vv.after_answer(p, "undecided", tum, none)
    assert np.all(q[1:-1] < p[1:-1]) and q[0] == 0 and q[-1] == 1
    assert q[2] == pytest.approx(0.5 * 0.15 / (0.5 * 0.15 + 0.5 * 0.3))
    # a mound answer makes a site likely a tumulus, a no_mound one unlikely
    assert vv.after_answer(0.5, "mound", tum, none) == pytest.approx(0.8 / 0.81)
    assert vv.after_answer(0.5, "no_mound", tum, none) == pytest.approx(0.05 / 0.74)
    assert vv.height_class(0.3) == "0-0.5 m" and vv.height_class(5.0) == ">= 5 m"
    mix = vv.Confusion({n: (1.0, 0.0, 0.0) if n == ">= 5 m" else (0.0, 1.0, 0.0)
                        for n in vv.HEIGHT_CLASS_NAMES}, none)
    assert mix.tumulus_mean({">= 5 m": 1.0, "1-2 m": 3.0}) == pytest.approx([0.25, 0.75, 0.0])


def test_a_model_carries_the_confusion_its_band_gives_its_training_sites() -> None:
    """train-verdict writes trained.confusion (issue 69: the value of a visit stored with
    the model); Confusion.from_model reads it and refuses a malformed one, naming it."""
    from test_verdict_model import NAMES, synthetic

    from mound.training import verdict_model as vm

    model = vm.train(synthetic(400, 5), NAMES, ["g"])
    c = model["trained"]["confusion"]
    assert c["answers"] == ["mound", "undecided", "no_mound"]
    # the synthetic tumuli: 3 m high, those without a rise 0.5 m
    assert set(c["tumulus"]) == {"2-5 m", "0.5-1 m"}
    for rates in (*c["tumulus"].values(), c["none"]):
        assert sum(rates) == pytest.approx(1.0)
    assert c["tumulus"]["2-5 m"][0] > c["none"][0]  # tumuli are called mound more often
    full = {"trained": {"confusion": {"tumulus": {n: c["tumulus"]["2-5 m"]
                                                  for n in vv.HEIGHT_CLASS_NAMES},
                                      "none": c["none"]}}}
    got = vv.Confusion.from_model(full, "m.json")
    assert got.none == pytest.approx(tuple(c["none"]))
    with pytest.raises(InputError, match=r"m.json: trained.confusion.tumulus: no '0-0.5 m'"):
        vv.Confusion.from_model({"trained": {"confusion": c}}, "m.json")
    with pytest.raises(InputError, match="m.json: trained.confusion: missing"):
        vv.Confusion.from_model({"trained": {}}, "m.json")
    full["trained"]["confusion"]["none"] = [0.5, 0.6, 0.1]  # type: ignore[index]
    with pytest.raises(InputError, match=r"trained.confusion.none: expected 3 rates"):
        vv.Confusion.from_model(full, "m.json")
