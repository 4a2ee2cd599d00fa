"""Property-based fuzzing (Hypothesis) of the Python readers of outside files: the user's
sites (mound.sites and GeoJSON), plans (mission build), QGroundControl .plan and WPL
missions, the Statlog data, the thresholds of a verdict-bound report; and the run's own
files read back (learn.json, a photo card's photos.json, mission.json, site rows, the
survey's ledger). From a valid file, Hypothesis replaces or deletes a value anywhere in it
(with huge or non-finite numbers, wrong types, deep nesting, control characters) or
splices random bytes into its text; every reader must answer with a value or an
InputError (the commands' exit 2), never another exception (exit 1).

(The camera and GPS files of the 3-D stage are read by mound_recon, fuzzed with libFuzzer:
cpp/recon/inputs_fuzz.cc.) CI runs MOUND_FUZZ_EXAMPLES (default 150) examples per reader
with a fixed seed; `make fuzz` runs 20,000 each with fresh randomness.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mound.classify import statlog
from mound.errors import InputError
from mound.formats.grid import GridRow
from mound.formats.learn import Change, Example, FlightLearned, LearnRecord
from mound.formats.mission import (
    ClearanceSpec,
    FlightTerrain,
    FormatEntry,
    MissionSummary,
    Refusal,
    SecondLookMissions,
    TerrainLeg,
    UploadRecord,
)
from mound.formats.photos import CardSite, CardSummary
from mound.formats.plan import Plan
from mound.formats.recon import Recon
from mound.formats.site_row import SiteRow
from mound.formats.sites import Sites, load_user_sites
from mound.formats.survey import SITE_ANSWERS, STATUSES, SurveyAnswers
from mound.formats.verdict import Verdict, VerdictFile
from mound.geometry.flight import scan_for_site
from mound.geometry.geodesy import Origin
from mound.jsonio import json_text
from mound.survey.ledger import Ledger, StageRecord
from mound.uav import files as mission_files
from mound.uav import mission, mission_items


def build_mission(plan: dict, *args: Any) -> Any:
    """mission.build of a plan document (the tests keep their plans as dicts)."""
    return mission.build(Plan.from_doc(plan, "test plan"), *args)


EXAMPLES = int(os.environ.get("MOUND_FUZZ_EXAMPLES", "150"))
FRESH = os.environ.get("MOUND_FUZZ_FRESH") == "1"  # make fuzz: new randomness each run
FUZZ = settings(max_examples=EXAMPLES, deadline=None, derandomize=not FRESH,
                suppress_health_check=list(HealthCheck), database=None)
WORK = Path(tempfile.mkdtemp(prefix="mound_fuzz_readers."))
ORIGIN = Origin(38.5705, 27.9862, 95.0)
SCAN = scan_for_site(60.0, "raster")

NASTY_NUMBERS = st.sampled_from([0, -1, 1e155, -1e300, 10**30, 10**400, 2**63, 1e-320,
                                 math.inf, -math.inf, math.nan, 3.5e38, 91, -181])
LEAVES = (st.none() | st.booleans() | NASTY_NUMBERS | st.integers() | st.floats()
          | st.text(max_size=12) | st.just("") | st.just("\x00\n\ud7ff") | st.just("a" * 300))
VALUES = st.recursive(LEAVES, lambda inner: st.lists(inner, max_size=3)
                      | st.dictionaries(st.text(max_size=8), inner, max_size=3), max_leaves=8)
DEEP = st.integers(1, 5000).map(lambda n: json.loads("[" * min(n, 400) + "]" * min(n, 400)))


def _paths(doc: Any, prefix: tuple = (), depth: int = 0) -> list[tuple]:
    """Every path into doc, to a depth of 12: a strategy must not recurse into the 400-deep
    values it may have drawn (the Python stack depth differs between Hypothesis's
    generation and replay, so a RecursionError there makes the data generation flaky)."""
    out = [prefix]
    if depth >= 12:
        return out
    if isinstance(doc, dict):
        for k, v in doc.items():
            out += _paths(v, (*prefix, k), depth + 1)
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            out += _paths(v, (*prefix, i), depth + 1)
    return out


@st.composite
def mutated_json(draw: st.DrawFn, base: dict[str, Any]) -> str:
    """`base` with one to three values replaced or deleted, then maybe bytes spliced in."""
    doc = json.loads(json.dumps(base))
    for _ in range(draw(st.integers(1, 3))):
        paths = [p for p in _paths(doc) if p]
        if not paths:
            break
        path = draw(st.sampled_from(paths))
        parent = doc
        for key in path[:-1]:
            parent = parent[key]
        if draw(st.booleans()) and isinstance(parent, dict):
            del parent[path[-1]]
        else:
            parent[path[-1]] = draw(VALUES | DEEP)
    text = json.dumps(doc, allow_nan=True)
    return draw(spliced(text))


@st.composite
def spliced(draw: st.DrawFn, text: str) -> str:
    """The text, or the text with a random piece replaced by random characters or bytes."""
    if draw(st.integers(0, 3)) != 0 or not text:
        return text
    at = draw(st.integers(0, len(text)))
    cut = draw(st.integers(0, 8))
    piece = draw(st.text(max_size=8) | st.binary(max_size=6).map(
        lambda b: b.decode("latin-1")))
    return text[:at] + piece + text[at + cut:]


def _file(text: str | bytes, name: str) -> Path:
    path = WORK / name
    if isinstance(text, str):
        text = text.encode("utf-8", "surrogatepass")
    path.write_bytes(text)
    return path


def value_or_input_error(fn: Any, *args: Any, check: Any = None) -> None:
    """A clear error (InputError, one line) or a correct result: `check` (when given) is
    asserted on the value read."""
    try:
        value = fn(*args)
    except InputError as e:
        assert str(e) and "\n" not in str(e), repr(str(e))
        return
    if check is not None:
        check(value)


def _valid_sites(sites: Sites) -> None:
    """What the survey may rely on in the sites the reader accepted."""
    assert math.isfinite(sites.budget_m) and sites.budget_m > 0
    ids = [s.id for s in sites.sites]
    assert sites.sites and len(set(ids)) == len(ids) and sites.home.id not in ids
    for s in sites.sites:
        assert isinstance(s.id, str) and s.id.strip()
        assert math.isfinite(s.x_m) and math.isfinite(s.y_m)
        assert math.isfinite(s.reward) and s.reward >= 0
        assert s.p_mound is not None and 0 <= s.p_mound <= 1
        assert s.scan_cost_m == SCAN.site_cost_m()
    assert sites.origin is not None
    assert -90 <= sites.origin.lat_deg <= 90 and -180 <= sites.origin.lon_deg <= 180
    # what is written is read back as it was
    assert Sites.from_doc(json.loads(json_text(sites.to_doc())), "again") == sites


SITES = {"schema": "mound.sites", "version": 1, "origin": ORIGIN.to_doc(),
         "home": {"id": "home", "x_m": 0, "y_m": 0}, "budget_m": 9000,
         "sites": [{"id": "a", "x_m": 300, "y_m": 0, "p_mound": 0.3, "reward": 0.88,
                    "truth": {"mound": False}},
                   {"id": "b", "x_m": 0, "y_m": 400, "p_mound": 0.7, "truth": True}]}
GEOJSON = {"type": "FeatureCollection", "budget_m": 9000, "features": [
    {"type": "Feature", "properties": {"kind": "home", "alt_m": 95},
     "geometry": {"type": "Point", "coordinates": [27.9862, 38.5705]}},
    {"type": "Feature", "id": "T17", "properties": {"p_mound": 0.62, "truth": True},
     "geometry": {"type": "Point", "coordinates": [27.9919, 38.5711]}}]}


@FUZZ
@given(st.one_of(mutated_json(SITES), mutated_json(GEOJSON)))
def test_sites_reader(text: str) -> None:
    path = _file(text, "sites.json")
    value_or_input_error(load_user_sites, path, SCAN, None, 14400.0, False,
                         check=_valid_sites)


PLAN = {"schema": "mound.plan", "version": 1, "tour": ["home", "a", "b", "home"],
        "closed": True, "budget_m": 1e7, "origin": ORIGIN.to_doc(),
        "scan": SCAN.to_doc() if hasattr(SCAN, "to_doc") else None,
        "waypoints": [{"id": "home", "x_m": 0.0, "y_m": 0.0, "kind": "home"},
                      {"id": "a", "x_m": 300.0, "y_m": 0.0, "kind": "site", "scan_cost_m": 400},
                      {"id": "b", "x_m": 300.0, "y_m": 300.0, "kind": "site"}]}


def _mission_build(path: Path) -> None:

    plan = Plan.read(path)
    if plan.origin is None:
        raise InputError(f"{path}: origin: missing")
    m = mission.build(plan, plan.origin, mission_items.MissionSpec(scan=SCAN))
    # a mission built is one that can be flown: within its budget, every item a place
    assert m.flight_distance_m <= m.budget_m * (1 + m.spec.budget_slack) + 1e-6
    for item in m.items:
        assert abs(item.x) <= 90e7 and abs(item.y) <= 180e7 and item.z == item.z


@FUZZ
@given(mutated_json(PLAN))
def test_plan_reader_and_mission_build(text: str) -> None:
    value_or_input_error(_mission_build, _file(text, "plan.json"))


def _valid_plan(plan: Plan) -> None:
    """What the survey may rely on in a plan the reader accepted, and that it is written
    back as read."""
    assert plan.flights and plan.budget_m >= 0 and math.isfinite(plan.budget_m)
    for f in plan.flights:
        assert len(f.tour) >= 2 and len(set(f.sites)) == len(f.sites)
        assert (f.tour[0], f.tour[-1]) == (plan.home, plan.end)
    assert Plan.from_doc(json.loads(json_text(plan.to_doc())), "again") == plan


MADE_PLAN = {**PLAN, "status": "ok", "algo": "alns", "reward": 1.5, "cost_m": 2000.0,
             "budget_left_m": 9.998e6,
             "flights": [{"flight": 1, "tour": ["home", "a", "b", "home"], "reward": 1.5,
                          "cost_m": 2000.0, "budget_left_m": 9.998e6}]}


@FUZZ
@given(st.one_of(mutated_json(PLAN), mutated_json(MADE_PLAN)))
def test_typed_plan_reader(text: str) -> None:
    value_or_input_error(Plan.read, _file(text, "plan.json"), check=_valid_plan)


VERDICT = {"schema": "mound.verdict", "version": 1, "status": "ok", "label": "undecided",
           "two_answer": {"label": "no_mound", "threshold": 0.78}, "confidence": 0.6,
           "p_mound": 0.4, "method": "reference_free_model", "reason": "why",
           "undecided": {"reasons": [{"code": "cut", "text": "t"}], "next": "second_look"},
           "second_look": {"advised": True, "p_low": 0.2, "scan_factor": 2.0},
           "measurements": {"rise": {"height_m": 1.2, "base_diameter_m": 20.0,
                                     "centre_enu_m": [1.0, 2.0]}}}
SITE_ROW = {"schema": "mound.survey_site", "version": 1, "id": "s1", "key": "k",
            "first_key": "f", "status": "ok", "source": "simulated", "worker": "h:1",
            "timings_s": {"total": 3.5}, "verdict": "mound", "answer": "mound",
            "confidence": 0.9, "verdict_p_mound": 0.9, "method": "m", "reason": "r",
            "rise": {"height_m": 2.0}, "verdict_cloud": "dense",
            "files": {"images": "sites/s1/sim/images"}, "recon": {"points": 10},
            "first_look": {"verdict": "no_mound", "answer": "undecided",
                           "verdict_p_mound": 0.5, "reason": "first"},
            "second_look": {"advised": True, "flown": True, "p_mound": 0.9}}


def _valid_verdict(v: Verdict) -> None:
    assert v.label in ("mound", "no_mound", "undecided")
    assert v.two_answer in ("mound", "no_mound")
    for p in (v.confidence, v.p_mound):
        assert p is None or 0 <= p <= 1
    if v.second_look is not None and v.second_look.advised:
        assert v.second_look.scan_factor is not None and v.second_look.scan_factor >= 1


def _valid_row(row: SiteRow) -> None:
    assert row.status in ("ok", "failed") and row.id
    if row.verdict is not None:
        _valid_verdict(row.verdict)
    assert all(t >= 0 and math.isfinite(t) for t in row.timings_s.values())
    assert SiteRow.from_doc(json.loads(json_text(row.to_doc())), "again") == row


@FUZZ
@given(mutated_json(VERDICT))
def test_typed_verdict_reader(text: str) -> None:
    value_or_input_error(Verdict.read, _file(text, "verdict.json"), check=_valid_verdict)


@FUZZ
@given(mutated_json(SITE_ROW))
def test_typed_site_row_reader(text: str) -> None:
    value_or_input_error(SiteRow.read, _file(text, "site_result.json"), check=_valid_row)


GRID_ROW = {"dir": "0000", "status": "ok", "times": {"simulate": 1.5, "verdict": 0.25},
            "p_mound": 0.8, "second": {"status": "failed", "times": {}, "reason": "few images"},
            "truth": {"mound": True, "kind": "tumulus", "profile": "conical", "height_m": 3.0,
                      "diameter_m": 20.0, "centre_enu_m": [1.0, -2.0], "pit": False,
                      "trench": True},
            "spec": {"terrain": {"seed": 4, "mound": True}}}
GRID_VERDICT = {"schema": "mound.verdict", "version": 1, "status": "ok", "label": "mound",
                "method": "reference_free_model", "p_mound": 0.8, "look": "first",
                "cloud": "dense/dense.ply", "coverage": {"status": "clipped"},
                "grid_times_s": {"simulate": 1.5, "verdict": 0.25},
                "measurements": {
                    "site_centre_enu_m": [0.5, 0.5], "site_radius_m": 30.0,
                    "candidates": "local_relief", "cell_m": 0.5,
                    "ground_coefficients": [100.0, 0.01, -0.02, 0.0, 0.001, 0.0],
                    "terrain": {"site_slope_rad": 0.05},
                    "rise": {"height_m": 2.5, "base_diameter_m": 18.0, "roundness": 0.8,
                             "dome_r2": 0.9, "centre_enu_m": [1.0, -1.5],
                             "ground_plane": [100.0, 0.01, 0.0],
                             "ground_curvature": [-0.002, 0.0, -0.001]},
                    "judged_rises": [{"centre_enu_m": [1.0, -1.5], "base_diameter_m": 18.0,
                                      "features": {"a": 1.5, "b": -2}}]}}


def _valid_grid_site(sites: list[Any]) -> None:
    """What training and evaluation rely on in a grid site the reader accepted: the
    values of the files, as numbers of their ranges."""
    (s,) = sites
    t = s.truth
    assert isinstance(t.mound, bool) and t.height_m >= 0 and t.diameter_m >= 0
    assert all(math.isfinite(v) for v in t.centre_enu_m)
    for r in s.rises + (s.rise,) * (s.rise is not None):
        assert all(isinstance(v, float) and math.isfinite(v) for v in r.features.values())
        assert r.centre_enu_m is None or all(math.isfinite(v) for v in r.centre_enu_m)
    assert s.site_radius_m is None or s.site_radius_m >= 0
    assert s.cloud in ("dense", "sparse") and s.measured is True
    assert s.candidates in ("site_ground", "local_relief")


def _read_grid(row_text: str, verdict_text: str) -> list[Any]:
    from mound.training.verdict_data import load_grid

    root = WORK / "grid"
    (root / "0000").mkdir(parents=True, exist_ok=True)
    try:
        row = json.loads(row_text)
    except ValueError:
        row = row_text
    (root / "grid.json").write_text(json.dumps({"schema": "mound.verdict_grid", "version": 1,
                                                "rows": [row]}))
    _file(verdict_text, "grid/0000/verdict.json")
    return load_grid(root)


@FUZZ
@given(mutated_json(GRID_ROW), mutated_json(GRID_VERDICT))
def test_grid_site_reader(row: str, verdict: str) -> None:
    """A grid's row and its site's verdict.json, mutated: a clear error, or a site whose
    truth, rises and disc are the numbers the files hold."""
    value_or_input_error(_read_grid, row, verdict,
                         check=lambda s: _valid_grid_site(s) if s[0].measured else None)


def _valid_verdict_file(v: VerdictFile) -> None:
    """What the grids, the training, the map and the figures rely on in a verdict file."""
    assert v.status in ("ok", "failed") and (v.verdict is not None) == v.ok
    if v.verdict is not None:
        _valid_verdict(v.verdict)
    assert v.look in ("first", "second") and v.cloud_kind in ("dense", "sparse")
    assert all(math.isfinite(t) for t in v.grid_times_s.values())
    m = v.measurements
    if m is not None:
        assert m.candidates in ("site_ground", "local_relief")
        assert m.ground_coefficients is None or len(m.ground_coefficients) == 6
        assert m.site_radius_m is None or m.site_radius_m >= 0
        for r in m.judged_rises + (m.rise,) * (m.rise is not None):
            assert r.ground_plane is None or len(r.ground_plane) == 3
            assert all(math.isfinite(x) for x in r.features.values())


@FUZZ
@given(mutated_json(GRID_VERDICT))
def test_verdict_file_reader(text: str) -> None:
    value_or_input_error(VerdictFile.read, _file(text, "verdict.json"),
                         check=_valid_verdict_file)


RECON = {"schema": "mound.recon", "version": 1, "status": "ok", "frame": "enu",
         "scale": "metric", "images_dir": "images",
         "origin": {"lat": 38.57, "lon": 27.98, "alt_m": 120.0, "alt_datum": "egm96"},
         "inputs": {"gps_source": "exif"},
         "camera": {"width": 640, "height": 480, "K": [[500, 0, 320], [0, 500, 240], [0, 0, 1]],
                    "dist_k1k2p1p2k3": [0.01, 0, 0, 0, 0]},
         "images": [{"file": "a.jpg", "registered": True,
                     "cam_from_world": {"R": [[1, 0, 0], [0, -1, 0], [0, 0, -1]],
                                        "t": [0.0, 0.0, 50.0]},
                     "centre": [0.0, 0.0, 50.0]},
                    {"file": "b.jpg", "registered": False}],
         "points": 1200, "reprojection_rmse_px": 0.6}


def _valid_recon(r: Recon) -> None:
    assert r.status in ("ok", "failed")
    json_text(r.summary())
    for _, pose, c in r.poses():
        assert pose.R.shape == (3, 3) and pose.t.shape == (3,) and c.shape == (3,)
        assert np.isfinite(pose.R).all() and np.isfinite(c).all()
    if r.camera is not None:
        assert r.camera.width_px > 0 and np.isfinite(r.camera.K).all()


@FUZZ
@given(mutated_json(RECON))
def test_recon_reader(text: str) -> None:
    value_or_input_error(Recon.read, _file(text, "recon.json"), check=_valid_recon)


def _mission_summary() -> dict[str, Any]:
    """A mission.json of one flight over a (made-up) DEM with one refused format, the
    upload's record and the second looks'."""
    m = build_mission(json.loads(json.dumps({**PLAN, "scan": None})), ORIGIN,
                      mission_items.MissionSpec(scan=SCAN))
    legs = (TerrainLeg("home", "s1", 180.0, 140.0, (10.0, 20.0), 40.0, 90.0),)
    terrain = FlightTerrain("dem.tif", "EPSG:32635", 95.0, ClearanceSpec(), 1500.0, 85.0,
                            85.0, 1450.0, legs)
    flight = replace(m.summary(), terrain=terrain, flight=1, file="mission.plan",
                     formats={"qgc_plan": FormatEntry({"firmware": "px4"}, ("mission.plan",)),
                              "dji_kmz": FormatEntry({"aircraft": "m3e"},
                                                     refused="too many waypoints")})
    upload = UploadRecord("udpout:127.0.0.1:14550", "mission.plan", 40, 1, 0.5, 0, 0, True,
                          ("ok",))
    second = SecondLookMissions(("s1", "s2"), 2.0, 120.0, ("s1",),
                                (Refusal("s2", "over the budget"),))
    return MissionSummary((flight,), flight.budget_m, None, upload, second).to_doc()


MISSION_SUMMARY = _mission_summary()


def _valid_mission_summary(s: MissionSummary) -> None:
    """The typed value writes back the same document (read again, equal)."""
    assert MissionSummary.from_doc(json.loads(json_text(s.to_doc())), "again") == s
    for f in s.flights:
        assert f.items >= 0 and f.flight_distance_m >= 0
        if f.terrain is not None:
            assert f.terrain.lowest_clearance_m is None or math.isfinite(
                f.terrain.lowest_clearance_m)


@FUZZ
@given(mutated_json(MISSION_SUMMARY))
def test_mission_summary_reader(text: str) -> None:
    value_or_input_error(MissionSummary.read, _file(text, "mission.json"),
                         check=_valid_mission_summary)


LEARN = LearnRecord(
    2.0, 0.91, 0.93, 1900, "sat.tst without the field's rows",
    (FlightLearned(1, ["s1", "s2"], 3.5, ["s1", "s2", "s3"], 1480.0, "flown",
                   [Example("s1", "mound", 0.97), Example("s2", "no_mound", 0.88)], 0.92, 3,
                   [Change("s3", 0.40, 0.61), Change("s4", 0.52, 0.47)]),),
    "battery 2: its missions are in battery_2/", 2).to_doc()
PHOTO_CARD = {"schema": "mound.photos", "version": 1, "card": "/cards/DJI_001",
              "counts": {"site": 40, "transit": 12, "blurred": 2},
              "sites": {"s1": CardSite(40, 2, 812.5, "ok", {
                  "source": "exif (focal_35mm)", "make": "DJI", "model": "FC3582",
                  "focal_px": 2940.1, "mixed": False}).to_doc()},
              "skipped_folders": ["MISC: Permission denied"]}


def _valid_learn(r: LearnRecord) -> None:
    """The typed value writes back the same document (read again, equal)."""
    again = LearnRecord.from_doc(json.loads(json_text(r.to_doc())), "again")
    assert again.to_doc() == r.to_doc()
    assert all(0 <= f.held_out_auc <= 1 and f.max_abs_dp <= 1 for f in r.flights)


def _valid_card(c: CardSummary) -> None:
    doc = {"schema": "mound.photos", "version": 1, **c.to_doc()}
    assert CardSummary.from_card(json.loads(json_text(doc)), "again", c.file) == c
    assert all(v.photos >= 0 and v.status in ("ok", "too_few_photos") for v in c.sites.values())


@FUZZ
@given(mutated_json(LEARN))
def test_learn_record_reader(text: str) -> None:
    value_or_input_error(LearnRecord.read, _file(text, "learn.json"), check=_valid_learn)


@FUZZ
@given(mutated_json(PHOTO_CARD))
def test_photo_card_summary_reader(text: str) -> None:
    value_or_input_error(lambda p: CardSummary.read(p, "photos/photos.json"),
                         _file(text, "photos.json"), check=_valid_card)


# summary.json as `mound day` reads it back (the other members are left to the report)
SUMMARY = {"schema": "mound.survey", "version": 1, "status": "partial", "options": {},
           "sites": [{"id": "s01", "visited": True, "verdict": "mound", "answer": "undecided"},
                     {"id": "s02", "visited": True, "verdict": "failed"},
                     {"id": "s03", "visited": False, "final_label": "no_mound"}]}


def _valid_answers(a: SurveyAnswers) -> None:
    assert a.status in STATUSES
    assert all(v is None or v in SITE_ANSWERS for v in a.answers.values())


@FUZZ
@given(mutated_json(SUMMARY))
def test_survey_answers_reader(text: str) -> None:
    value_or_input_error(SurveyAnswers.read, _file(text, "summary.json"), check=_valid_answers)


LEDGER = {"schema": "mound.survey_ledger", "version": 1, "stages": {
    "classify": StageRecord("classify", "a" * 64, 1.5, ("model.json", "classifier.json"),
                            "band 1", "2026-11-30T18:00:00Z").to_doc(),
    "plan": StageRecord("plan", "b" * 64, 0.2, ("plan.json",)).to_doc()}}


@FUZZ
@given(mutated_json(LEDGER))
def test_survey_ledger_reader(text: str) -> None:
    """A damaged ledger costs a rerun of its damaged stages, never an error past the
    file's own (not JSON: InputError)."""
    path = _file(text, "stages.json")
    try:
        ledger = Ledger(path)
    except InputError as e:
        assert str(e) and "\n" not in str(e)
        return
    for name, rec in ledger.done.items():
        assert rec.name == name and isinstance(rec.key, str) and math.isfinite(rec.wall_s)
        assert all(isinstance(o, str) for o in rec.outputs)
        ledger.is_done(name, rec.key)


