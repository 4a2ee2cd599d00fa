"""What a visit is worth to the survey's planner (`--reward`): the paper's binary entropy of
p(mound), or the value of a visit given the verdict's measured three-answer confusion
(mound.recon.visit_value: the expected fall in wrong final labels; `--confusion`, a
verdict model's `trained.confusion` or an `eval-verdict` report). A tumulus's rates are
the mean over its height classes weighted by the Kazanlak inventory's mix of heights
(the population the confusion was measured on)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mound.classify.reward import binary_entropy_bits
from mound.errors import InputError
from mound.formats.sites import Sites
from mound.jsonio import load_json

if TYPE_CHECKING:
    from mound.recon.visit_value import Confusion

Reward = Callable[[np.ndarray], np.ndarray]


def read_confusion(path: str) -> Confusion:
    """The confusion a model or a report holds (InputError naming the file when neither)."""
    from mound.recon import visit_value as vv

    doc = load_json(path)
    if not isinstance(doc, dict):
        raise InputError(f"{path}: expected a verdict model or an eval-verdict report")
    if doc.get("schema") == "mound.verdict_model":
        return vv.Confusion.from_model(doc, path)
    return vv.Confusion.from_report(doc, path)


def kazanlak_mix() -> dict[str, float]:
    """How many of the Kazanlak inventory's tumuli fall in each height class."""
    from mound.recon import visit_value as vv
    from mound.sim.population import population_path, read_population

    mix: dict[str, float] = {}
    for row in read_population(str(population_path("kazanlak"))).rows:
        c = vv.height_class(float(row.height_m))
        mix[c] = mix.get(c, 0.0) + 1.0
    return mix


def reward_of(kind: str, confusion: str | None) -> Reward:
    """The reward of a site of p(mound) p, as a function of p."""
    if kind == "entropy":
        return binary_entropy_bits
    if kind != "value":
        raise InputError(f"--reward: expected entropy or value, got {kind!r:.40}")
    if confusion is None:
        raise InputError("--reward value: needs --confusion (a verdict model with "
                         "trained.confusion, or an eval-verdict report)")
    from mound.recon import visit_value as vv

    conf = read_confusion(confusion)
    tumulus = conf.tumulus_mean(kazanlak_mix())
    # a visit that can only add a false alarm on average (p tiny) is worth nothing
    return lambda p: np.maximum(vv.visit_value(np.asarray(p, dtype=float), tumulus,
                                               conf.none), 0.0)


def with_rewards(sites: Sites, reward: Reward, kind: str) -> Sites:
    """Every site's reward from its p_mound by `reward` (the provenance's total too)."""
    missing = next((s.id for s in sites.sites if s.p_mound is None), None)
    if missing is not None:
        raise InputError(f"sites: {missing}.p_mound: missing (the reward is computed from it)")
    p = np.array([s.p_mound for s in sites.sites], dtype=float)
    r = reward(p)
    prov = dict(sites.extra.get("provenance", {}))
    return sites.with_sites([replace(s, reward=float(v)) for s, v in zip(sites.sites, r,
                                                                         strict=True)],
                            provenance={**prov, "total_reward": float(r.sum()),
                                        "reward": kind})


def describe(kind: str) -> str:
    return "bits" if kind == "entropy" else "expected wrong labels settled"


def confusion_digest(path: str | None) -> str | None:
    from mound.datasets import sha256_of

    return sha256_of(Path(path)) if path else None
