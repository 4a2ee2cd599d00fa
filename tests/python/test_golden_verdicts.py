"""The golden verdicts (issue 57): the learned verdict depends on floating-point summation
order (cpp/terrain/rise_fit.cc says so), so three reference sites of a dense grid
(tests/data/golden: a tumulus, a haystack, a low tumulus on the laser DEM; every 16th point
of their dense clouds) hold `mound_recon verdict` to the features and p it gave them when
they were made (tools/golden_verdicts.py). A refactor or a compiler flag that moves a
verdict fails here; a change that moves them on purpose remakes them and says why."""

from __future__ import annotations

import json
import math
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
GOLDEN = ROOT / "tests" / "data" / "golden"
SITES = sorted(p.name for p in GOLDEN.iterdir() if p.is_dir())
# far above the last bits a platform may round differently, far below a verdict's move
REL = 1e-6


def test_the_golden_sites_are_there() -> None:
    assert SITES == ["haystack", "tumulus", "tumulus_on_dem"]


@pytest.mark.parametrize("name", SITES)
def test_the_verdict_of_a_golden_site_has_not_moved(name: str, mound_recon: Path,
                                                   tmp_path: Path) -> None:
    site = GOLDEN / name
    want = json.loads((site / "expected.json").read_text())
    out = tmp_path / "verdict.json"
    subprocess.run([str(mound_recon), "verdict", str(site / "recon"), "--cloud",
                    str(site / "dense.ply"), "--out", str(out)], check=True,
                   capture_output=True)
    got = json.loads(out.read_text())
    assert got["label"] == want["label"]
    assert got["p_mound"] == pytest.approx(want["p_mound"], rel=REL, abs=1e-9)
    rises = [r["features"] for r in got["measurements"]["judged_rises"]]
    assert len(rises) == len(want["judged_rises"])
    for k, (a, b) in enumerate(zip(rises, want["judged_rises"], strict=True)):
        assert a.keys() == b.keys(), k
        moved = {f: (a[f], b[f]) for f in b
                 if not math.isclose(a[f], b[f], rel_tol=REL, abs_tol=1e-9)}
        assert not moved, f"{name}: judged rise {k}: {moved}"
    truth = json.loads((site / "truth.json").read_text())
    assert truth["mound"] == (name != "haystack")  # the reference sites are what they say
