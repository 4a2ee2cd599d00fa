"""The survey's typed options: the command line and the dataclass agree (every option a
field, every default from the dataclass), and bad combinations are refused naming the
option."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from mound.args import UsageError
from mound.survey.driver import build_parser
from mound.survey.options import SurveyOptions


def test_the_parser_and_the_dataclass_agree() -> None:
    assert SurveyOptions.from_namespace(build_parser().parse_args([])) == SurveyOptions()
    o = SurveyOptions.from_namespace(build_parser().parse_args(
        ["--flights", "3", "--image-size", "320", "240", "--algo", "newalg",
         "--scene", "a.tif", "b.tif", "--clearance-m", "45"]))
    assert (o.flights, o.image_size, o.algo, o.scenes, o.clearance_m) == (
        3, (320, 240), "newalg", ["a.tif", "b.tif"], 45.0)
    assert o.terrain_spec().clearance_m == 45.0
    doc = o.as_dict()
    assert doc["image_size"] == [320, 240] and doc["scene"] == ["a.tif", "b.tif"]
    json.dumps(doc)  # JSON-ready


def test_a_parser_option_without_a_field_is_a_bug() -> None:
    ns = build_parser().parse_args([])
    ns.surprise = 1
    with pytest.raises(RuntimeError, match="surprise"):
        SurveyOptions.from_namespace(ns)


@pytest.mark.parametrize("options, flag", [
    ({"spacing": 0.0}, "--spacing"),
    ({"image_size": (32, 32)}, "--image-size"),
    ({"flights": 0}, "--flights"),
    ({"camera": "cam.json"}, "--camera"),
    ({"labels": "known.geojson"}, "--labels"),
    ({"scene": ("s.tif",)}, "--home"),
    ({"learn": True, "learn_weight": 0.0}, "--learn-weight"),
    ({"dense_size": 8}, "--dense-size"),
    ({"basemap": "tiles.example.org"}, "--basemap"),
])
def test_check_names_the_option(options: dict[str, object], flag: str,
                                tmp_path: Path) -> None:
    with pytest.raises(UsageError, match=flag):
        SurveyOptions(out=str(tmp_path), **options).check()  # type: ignore[arg-type]


def test_the_stage_table_alone_says_the_stages_and_their_order(tmp_path) -> None:
    """Issue 70: survey/stages' TABLE is the one list of the stages: run_stages gives the
    Context its order, --rerun-from offers its names, and what is redone follows it (no
    second list, no stage count)."""
    from mound.survey.context import Context
    from mound.survey.ledger import Ledger
    from mound.survey.stages import NAMES, TABLE
    from mound.survey.tree import RunTree

    assert NAMES == tuple(name for name, _ in TABLE) and NAMES[-1] == "report"
    rerun = next(a for a in build_parser()._actions if a.dest == "rerun_from")
    assert tuple(rerun.choices) == NAMES
    ctx = Context(SurveyOptions(out=str(tmp_path)), RunTree(tmp_path), Ledger(tmp_path / "l"))
    ctx.order = NAMES
    assert not any(ctx.redoes(n) for n in NAMES)
    ctx.redo_from = "mission"
    assert [n for n in NAMES if ctx.redoes(n)] == list(NAMES[NAMES.index("mission"):])
    assert ctx.before("mission") == NAMES[:NAMES.index("mission")]


