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


def test_the_stage_table_runs_the_stages_in_their_order() -> None:
    """survey/stages' table, then the report, is context.STAGES: the order the ledger's
    --rerun-from and the stage keys rely on."""
    from mound.survey.context import STAGES
    from mound.survey.stages import TABLE

    assert [name for name, _ in TABLE] + ["report"] == list(STAGES)