def _mission_texts() -> tuple[str, str]:
    m = build_mission(json.loads(json.dumps({**PLAN, "scan": None})), ORIGIN,
                            mission_items.MissionSpec(scan=SCAN))
    return mission_files.plan_text(m), mission_files.wpl_text(m)


QGC_PLAN, WPL = _mission_texts()


@FUZZ
@given(mutated_json(json.loads(QGC_PLAN)))
def test_qgc_plan_reader(text: str) -> None:
    value_or_input_error(mission_files.read_mission, _file(text, "m.plan"))


@st.composite
def mutated_lines(draw: st.DrawFn, text: str, sep: str) -> str:
    """A line-and-field file with fields replaced by nasty tokens, lines dropped or
    duplicated, then maybe bytes spliced in."""
    lines = text.splitlines()
    for _ in range(draw(st.integers(1, 3))):
        k = draw(st.integers(0, len(lines) - 1))
        fields = lines[k].split(sep)
        op = draw(st.integers(0, 3))
        if op == 0:
            i = draw(st.integers(0, len(fields) - 1))
            fields[i] = draw(st.sampled_from(["inf", "nan", "-5", "--5", "1e400", "1e20", "x",
                                              "", "9" * 30, "9" * 5000, "0x10", "١٢"])
                             | st.text(max_size=6))
            lines[k] = sep.join(fields)
        elif op == 1:
            del lines[k]
        elif op == 2:
            lines.insert(k, lines[k])
        else:
            lines[k] = sep.join(fields[:draw(st.integers(0, len(fields)))])
    return draw(spliced("\n".join(lines) + "\n"))


