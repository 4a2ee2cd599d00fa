#!/usr/bin/env python3
"""The golden verdicts (issue 57): a few reference sites of a dense grid — its recon.json,
sparse points.ply and every 16th point of its dense cloud — with the features and p that
`mound_recon verdict` (the built-in dense model) gives them today, in
tests/data/golden/. tests/python/test_golden_verdicts.py holds the detector to them, so
that a refactor or a compiler flag that moves a verdict is seen; after a change that moves
them on purpose, remake them and say why in the changelog.

    python tools/golden_verdicts.py GRID DIR:NAME [DIR:NAME ...]   # new reference sites
    python tools/golden_verdicts.py --remeasure                    # the expected figures
"""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = ROOT / "tests" / "data" / "golden"
EVERY = 16  # the dense cloud's points kept


def thin_ply(src: Path, dst: Path, every: int = EVERY) -> None:
    """Every `every`-th vertex of a binary PLY of fixed-size records (the dense cloud)."""
    data = src.read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii")
    n = int(next(w for w in header.splitlines() if w.startswith("element vertex")).split()[-1])
    size = (len(data) - end) // n
    body = b"".join(data[end + k * size:end + (k + 1) * size] for k in range(0, n, every))
    m = len(body) // size
    dst.write_bytes(header.replace(f"element vertex {n}\n", f"element vertex {m}\n").encode()
                    + body)


def verdict(site: Path) -> dict:
    out = site / "verdict.out.json"
    subprocess.run([str(ROOT / "build" / "mound_recon"), "verdict", str(site / "recon"),
                    "--cloud", str(site / "dense.ply"), "--out", str(out)],
                   check=True, capture_output=True)
    doc = json.loads(out.read_text())
    out.unlink()
    return doc


def expected(doc: dict) -> dict:
    return {"label": doc["label"], "p_mound": doc["p_mound"],
            "judged_rises": [r["features"] for r in doc["measurements"]["judged_rises"]]}


def main(argv: list[str]) -> int:
    if argv and argv[0] != "--remeasure":
        grid = Path(argv[0])
        for spec in argv[1:]:
            folder, name = spec.split(":")
            site = GOLDEN / name
            (site / "recon").mkdir(parents=True, exist_ok=True)
            for f in ("recon.json", "points.ply"):
                shutil.copy(grid / folder / "recon" / f, site / "recon" / f)
            thin_ply(grid / folder / "dense" / "dense.ply", site / "dense.ply")
            # how the cloud was made (mound_recon verdict checks it against the model's
            # cloud_settings): the grid's densify options, the per-image report left out
            made = json.loads((grid / folder / "dense" / "dense.json").read_text())
            (site / "dense.json").write_text(json.dumps(
                {k: made[k] for k in ("schema", "version", "options") if k in made},
                indent=1) + "\n")
            truth = json.loads((grid / "grid.json").read_text())["rows"][int(folder)]["truth"]
            (site / "truth.json").write_text(json.dumps(truth, indent=1) + "\n")
    for site in sorted(p for p in GOLDEN.iterdir() if p.is_dir()):
        (site / "expected.json").write_text(json.dumps(expected(verdict(site)), indent=1)
                                            + "\n")
        print(site.name, json.loads((site / "expected.json").read_text())["p_mound"])
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
