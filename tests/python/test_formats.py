"""The typed documents (mound.formats, issue 57): what the tools write is read and written
back unchanged; a document that lacks what a use needs says so, naming the field."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from mound import native
from mound.classify import coarse, statlog
from mound.errors import InputError
from mound.formats.plan import Plan
from mound.formats.site_row import SiteRow
from mound.formats.sites import Sites
from mound.formats.verdict import Verdict
from mound.geometry.flight import scan_for_site
from mound.jsonio import json_text
from mound.paths import REPO_ROOT
from mound.plan.field import make_field, sites_document


def _same(a: object, b: object, where: str = "") -> None:
    """Equal documents, numbers to 1e-9 relative (a sum recomputed in another order)."""
    if isinstance(a, dict) and isinstance(b, dict):
        assert set(a) == set(b), (where, set(a) ^ set(b))
        for k in a:
            _same(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, list) and isinstance(b, list):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _same(x, y, f"{where}[{i}]")
    elif isinstance(a, float) or isinstance(b, float):
        assert a == pytest.approx(b, rel=1e-9, abs=1e-9), where
    else:
        assert a == b, where


@pytest.mark.slow
@pytest.mark.parametrize("flights", [1, 3])
def test_mound_plan_s_plans_are_read_and_written_back_unchanged(tmp_path: Path,
                                                                flights: int) -> None:
    out = tmp_path / "plan.json"
    native.run_tool("mound_plan", [str(REPO_ROOT / "data" / "sites.json"), "--flights",
                                   str(flights), "--out", str(out)])
    doc = json.loads(out.read_text())
    plan = Plan.read(out)
    assert len(plan.flights) == flights and plan.reward == pytest.approx(doc["reward"])
    assert plan.visit_order() == list(dict.fromkeys(
        s for f in doc["flights"] for s in f["tour"][1:-1]))
    _same(json.loads(json_text(plan.to_doc())), doc)


def test_a_plan_written_by_hand_says_what_it_lacks() -> None:
    doc = {"schema": "mound.plan", "version": 1, "tour": ["home", "a", "home"],
           "budget_m": 100.0}
    plan = Plan.from_doc(doc, "hand.json")
    assert plan.visited() == {"a"} and plan.closed
    with pytest.raises(InputError, match=r"flights\[0\]\.reward: missing"):
        _ = plan.reward
    with pytest.raises(InputError, match=r"hand.json: tour: a site visited twice"):
        Plan.from_doc({**doc, "tour": ["home", "a", "a", "home"]}, "hand.json")
    with pytest.raises(InputError, match=r"hand.json: status: 'failed'"):
        Plan.from_doc({**doc, "status": "failed"}, "hand.json")


@pytest.mark.slow
def test_the_standard_field_is_read_back_as_written() -> None:
    test = statlog.load("sat.tst")
    model = coarse.train(statlog.load("sat.trn"), coarse.DEFAULT_BAND)
    sites = sites_document(make_field(test, 0), test, model, None, 14_400.0,
                           spacing_m=250.0, scan=scan_for_site(60.0, "raster"))
    doc = json.loads(json_text(sites.to_doc()))
    assert Sites.from_doc(doc, "field.json") == sites
    assert sum(1 for s in sites.sites if s.truth and s.truth.mound) == \
        doc["provenance"]["positives"]
    doc["sites"][3]["id"] = doc["sites"][1]["id"]
    with pytest.raises(InputError, match="field.json: sites: ids are not unique"):
        Sites.from_doc(doc, "field.json")
    doc["sites"][3]["id"] = "s004"
    doc["sites"][5]["truth"]["statlog_row"] = -1
    with pytest.raises(InputError, match=r"sites\[5\]\.truth\.statlog_row"):
        Sites.from_doc(doc, "field.json")


def test_a_row_carries_its_verdict_and_its_first_look() -> None:
    verdict = Verdict.from_doc({
        "schema": "mound.verdict", "version": 1, "label": "undecided",
        "two_answer": {"label": "mound"}, "confidence": 0.55, "p_mound": 0.55,
        "method": "reference_free_model", "reason": "r",
        "undecided": {"reasons": [], "next": "second_look"},
        "second_look": {"advised": True, "scan_factor": 2.0, "p_low": 0.2}}, "v.json")
    assert verdict.second_look is not None and verdict.second_look.scan_factor == 2.0
    row = SiteRow("s1", "k", status="ok", verdict=verdict, first_look=verdict,
                  files={"images": "x"}, extra={"recon": {"points": 3}})
    doc = row.to_doc()
    assert doc["verdict"] == "mound" and doc["answer"] == "undecided"
    assert doc["first_look"]["verdict_p_mound"] == 0.55 and "method" not in doc["first_look"]
    back = SiteRow.from_doc(json.loads(json_text(doc)), "row.json")
    assert back.verdict is not None and back.verdict.label == "undecided"
    assert back.to_doc() == doc
    with pytest.raises(InputError, match=r"v.json: two_answer.label"):
        Verdict.from_doc({"schema": "mound.verdict", "version": 1, "label": "undecided"},
                         "v.json")
    with pytest.raises(InputError, match=r"v.json: second_look.scan_factor: missing"):
        Verdict.from_doc({"schema": "mound.verdict", "version": 1, "label": "mound",
                          "second_look": {"advised": True}}, "v.json")


def test_a_user_s_sites_are_typed_and_an_end_id_is_not_coerced(tmp_path: Path) -> None:
    """The --sites reader builds the typed sites directly: the user's file's sites, costed
    by the scan, read back equal; an end whose id is not a string is refused (until
    2026-11-28 it was turned into one: an end id {} became "{}")."""
    from mound.formats.sites import user_sites
    from mound.geometry.flight import ScanSpec

    doc = {"schema": "mound.sites", "version": 1,
           "origin": {"lat": 38.57, "lon": 27.98, "alt_m": 95.0},
           "home": {"id": "home", "x_m": 0, "y_m": 0}, "end": {"id": "e", "x_m": 9, "y_m": 4},
           "sites": [{"id": "a", "x_m": 300, "y_m": 0, "p_mound": 0.3,
                      "truth": {"mound": True, "height_m": 4}}]}
    scan = ScanSpec()
    sites = user_sites(doc, Path("s.json"), scan, 900.0, 1.0, need_truth=True)
    assert sites.end.id == "e" and not sites.closed and sites.budget_m == 900.0
    a = sites.sites[0]
    assert a.scan_cost_m == scan.site_cost_m() and a.truth is not None
    assert a.truth.height_m == 4.0 and a.reward == pytest.approx(0.8812908992306927)
    assert Sites.from_doc(json.loads(json_text(sites.to_doc())), "again") == sites
    for bad in (0, {}, None):
        with pytest.raises(InputError, match=r"s.json: end.id: expected a string"):
            user_sites({**doc, "end": {"id": bad, "x_m": 9, "y_m": 4}}, Path("s.json"), scan,
                       900.0, 1.0, need_truth=True)