@FUZZ
@given(mutated_lines(WPL, "\t"))
def test_wpl_reader(text: str) -> None:
    value_or_input_error(mission_files.read_mission, _file(text, "m.waypoints"))


STATLOG_ROWS = "\n".join(" ".join(str((7 * r + c) % 256) for c in range(36)) + f" {1 + r % 5}"
                         for r in range(6)) + "\n"


@FUZZ
@given(mutated_lines(STATLOG_ROWS, " "))
def test_statlog_reader(text: str) -> None:
    value_or_input_error(statlog.parse, text, "sat.trn")


@FUZZ
@given(st.binary(max_size=64))
def test_readers_on_random_bytes(data: bytes) -> None:
    for name in ("sites.json", "m.plan", "m.waypoints"):
        path = _file(data, name)
        if name == "sites.json":
            value_or_input_error(load_user_sites, path, SCAN, None, 14400.0, False,
                         check=_valid_sites)
        else:
            value_or_input_error(mission_files.read_mission, path)


def test_the_fuzzed_seeds_are_valid() -> None:
    """The starting points are well-formed (else the fuzzing would only test refusals)."""
    load_user_sites(_file(json.dumps(SITES), "sites.json"), SCAN, None, 14400.0, False)
    load_user_sites(_file(json.dumps(GEOJSON), "sites.json"), SCAN, None, 14400.0, True)
    _mission_build(_file(json.dumps(PLAN), "plan.json"))
    _valid_plan(Plan.read(_file(json.dumps(PLAN), "plan.json")))
    _valid_plan(Plan.read(_file(json.dumps(MADE_PLAN), "plan.json")))
    _valid_verdict(Verdict.read(_file(json.dumps(VERDICT), "verdict.json")))
    grid = _read_grid(json.dumps(GRID_ROW), json.dumps(GRID_VERDICT))
    _valid_grid_site(grid)
    assert grid[0].rise is not None and grid[0].rise.ground_plane == (100.0, 0.01, 0.0)
    _valid_verdict_file(VerdictFile.read(_file(json.dumps(GRID_VERDICT), "verdict.json")))
    recon = Recon.read(_file(json.dumps(RECON), "recon.json"))
    _valid_recon(recon)
    assert len(recon.poses()) == 1 and recon.alt_datum == "egm96"
    summary = MissionSummary.read(_file(json.dumps(MISSION_SUMMARY), "mission.json"))
    _valid_mission_summary(summary)
    assert summary.flights[0].terrain is not None and summary.second_look is not None
    _valid_row(SiteRow.read(_file(json.dumps(SITE_ROW), "site_result.json")))
    _valid_learn(LearnRecord.read(_file(json.dumps(LEARN), "learn.json")))
    row = GridRow.from_doc({**GRID_ROW, "note": "an unknown member"}, "rows[0]")
    assert set(row.second) == {"second"} and row.second["second"].status == "failed"
    assert GridRow.from_doc(json.loads(json.dumps(row.to_doc())), "again") == row
    answers = SurveyAnswers.read(_file(json.dumps(SUMMARY), "summary.json"))
    assert dict(answers.answers) == {"s01": "undecided", "s02": "failed", "s03": None}
    assert set(Ledger(_file(json.dumps(LEDGER), "stages.json")).done) == {"classify", "plan"}
    _valid_card(CardSummary.read(_file(json.dumps(PHOTO_CARD), "photos.json"), "photos.json"))
    assert len(mission_files.read_mission(_file(QGC_PLAN, "m.plan"))[0]) > 5
    assert len(mission_files.read_mission(_file(WPL, "m.waypoints"))[0]) > 5
    assert len(statlog.parse(STATLOG_ROWS, "sat.trn").cls) == 6
    from mound.training.verdict_bound import read_thresholds

    assert read_thresholds(_file(json.dumps(BOUND), "bound.json")) == {"dem": 5.35,
                                                                        "synthetic": 6.36}


