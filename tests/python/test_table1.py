"""Error rates of Table I on a hand-made field."""

from __future__ import annotations

import pytest

from mound.plan.table1 import error_rates


def site(sid: str, mound: bool, p: float) -> dict:
    return {"id": sid, "p_mound": p, "truth": {"mound": mound}}


def test_visited_sites_are_correct_and_unvisited_keep_the_classifier_label() -> None:
    doc = {"sites": [
        site("a", True, 0.2),   # mound the classifier misses
        site("b", True, 0.9),   # mound the classifier finds
        site("c", False, 0.7),  # false alarm of the classifier
        site("d", False, 0.1),
        site("e", False, 0.6),  # another false alarm
    ]}
    # Nothing visited: the classifier alone. MD = 1/2, FA = 2/3.
    assert error_rates(doc, set()) == pytest.approx((0.5, 2 / 3))
    # Visiting a and c fixes both of those; e remains a false alarm.
    assert error_rates(doc, {"a", "c"}) == pytest.approx((0.0, 1 / 3))
    # Visiting everything leaves no error.
    assert error_rates(doc, {"a", "b", "c", "d", "e"}) == (0.0, 0.0)
