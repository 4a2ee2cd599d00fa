"""`mound day` (issue 69, item 1; INTERFACES.md "A field day"): a two-battery day on
simulated JPEG cards — battery 1's missions written, its card (mound sim flight: JPEGs with
EXIF) sorted and judged, battery 2 re-planned and its missions written in every format,
day.json, and the map drawing the next battery in headless Chromium."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from mound.cli import main as mound_main
from mound.formats.plan import Plan
from mound.paths import REPO_ROOT
from mound.uav import mission_format

DAY = ["--batteries", "2", "--budget", "2000", "--image-size", "320", "240",
       "--no-progress", "--max-features", "4000", "--dense-size", "0"]


def day(out: Path, *cards: Path) -> int:
    return mound_main(["day", "--out", str(out), *DAY,
                       *(x for c in cards for x in ("--photos", str(c)))])


def battery_files(out: Path, k: int) -> Plan:
    """Battery k's folder: its plan, and its mission in each format, read back by that
    format's reader over the plan's sites."""
    b = out / f"battery_{k}"
    plan = Plan.read(b / "plan.json")
    for fmt in (f for f in mission_format.registry() if f.readable):
        name = f"mission{fmt.suffix}"
        _, routes = mission_format.read_any(b / name)
        assert routes and len(routes[0].points) >= 2 * len(plan.visited()), name
    assert json.loads((b / "mission.json").read_text())["schema"] == "mound.mission"
    return plan


@pytest.mark.slow
def test_a_two_battery_day_on_simulated_cards(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "day"
    # morning: battery 1's missions, nothing judged yet; exit 0, the day waits for a card
    assert day(out) == 0
    doc = json.loads((out / "day.json").read_text())
    assert doc["schema"] == "mound.day" and doc["status"] == "waiting" and not doc["flown"]
    plan1 = battery_files(out, 1)
    # the day planned once is not written as missions: the crew flies battery_K/ only
    assert not list(out.glob("mission*.plan")) and not (out / "mission.json").exists()
    assert doc["next"] == {"battery": 1, "folder": "battery_1",
                           "sites": sorted(plan1.visited(), key=plan1.visit_order().index)}
    # battery 1 flies: its card
    card1 = tmp_path / "card1"
    assert mound_main(["sim", "flight", str(out / "battery_1" / "plan.json"), "--out",
                       str(card1), "--image-size", "320", "240"]) == 0
    # it lands: the card judged, battery 2 re-planned and written
    assert day(out, card1) == 0
    doc = json.loads((out / "day.json").read_text())
    assert [b["battery"] for b in doc["flown"]] == [1] and doc["next"]["battery"] == 2
    summary = json.loads((out / "summary.json").read_text())
    rows = {r["id"]: r for r in summary["sites"]}
    for j in doc["flown"][0]["judged"]:
        r = rows[j["id"]]
        assert r["visited"] and r["source"] == "photos" and j["answer"] == r["answer"]
        assert r["files"]["images"] == f"battery_1/photos/{j['id']}"
    plan2 = battery_files(out, 2)
    assert not plan2.visited() & plan1.visited()  # battery 2 flies sites not flown
    assert doc["flown"][0]["plan_left"][0] == doc["next"]["sites"]
    learn = json.loads((out / "learn" / "learn.json").read_text())
    assert learn["waiting_for_battery"] == 2 and len(learn["flights"]) == 1
    # the same command again changes nothing: the judged battery is kept
    before = (out / "battery_2" / "plan.json").read_text()
    assert day(out, card1) == 0
    assert (out / "battery_2" / "plan.json").read_text() == before
    assert "1 of 2 batteries judged" in capsys.readouterr().out
    # the day's own flags are refused when given to it as survey options
    assert mound_main(["day", "--out", str(out), "--learn"]) == 2
    assert "--learn: mound day sets it" in capsys.readouterr().err
    assert mound_main(["day", "--out", str(out), "--connect", "udpout:127.0.0.1:14550"]) == 2
    assert "--connect: a day on cards uploads no mission" in capsys.readouterr().err
    # the map: the flight flown, the next battery, its mission files read back
    js = (out / "map" / "survey.js").read_text()
    data = json.loads(js[js.index("=") + 1:].strip().rstrip(";"))
    assert data["next_battery"]["battery"] == 2 and len(data["flights"]) == 1
    assert data["footprints"]  # the batteries' image footprints
    assert {f["file"] for f in data["mission_files"]} == {
        f"battery_{k}/mission{f.suffix}" for k in (1, 2) for f in mission_format.registry()
        if f.readable}
    if shutil.which("chromium"):
        from pages import body_data

        got = body_data((out / "map.html").as_uri() + "#selftest", tmp_path / "chromium")
        assert json.loads(got["errors"]) == [] and got["next-battery"] == "2"
        assert len(json.loads(got["mission-files"])) == len(data["mission_files"])


def test_the_day_planned_on_the_value_of_a_visit(tmp_path: Path) -> None:
    """--reward value: every site's reward is the value of a visit given the verdict's
    measured confusion (never below 0), the day's first battery planned on it."""
    import numpy as np

    from mound.recon import visit_value as vv
    from mound.survey.reward import kazanlak_mix

    report = REPO_ROOT / "docs" / "results" / "verdict_three_answers_kazanlak.json"
    out = tmp_path / "day"
    assert mound_main(["day", "--out", str(out), "--batteries", "2", "--budget", "3000",
                       "--no-progress", "--reward", "value", "--confusion",
                       str(report)]) == 0
    sites = json.loads((out / "sites.json").read_text())
    conf = vv.Confusion.from_report(json.loads(report.read_text()), str(report))
    tum = conf.tumulus_mean(kazanlak_mix())
    p = np.array([s["p_mound"] for s in sites["sites"]])
    want = np.maximum(vv.visit_value(p, tum, conf.none), 0.0)
    assert np.allclose([s["reward"] for s in sites["sites"]], want)
    assert sites["provenance"]["reward"] == "value"
    plan = battery_files(out, 1)
    assert plan.visited()
    # the value's largest sites are the likeliest tumuli; the entropy's are p near 0.5
    top = max(sites["sites"], key=lambda s: s["reward"])
    assert top["p_mound"] == max(s["p_mound"] for s in sites["sites"])