@pytest.fixture(scope="module", autouse=True)
def _cleanup() -> Any:
    yield
    for p in WORK.iterdir():
        shutil.rmtree(p) if p.is_dir() else p.unlink()
    WORK.rmdir()


# ------------------------------------------------------------------ the scene workflow

LABELS = {"type": "FeatureCollection", "features": [
    {"type": "Feature", "id": "1001", "properties": {"kind": "mound", "height_m": 4.0,
                                                     "visibility": "visible"},
     "geometry": {"type": "Point", "coordinates": [25.2466, 42.6271]}},
    {"type": "Feature", "properties": {"kind": "not_mound"},
     "geometry": {"type": "Point", "coordinates": [25.2503, 42.6266]}},
    {"type": "Feature", "properties": {},
     "geometry": {"type": "Point", "coordinates": [25.2495, 42.6259]}}]}
AOI = {"type": "FeatureCollection", "features": [
    {"type": "Feature", "properties": {}, "geometry": {"type": "Polygon", "coordinates": [
        [[25.24, 42.62], [25.26, 42.62], [25.26, 42.63], [25.24, 42.63], [25.24, 42.62]]]}}]}


BOUND = {"schema": "mound.verdict_bound", "version": 1, "filter": "plain",
         "place_within_m": 0.0, "thresholds": {"dem": 5.35, "synthetic": 6.36},
         "goal_tumuli": {}}


