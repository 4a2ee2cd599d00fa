"""A candidate site as the survey's summary (summary.json, mound.survey v1) reports it.

`SurveySite` joins the candidate (its position, the classifier's p(mound) and reward, the
truth where known) with, when the tour visited it, its 3-D work's row (`SiteRow`), and
says what the survey concluded: the classifier's label, the verdict (its two answers, or
failed), the verdict's own answer (mound, no_mound or undecided) and the final label with
its source. `to_doc()` is summary.json's `sites[k]`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from mound.classify.metrics import says_mound
from mound.errors import InputError
from mound.formats.site_row import SiteRow
from mound.formats.sites import Site
from mound.formats.verdict import Verdict
from mound.jsonio import JsonObject

# What a site's entry copies of its row (SiteRow.to_doc()) when the site was judged, and
# in any case (the 3-D work's figures and files).
JUDGED_KEYS = ("answer", "undecided", "confidence", "verdict_p_mound", "verdict_cloud",
               "coverage", "method", "reason", "rise", "distance_m", "second_look",
               "first_look", "rasters_error", "dense_error")
WORK_KEYS = ("recon", "timings_s", "files", "source", "simulated", "worker")


@dataclass(frozen=True)
class SurveySite:
    """A candidate site, and (visited) its 3-D work's row (None: not processed)."""

    site: Site
    visited: bool
    row: SiteRow | None = None

    def __post_init__(self) -> None:
        if self.site.p_mound is None:
            raise InputError(f"sites: {self.site.id}: no p_mound (the survey's sites carry "
                             "the classifier's)")

    @property
    def id(self) -> str:
        return self.site.id

    @property
    def p_mound(self) -> float:
        assert self.site.p_mound is not None  # __post_init__
        return self.site.p_mound

    @property
    def truth(self) -> bool | None:
        return None if self.site.truth is None else self.site.truth.mound

    @property
    def classifier_label(self) -> str:
        return "mound" if says_mound(self.p_mound) else "no_mound"

    @property
    def judged_verdict(self) -> Verdict | None:
        """Its 3-D verdict, where it was visited and the verdict stands (None otherwise)."""
        row = self.row
        return row.verdict if self.visited and row is not None and row.ok else None

    @property
    def judged(self) -> bool:
        """Visited, and its 3-D verdict stands."""
        return self.judged_verdict is not None

    @property
    def verdict(self) -> str | None:
        """The 3-D verdict's two answers, `failed` (visited, no verdict), None (not
        visited)."""
        v = self.judged_verdict
        return v.two_answer if v is not None else "failed" if self.visited else None

    @property
    def answer(self) -> str | None:
        """The verdict's own answer (mound, no_mound or undecided); None without one."""
        v = self.judged_verdict
        return v.label if v is not None else None

    @property
    def final_label(self) -> str:
        return self.verdict if self.judged and self.verdict else self.classifier_label

    @property
    def label_source(self) -> str:
        if self.judged:
            return "3-D verdict"
        return "classifier (3-D stage failed)" if self.visited else "classifier"

    def undecided_reasons(self) -> list[Mapping[str, object]]:
        """The verdict's reasons for leaving the site undecided (code, text)."""
        v = self.judged_verdict
        reasons = (v.undecided or {}).get("reasons", []) if v is not None else []
        return [r for r in reasons if isinstance(r, dict)] if isinstance(reasons, list) else []

    def to_doc(self) -> JsonObject:
        s = self.site
        doc: JsonObject = {"id": s.id, "x_m": s.x_m, "y_m": s.y_m,
                           "p_mound": self.p_mound, "reward": s.reward,
                           "visited": self.visited}
        if self.truth is not None:
            doc["truth"] = self.truth
        doc["classifier_label"] = self.classifier_label
        if not self.visited:
            return {**doc, "final_label": self.final_label, "label_source": self.label_source}
        row = self.row or SiteRow(s.id, "", reason="not processed")
        result = row.to_doc()
        doc["verdict"] = self.verdict
        if self.judged:
            doc.update(final_label=self.final_label, label_source=self.label_source)
            doc.update({k: result[k] for k in JUDGED_KEYS if k in result})
        else:
            doc.update(failure=row.reason or "?", final_label=self.final_label,
                       label_source=self.label_source)
        doc.update({k: result[k] for k in WORK_KEYS if k in result})
        return doc
