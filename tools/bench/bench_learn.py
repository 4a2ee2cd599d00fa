"""Measurement (not a test): does learning between flights miss fewer mounds?

The whole survey (`python python/mission.py`) on the ten standard fields with K flights,
once without learning and once per `--learn-weight` W with `--learn`, all else equal
(the same simulated sites: a site's 3-D result depends only on the site, so each learning
run starts from a copy of the plain run's site results, and a site flown by both is judged
once). Printed per field and on average: eps_MD and eps_FA of the final labels after all
flights, the sites flown, and the classifier's AUC on sat.tst without the field's 100 rows
before and after (the verified sites are sat.tst rows that become training rows, so none
of the field's rows judges the classifier).

    .venv/bin/python tools/bench/bench_learn.py --out DIR [--fields 0 .. 9] [--flights 3]
        [--budget 3000] [--weights 1 100] [--workers 2]
"""

from __future__ import annotations

import argparse
import json
import shutil
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def survey(out: Path, field: int, a: argparse.Namespace, learn: float | None) -> dict:
    args = [sys.executable, str(ROOT / "python" / "mission.py"), "--out", str(out),
            "--field-seed", str(field), "--flights", str(a.flights), "--budget",
            str(a.budget), "--image-size", "320", "240", "--dense-size", "0",
            "--no-progress", "--workers", str(a.workers)]
    if learn is not None:
        args += ["--learn", "--learn-weight", str(learn)]
    r = subprocess.run(args, capture_output=True, text=True, cwd=ROOT)
    if r.returncode not in (0, 3):
        raise SystemExit(f"field {field}: mission.py exit {r.returncode}\n{r.stderr[-2000:]}")
    s = json.loads((out / "summary.json").read_text())
    row = {"eps_md": s["metrics"]["eps_md"], "eps_fa": s["metrics"]["eps_fa"],
           "visited": s["metrics"]["visited"],
           "mounds_flown": sum(1 for x in s["sites"] if x["visited"] and x.get("truth")),
           "wrong_verdicts": s["metrics"]["verdicts_with_truth"]
           - s["metrics"]["verdicts_correct"]}
    if "learn" in s:
        row["auc_before"] = s["learn"]["held_out_auc_before"]
        row["auc_after"] = s["learn"]["held_out_auc_after"]
        row["flipped"] = sum(f["labels_flipped"] for f in s["learn"]["flights"])
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--fields", type=int, nargs="+", default=list(range(10)))
    ap.add_argument("--flights", type=int, default=3)
    ap.add_argument("--budget", type=float, default=3000.0)
    ap.add_argument("--weights", type=float, nargs="+", default=[1.0, 100.0])
    ap.add_argument("--workers", type=int, default=2)
    a = ap.parse_args()
    out = Path(a.out)
    results: dict[str, list[dict]] = {"plain": [], **{f"learn W={w:g}": [] for w in a.weights}}
    print(f"K={a.flights} flights of {a.budget:.0f} m, fields {a.fields}", flush=True)
    for field in a.fields:
        plain_dir = out / f"field{field}" / "plain"
        row = survey(plain_dir, field, a, None)
        results["plain"].append(row)
        line = [f"field {field}: plain eps_MD {row['eps_md']:.3f} eps_FA {row['eps_fa']:.3f} "
                f"({row['visited']} flown, {row['mounds_flown']} mounds)"]
        for w in a.weights:
            d = out / f"field{field}" / f"learn_w{w:g}"
            if not (d / "sites").exists() and (plain_dir / "sites").exists():
                shutil.copytree(plain_dir / "sites", d / "sites")
            r = survey(d, field, a, w)
            results[f"learn W={w:g}"].append(r)
            line.append(f"W={w:g} eps_MD {r['eps_md']:.3f} eps_FA {r['eps_fa']:.3f} "
                        f"({r['visited']} flown, {r['mounds_flown']} mounds, AUC "
                        f"{r['auc_before']:.4f}->{r['auc_after']:.4f}, {r['flipped']} "
                        "labels flipped)")
        print("; ".join(line), flush=True)
    print("\nmean over fields:")
    for name, rows in results.items():
        md = [r["eps_md"] for r in rows]
        fa = [r["eps_fa"] for r in rows]
        extra = ""
        if rows and "auc_after" in rows[0]:
            extra = (f", held-out AUC {statistics.mean(r['auc_before'] for r in rows):.4f} -> "
                     f"{statistics.mean(r['auc_after'] for r in rows):.4f}")
        print(f"  {name:14s} eps_MD {statistics.mean(md):.4f} eps_FA {statistics.mean(fa):.4f}"
              f" mounds flown {sum(r['mounds_flown'] for r in rows)}, wrong verdicts "
              f"{sum(r['wrong_verdicts'] for r in rows)}{extra}")
    (out / "bench_learn.json").write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