@FUZZ
@given(mutated_json(BOUND))
def test_verdict_bound_thresholds_reader(text: str) -> None:
    from mound.training.verdict_bound import read_thresholds

    value_or_input_error(read_thresholds, _file(text, "bound.json"))
    value_or_input_error(read_thresholds, _file(text, "bound.json"), "whitened")


@FUZZ
@given(mutated_json(LABELS))
def test_scene_labels_reader(text: str) -> None:
    from mound.scene.vector import read_labels

    value_or_input_error(read_labels, _file(text, "labels.geojson"))


@FUZZ
@given(mutated_json(AOI))
def test_scene_aoi_reader(text: str) -> None:
    from mound.scene.vector import read_aoi

    value_or_input_error(read_aoi, _file(text, "aoi.geojson"))


def _scene_bytes() -> bytes:
    import numpy as np
    import rasterio
    from rasterio.transform import from_origin

    path = WORK / "valid_scene.tif"
    with rasterio.open(path, "w", driver="GTiff", width=24, height=20, count=2,
                       dtype="uint16", nodata=0, crs="EPSG:32635",
                       transform=from_origin(366000, 4727000, 1, 1)) as ds:
        ds.write(np.arange(2 * 24 * 20, dtype=np.uint16).reshape(2, 20, 24) + 1)
        ds.set_band_description(1, "red")
        ds.set_band_description(2, "nir")
    return path.read_bytes()


SCENE = _scene_bytes()


def _read_scene(path: Path) -> None:
    from mound.scene.raster import open_scene, read_window

    scene = open_scene(path)
    bands = scene.resolve_bands(["red", "nir"] if "red" in scene.band_names else None)
    read_window(scene, bands, -3, -3, 30, 30)


@FUZZ
@given(st.integers(0, len(SCENE) - 1), st.binary(min_size=1, max_size=16),
       st.integers(0, 16), st.booleans())
def test_scene_geotiff_reader(at: int, piece: bytes, cut: int, truncate: bool) -> None:
    """A valid GeoTIFF with bytes overwritten (header, tags, geokeys, pixel strips) or cut
    short: open_scene and read_window answer with a scene or an InputError."""
    data = SCENE[:at] if truncate else SCENE[:at] + piece + SCENE[at + cut:]
    value_or_input_error(_read_scene, _file(data, "scene.tif"))


