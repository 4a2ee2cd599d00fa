"""The value of visiting a site, given what the 3-D verdict is measured to say (issue 69).

The paper's reward is a site's binary entropy, as if a visit always settled it. A visit
settles a site only as often as the verdict answers: its three answers (`mound`,
`no_mound`, `undecided`) have a measured confusion, a tumulus's by its height class and a
bare site's as a whole (an `eval-verdict` report's `three_answers`). Here a site's value is
the expected fall in wrong final labels from visiting it, where a tumulus not confirmed
`mound` by a visit is a wrong (unknown) label and a site without one called `mound` is a
wrong one too:

    value = p P(mound | tumulus) - (1 - p) P(mound | none)

with P(mound | tumulus) averaged over the population's height classes. An answer moves p by
Bayes' rule (`after_answer`): after an undecided one the site may be visited again (a
second look) at the value its new p gives.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from mound.errors import InputError
from mound.jsonio import finite_number
from mound.recon.verdict_band import ANSWERS, HEIGHT_CLASS_NAMES, height_class

__all__ = ["ANSWERS", "HEIGHT_CLASS_NAMES", "Confusion", "after_answer", "drawn_answer",
           "height_class", "visit_value"]


@dataclass(frozen=True)
class Confusion:
    """The verdict's three answers' rates: `tumulus[c]` for a tumulus of height class c,
    `none` for a site without one; each (mound, undecided, no_mound), summing to 1."""

    tumulus: Mapping[str, tuple[float, float, float]]
    none: tuple[float, float, float]

    @classmethod
    def from_report(cls, doc: Mapping[str, object], where: str) -> Confusion:
        """From an `eval-verdict` report (its three_answers): per height class the tumuli
        confirmed, undecided and called no_mound; the sites without a tumulus called mound
        (confident false alarms) and left undecided (the undecided less its tumuli)."""
        at = f"{where}: three_answers"
        t = _field(doc, "three_answers", where)
        by = _field(_field(_field(t, "field_recall", at), "all", f"{at}.field_recall"),
                    "by_height", f"{at}.field_recall.all")
        out: dict[str, tuple[float, float, float]] = {}
        for name in HEIGHT_CLASS_NAMES:
            c_at = f"{at}.field_recall.all.by_height.{name}"
            c = _field(by, name, f"{at}.field_recall.all.by_height")
            n = finite_number(c.get("tumuli"), f"{c_at}.tumuli", lo=0)
            k = [finite_number(_field(c, a, c_at).get("count"), f"{c_at}.{a}.count", lo=0)
                 for a in ("confirmed", "undecided", "no_mound")]
            if not n > 0 or abs(sum(k) - n) > 1e-9 * n:
                raise InputError(f"{c_at}: expected tumuli > 0, each confirmed, undecided or "
                                 "called no_mound")
            out[name] = (k[0] / n, k[1] / n, k[2] / n)
        fa_doc = _field(t, "confident_false_alarms", at)
        und_doc = _field(t, "undecided", at)
        neg = finite_number(fa_doc.get("of"), f"{at}.confident_false_alarms.of", lo=0)
        fa = finite_number(fa_doc.get("count"), f"{at}.confident_false_alarms.count", lo=0)
        und = (finite_number(und_doc.get("count"), f"{at}.undecided.count", lo=0)
               - finite_number(und_doc.get("tumuli"), f"{at}.undecided.tumuli", lo=0))
        if not neg > 0 or not 0 <= und or not fa + und <= neg:
            raise InputError(f"{at}: no sites without a tumulus, or more of them called "
                             "mound and undecided than there are")
        return cls(out, (fa / neg, und / neg, 1 - (fa + und) / neg))

    @classmethod
    def from_model(cls, doc: Mapping[str, object], where: str) -> Confusion:
        """From a verdict model trained since 2026-11-29 (`trained.confusion`, train-verdict's:
        the rates its band gives its training sites' out-of-fold p); InputError naming
        `where` and the field when it has none or it is malformed."""
        trained = doc.get("trained")
        c = trained.get("confusion") if isinstance(trained, Mapping) else None
        at = f"{where}: trained.confusion"
        if not isinstance(c, Mapping):
            raise InputError(f"{at}: missing (retrain the model with mound recon "
                             "train-verdict)")
        tum = c.get("tumulus")
        if not isinstance(tum, Mapping):
            raise InputError(f"{at}.tumulus: expected rates by height class")
        out = {}
        for name in HEIGHT_CLASS_NAMES:
            if name not in tum:
                raise InputError(f"{at}.tumulus: no {name!r} (no such tumulus in training)")
            out[name] = _rates(tum[name], f"{at}.tumulus.{name}")
        return cls(out, _rates(c.get("none"), f"{at}.none"))

    def tumulus_mean(self, weights: Mapping[str, float]) -> np.ndarray:
        """A tumulus's answer rates averaged over height classes weighted by `weights`."""
        w = np.array([weights.get(n, 0.0) for n in HEIGHT_CLASS_NAMES], dtype=float)
        if not w.sum() > 0:
            raise InputError("height class weights: none above 0")
        rates = np.array([self.tumulus[n] for n in HEIGHT_CLASS_NAMES])
        return (w / w.sum()) @ rates


def _field(doc: object, key: str, at: str) -> Mapping[str, Any]:
    """doc[key], an object, else InputError naming `at`.key."""
    v = doc.get(key) if isinstance(doc, Mapping) else None
    if not isinstance(v, Mapping):
        raise InputError(f"{at}: {key}: expected an object (not an eval-verdict report with "
                         "three answers?)")
    return v


def _rates(v: object, at: str) -> tuple[float, float, float]:
    """Three answer rates (mound, undecided, no_mound) in [0, 1] summing to 1."""
    if not isinstance(v, list) or len(v) != 3:
        raise InputError(f"{at}: expected 3 rates (mound, undecided, no_mound)")
    xs = [finite_number(x, f"{at}[{k}]", lo=0, hi=1) for k, x in enumerate(v)]
    if abs(sum(xs) - 1) > 1e-6:
        raise InputError(f"{at}: expected 3 rates in [0, 1] summing to 1 (mound, undecided, "
                         "no_mound)")
    return xs[0], xs[1], xs[2]


def visit_value(p: np.ndarray, tumulus: np.ndarray, none: tuple[float, float, float]
                ) -> np.ndarray:
    """The expected fall in wrong final labels from visiting sites of p(tumulus) `p`: a
    tumulus confirmed (rate tumulus[0]) is one wrong label fewer, a site without one called
    mound (none[0]) one more."""
    p = np.asarray(p, dtype=float)
    return p * tumulus[0] - (1 - p) * none[0]


def after_answer(p: np.ndarray | float, answer: str, tumulus: np.ndarray,
                 none: tuple[float, float, float]) -> np.ndarray:
    """p(tumulus) of sites after the verdict answered `answer` (Bayes' rule; p unchanged
    where the answer is impossible either way): how much a `mound` or `no_mound` says, which
    the classifier learns as the example's weight, and where an `undecided` leaves p."""
    k = ANSWERS.index(answer)
    p = np.asarray(p, dtype=float)
    a, b = p * tumulus[k], (1 - p) * none[k]
    return np.where(a + b > 0, a / np.maximum(a + b, 1e-300), p)


def drawn_answer(rates: Sequence[float] | np.ndarray, u: float) -> str:
    """The answer a uniform draw `u` in [0, 1) picks from the three answers' `rates` (in
    ANSWERS' order): what a simulated visit answers."""
    return ANSWERS[0] if u < rates[0] else ANSWERS[1] if u < rates[0] + rates[1] \
        else ANSWERS[2]