def _dem_bytes() -> bytes:
    import numpy as np
    import rasterio
    from rasterio.transform import from_origin

    path = WORK / "valid_dem.tif"
    with rasterio.open(path, "w", driver="GTiff", width=40, height=40, count=1,
                       dtype="float32", crs="EPSG:3794",
                       transform=from_origin(564000, 147000, 1, 1)) as ds:
        ds.write(np.linspace(250, 320, 1600, dtype=np.float32).reshape(1, 40, 40))
    return path.read_bytes()


DEM_TIF = _dem_bytes()


def _read_dem(path: Path) -> None:
    import numpy as np

    from mound.sim.terrain import dem_patch

    z = dem_patch(str(path), 564020.0, 146980.0, np.linspace(-10, 10, 21))
    assert z.shape == (21, 21) and np.isfinite(z).all()
    # a second look's site wider than the DEM: continued across its edges
    z = dem_patch(str(path), 564010.0, 146980.0, np.linspace(-40, 40, 41), extend=True)
    assert z.shape == (41, 41) and np.isfinite(z).all()


@FUZZ
@given(st.integers(0, len(DEM_TIF) - 1), st.binary(min_size=1, max_size=16),
       st.integers(0, 16), st.booleans())
@pytest.mark.slow
def test_dem_patch_reader(at: int, piece: bytes, cut: int, truncate: bool) -> None:
    """The simulator's DEM reader (a terrain patch for `mound sim site --dem`, the grid) on
    a valid DEM with bytes overwritten or cut short: a finite patch or an InputError."""
    data = DEM_TIF[:at] if truncate else DEM_TIF[:at] + piece + DEM_TIF[at + cut:]
    value_or_input_error(_read_dem, _file(data, "dem.tif"))


def _read_dem_for_flight(path: Path) -> None:
    import numpy as np

    from mound.geometry.dem import Dem

    dem = Dem.at(str(path), 564020.0, 146980.0, "egm96", margin_m=15)
    h = dem.height(np.array([[0.0, 0.0], [5.0, -5.0]]))
    top, _ = dem.corridor_max(np.array([[-5.0, 5.0]]), np.array([[5.0, -5.0]]), 3.0)
    assert np.isfinite(h).all() and np.isfinite(top).all()


@FUZZ
@given(st.integers(0, len(DEM_TIF) - 1), st.binary(min_size=1, max_size=16),
       st.integers(0, 16), st.booleans())
@pytest.mark.slow
def test_dem_flight_reader(at: int, piece: bytes, cut: int, truncate: bool) -> None:
    """The flight's DEM reader (geometry/dem.py: heights, corridor maxima over ENU points)
    on a valid DEM with bytes overwritten or cut short: finite heights or an InputError."""
    data = DEM_TIF[:at] if truncate else DEM_TIF[:at] + piece + DEM_TIF[at + cut:]
    value_or_input_error(_read_dem_for_flight, _file(data, "dem.tif"))


# --------------------------------------------------- issue 54: the field work's readers

def _verdict_model() -> dict[str, Any]:
    from mound.paths import REPO_ROOT

    doc = json.loads((REPO_ROOT / "data" / "verdict_model_dense.json").read_text())
    doc.pop("trained"), doc.pop("heldout")  # reports, not read: mutations go to the model
    doc["second_look"] = {"p_low": 0.3, "threshold": 0.6, "scan_factor": 2.0,
                          "combine": {"first": 0.5, "second": 1.0, "bias": -0.2}}
    doc["detector"] = {"candidates": "local_relief"}
    return doc


VERDICT_MODEL = _verdict_model()


def _judge_with_model(path: Path) -> None:
    """The model read, then used: a valid model gives every site a p in [0, 1]."""
    import numpy as np

    from mound.recon.model_file import read_verdict_model
    from mound.training import verdict_model as vm

    model = read_verdict_model(path)
    rows = [vm.rises_of([{"features": dict(zip(model.features, f, strict=True))}
                         for f in np.random.default_rng(k).normal(0, 3, (3, 25)).tolist()],
                        "rises") for k in range(3)] + [()]
    p = vm.probability(model, rows)
    assert np.all((p >= 0) & (p <= 1)), p


@FUZZ
@given(mutated_json(VERDICT_MODEL))
def test_verdict_model_reader(text: str) -> None:
    value_or_input_error(_judge_with_model, _file(text, "model.json"))


def _confusion_seeds() -> tuple[dict[str, Any], dict[str, Any]]:
    """An eval-verdict report's three answers (the held-out Kazanlak one, cut to what the
    reader reads) and a model's trained.confusion."""
    from mound.paths import REPO_ROOT

    r = json.loads((REPO_ROOT / "docs" / "results" / "verdict_three_answers_kazanlak.json")
                   .read_text())["three_answers"]
    by = {c: {k: v for k, v in row.items() if k in ("tumuli", "confirmed", "undecided",
                                                     "no_mound")}
          for c, row in r["field_recall"]["all"]["by_height"].items()}
    report = {"three_answers": {"field_recall": {"all": {"by_height": by}},
                                "confident_false_alarms": r["confident_false_alarms"],
                                "undecided": r["undecided"]}}
    rates = [0.5, 0.3, 0.2]
    model = {"trained": {"confusion": {
        "tumulus": {c: rates for c in by}, "none": [0.01, 0.3, 0.69]}}}
    return report, model


CONFUSION_REPORT, CONFUSION_MODEL = _confusion_seeds()


def _valid_confusion(c: Any) -> None:
    for rates in (*c.tumulus.values(), c.none):
        assert len(rates) == 3 and all(math.isfinite(x) for x in rates), rates


@FUZZ
@given(mutated_json(CONFUSION_REPORT), mutated_json(CONFUSION_MODEL))
def test_visit_value_confusion_readers(report: str, model: str) -> None:
    """bench_day's --confusion: a report's three answers or a model's trained.confusion,
    mutated: rates the value of a visit can use, or a clear error."""
    from mound.recon.visit_value import Confusion

    def read(text: str, kind: str) -> Any:
        try:
            doc = json.loads(text)
        except ValueError:
            raise InputError("not JSON") from None
        if not isinstance(doc, dict):
            raise InputError("not an object")
        return (Confusion.from_report if kind == "report" else Confusion.from_model)(
            doc, "c.json")

    value_or_input_error(read, report, "report", check=_valid_confusion)
    value_or_input_error(read, model, "model", check=_valid_confusion)


PHOTO_SITES = {"schema": "mound.sites", "version": 1, "origin": ORIGIN.to_doc(),
               "home": {"id": "home", "x_m": 0, "y_m": 0}, "scan": SCAN.to_doc(),
               "sites": [{"id": "a", "x_m": 300, "y_m": 0}, {"id": "b", "x_m": 0, "y_m": 400}]}


def _photo_card_sites(path: Path) -> None:
    import numpy as np

    from mound.photos.sort import SortSpec, sites_of

    s = sites_of(str(path), SortSpec())
    assert np.all(np.isfinite(s.xy)) and np.isfinite(s.reach_m) and s.reach_m > 0
    assert len(s.ids) == len(s.xy)


@FUZZ
@given(st.one_of(mutated_json(PHOTO_SITES), mutated_json(PLAN)))
def test_photo_card_sites_reader(text: str) -> None:
    """What `mound photos sort --sites/--plan` reads to sort a card: the sites and the
    scan's reach, finite, or an InputError."""
    value_or_input_error(_photo_card_sites, _file(text, "sites.json"))  # it asserts


GEO_NUMBERS = (st.floats(-1e7, 1e7) | st.floats() | st.sampled_from(
    [0.0, 1.0, -1.0, 0.5, 1e-4, 1e155, -1e300, 1e-320, 3.5e38, 91.0, -181.0, 564000.0,
     147000.0, 14.5, 46.05]))
CRSS = st.sampled_from([
    "EPSG:3794", "EPSG:4326", "EPSG:4979", "EPSG:4326+5773", "EPSG:3794+5773",
    "EPSG:32633", "EPSG:4326+3855", 'LOCAL_CS["x",UNIT["metre",1]]',
    'PROJCS["x",GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],'
    'PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433]],PROJECTION["Foo"],'
    'UNIT["metre",1]]', None])


def _geotiff(name: str, transform: tuple[float, ...], crs: str | None, bands: int) -> Path:
    import warnings

    import numpy as np
    import rasterio
    from rasterio.transform import Affine

    path = WORK / name
    kw: dict[str, Any] = {"transform": Affine(*transform)}
    if crs is not None:
        kw["crs"] = crs
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with rasterio.open(path, "w", driver="GTiff", width=30, height=30, count=bands,
                           dtype="float32", **kw) as ds:
            ds.write(np.linspace(250, 320, 900 * bands, dtype=np.float32
                                 ).reshape(bands, 30, 30))
    return path


def _dem_heights(path: Path, x: float, y: float, vertical: str | None) -> None:
    import numpy as np

    from mound.geometry.dem import Dem

    try:
        dem = Dem.at(str(path), x, y, vertical, margin_m=15)
    except OverflowError:  # pragma: no cover - reported by the assertion below
        raise AssertionError("OverflowError") from None
    h = dem.height(np.array([[0.0, 0.0], [3.0, -3.0]]))
    top, _ = dem.corridor_max(np.array([[-3.0, 3.0]]), np.array([[3.0, -3.0]]), 2.0)
    assert np.isfinite(h).all() and np.isfinite(top).all() and np.all(top >= h.min() - 1e-6)


@FUZZ
@given(st.tuples(GEO_NUMBERS, GEO_NUMBERS, GEO_NUMBERS, GEO_NUMBERS, GEO_NUMBERS,
                 GEO_NUMBERS), CRSS, st.sampled_from([None, "egm96", "ellipsoid", "egm2008"]),
       GEO_NUMBERS, GEO_NUMBERS)
@pytest.mark.slow
def test_dem_georeference(tf: tuple[float, ...], crs: str | None, vertical: str | None,
                          x: float, y: float) -> None:
    """The flight's DEM reader on DEMs whose geotransform, CRS and vertical datum are drawn
    (NaN, inf, huge, zero, rotated; CRSs PROJ cannot use): finite heights or an
    InputError, for any point asked."""
    path = _geotiff("georef_dem.tif", tf, crs, 1)
    value_or_input_error(_dem_heights, path, x, y, vertical)


@FUZZ
@given(st.tuples(GEO_NUMBERS, GEO_NUMBERS, GEO_NUMBERS, GEO_NUMBERS, GEO_NUMBERS,
                 GEO_NUMBERS), CRSS)
def test_scene_georeference(tf: tuple[float, ...], crs: str | None) -> None:
    """The scene reader on scenes whose geotransform and CRS are drawn: a scene whose
    corners are places on the earth, or an InputError."""
    def read(path: Path) -> None:
        import numpy as np

        from mound.scene.raster import open_scene, read_window, transformer_from_scene

        scene = open_scene(path, ["red", "nir"])
        w, s, e, n = scene.bounds()
        lon, lat = transformer_from_scene(scene).transform(np.array([w, e]), np.array([s, n]))
        assert read_window(scene, [1, 2], -3, -3, 8, 8).shape == (2, 8, 8)
        assert np.all(np.isfinite([w, s, e, n])), (w, s, e, n)
        del lon, lat

    value_or_input_error(read, _geotiff("georef_scene.tif", tf, crs, 2))


def test_the_field_work_seeds_are_valid() -> None:
    """The new properties' starting points are read (else they would test refusals only)."""
    _judge_with_model(_file(json.dumps(VERDICT_MODEL), "model.json"))
    _photo_card_sites(_file(json.dumps(PHOTO_SITES), "sites.json"))
    _photo_card_sites(_file(json.dumps(PLAN), "plan.json"))
    for crs, vertical in (("EPSG:3794", "egm96"), ("EPSG:3794+5773", None)):
        _dem_heights(_geotiff("georef_dem.tif", (1.0, 0.0, 564000.0, 0.0, -1.0, 147000.0),
                              crs, 1), 564015.0, 146985.0, vertical)
    _dem_heights(_geotiff("georef_dem.tif", (1e-4, 0.0, 14.49, 0.0, -1e-4, 46.06),
                          "EPSG:4979", 1), 14.4915, 46.0585, None)


# ------------------------------------------------ issue 55: DJI and Litchi mission files

def _dji_and_litchi() -> tuple[str, str, str]:
    from mound.uav import dji, litchi
    from mound.uav.filetypes.dji_kmz import kmz
    from mound.uav.route import mission_route

    plan = json.loads(json.dumps({**PLAN, "scan": scan_for_site(
        60.0, "both").to_doc()}))
    m = build_mission(plan, ORIGIN, None)
    data = kmz(m, dji.AIRCRAFT["m3e"])
    import io
    import zipfile

    with zipfile.ZipFile(io.BytesIO(data)) as z:
        template, waylines = (z.read(n).decode() for n in (dji.TEMPLATE, dji.WAYLINES))
    return template, waylines, litchi.csv_text(litchi.prepare(mission_route(m))[0])


KML_TEMPLATE, WAYLINES_WPML, LITCHI_CSV = _dji_and_litchi()


def _kmz(template: str, waylines: str, deflate: bool = False) -> bytes:
    import io
    import zipfile

    from mound.uav import dji

    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED if deflate else zipfile.ZIP_STORED) as z:
        z.writestr(dji.TEMPLATE, template.encode("utf-8", "surrogatepass"))
        z.writestr(dji.WAYLINES, waylines.encode("utf-8", "surrogatepass"))
    return buf.getvalue()


def _read_kmz_routes(path: Path) -> None:
    import numpy as np

    from mound.uav import dji_read

    k = dji_read.read_kmz(path)
    for w in range(len(k.waylines)):
        r = k.route(w)
        assert len(r.points) >= 1 and np.all(np.isfinite(r.enu()))


@st.composite
def mutated_xml(draw: st.DrawFn, text: str) -> str:
    """XML with element texts replaced by nasty tokens, elements deleted or duplicated,
    then maybe characters spliced in."""
    import re

    spans = [m.span(1) for m in re.finditer(r">([^<>]*)</", text)]
    for _ in range(draw(st.integers(1, 3))):
        a, b = draw(st.sampled_from(spans))
        if a > len(text) or b > len(text):
            continue
        token = draw(st.sampled_from(["", "nan", "inf", "-1", "1e400", "9" * 40, "x", "0",
                                      "-999999", "0,0", "1,2,3,4", "&amp;", "\u00e9"])
                     | st.text(max_size=8))
        text = text[:a] + token.replace("<", "").replace("&", "") + text[b:]
    lines = text.splitlines()
    if draw(st.booleans()) and len(lines) > 3:
        k = draw(st.integers(1, len(lines) - 2))
        lines.insert(k, lines[k]) if draw(st.booleans()) else lines.pop(k)
    return draw(spliced("\n".join(lines)))


@FUZZ
@given(mutated_xml(WAYLINES_WPML), st.booleans())
def test_dji_kmz_reader(waylines: str, keep_template: bool) -> None:
    """A KMZ of this project's with its waylines mutated: routes with finite positions,
    or an InputError."""
    data = _kmz(KML_TEMPLATE if keep_template else "<kml/>", waylines)
    value_or_input_error(_read_kmz_routes, _file(data, "m.kmz"))


@FUZZ
@given(mutated_xml(KML_TEMPLATE))
def test_dji_kmz_template_reader(template: str) -> None:
    """Issue 67: the template is read too (its heightMode, heights, imageFormat): a
    mutated template.kml beside intact waylines gives routes or an InputError."""
    value_or_input_error(_read_kmz_routes, _file(_kmz(template, WAYLINES_WPML), "m.kmz"))


@FUZZ
@given(st.integers(0, 4000), st.binary(min_size=1, max_size=16), st.booleans(),
       st.booleans())
def test_dji_kmz_zip_bytes(at: int, piece: bytes, truncate: bool, deflate: bool) -> None:
    """The KMZ's zip bytes overwritten or cut short, stored or deflated (a corrupt deflate
    stream was a zlib.error: issue 67)."""
    data = _kmz(KML_TEMPLATE, WAYLINES_WPML, deflate)
    at = at % len(data)
    data = data[:at] if truncate else data[:at] + piece + data[at + len(piece):]
    value_or_input_error(_read_kmz_routes, _file(data, "m.kmz"))


@FUZZ
@given(mutated_lines(LITCHI_CSV, ","))
def test_litchi_reader(text: str) -> None:
    from mound.uav import litchi

    def read(path: Path) -> None:
        import numpy as np

        pts = litchi.read_litchi(path)
        assert np.all(np.isfinite([[p.lat_deg, p.lon_deg, p.height_m] for p in pts]))

    value_or_input_error(read, _file(text, "m.csv"))


def _gpx_seed() -> str:
    from mound.uav.filetypes import gpx

    plan = json.loads(json.dumps({**PLAN, "scan": scan_for_site(
        60.0, "both").to_doc()}))
    return gpx.gpx_text(build_mission(plan, ORIGIN, None))


GPX_TEXT = _gpx_seed()


@st.composite
def mutated_gpx(draw: st.DrawFn, text: str) -> str:
    """GPX with attribute values (lat, lon, the legs' extension) replaced by nasty tokens,
    then its element texts and lines mutated as any XML's."""
    import re

    spans = [m.span(1) for m in re.finditer(r'="([^"]*)"', text)]
    for _ in range(draw(st.integers(0, 3))):
        a, b = draw(st.sampled_from(spans))
        if b <= len(text):
            token = draw(st.sampled_from(["", "nan", "inf", "-1", "1e400", "91", "-181", "x"])
                         | st.text(max_size=6))
            text = text[:a] + token.replace('"', "").replace("<", "").replace("&", "") + text[b:]
    return draw(mutated_xml(text))


def _read_gpx_route(path: Path) -> None:
    import numpy as np

    from mound.uav.filetypes import gpx

    _, r = gpx.read_gpx(path)
    assert len(r.points) >= 2 and np.all(np.isfinite(r.enu()))


@FUZZ
@given(mutated_gpx(GPX_TEXT))
def test_gpx_reader(text: str) -> None:
    """Issue 70: a GPX track of this project's, mutated: a route with finite positions and
    heights, or an InputError."""
    value_or_input_error(_read_gpx_route, _file(text, "m.gpx"))


def test_the_mission_format_seeds_are_valid() -> None:
    from mound.uav import litchi

    _read_kmz_routes(_file(_kmz(KML_TEMPLATE, WAYLINES_WPML), "m.kmz"))
    assert len(litchi.read_litchi(_file(LITCHI_CSV, "m.csv"))) > 5
    _read_gpx_route(_file(GPX_TEXT, "m.gpx"))


# ---- issue 56: the measured population a grid draws its tumuli from

POPULATION = {"type": "FeatureCollection", "features": [
    {"type": "Feature", "id": "1001",
     "properties": {"length_m": 15.0, "width_m": 12.0, "height_m": 0.5, "robber_trench": True},
     "geometry": {"type": "Point", "coordinates": [25.2466, 42.6271]}},
    {"type": "Feature", "id": "1002",
     "properties": {"length_m": 30, "width_m": 40, "height_m": 4.5, "robber_trench": None},
     "geometry": {"type": "Point", "coordinates": [25.25, 42.63]}},
    {"type": "Feature", "properties": {"length_m": 9, "width_m": 9, "height_m": 0}}]}


@FUZZ
@given(mutated_json(POPULATION))
def test_population_reader(text: str) -> None:
    """A clear error, or a population whose every row a grid can draw: finite sizes, the
    base's length >= width > 0, a height > 0, within the reader's bounds."""
    from mound.sim.population import MAX_HEIGHT_M, MAX_SIZE_M, read_population

    def read(path: Path) -> None:
        pop = read_population(str(path))
        assert pop.rows and pop.levelled >= 0
        for r in pop.rows:
            assert MAX_SIZE_M >= r.length_m >= r.width_m > 0
            assert 0 < r.height_m <= MAX_HEIGHT_M and r.trench in (True, False, None)

    value_or_input_error(read, _file(text, "population.geojson"))


def test_the_population_seed_is_valid() -> None:
    from mound.sim.population import read_population

    pop = read_population(str(_file(json.dumps(POPULATION), "population.geojson")))
    assert len(pop.rows) == 2 and pop.levelled == 1
    assert (pop.rows[1].length_m, pop.rows[1].width_m) == (40.0, 30.0)
