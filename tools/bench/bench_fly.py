"""Measurement (not a test): batteries flown with `mound fly`'s loop against the MAVSDK
stand-in vehicle (issue 69, item 3) — how often the mission is replaced in the air, what a
re-plan and a replacement cost, and whether the aircraft comes home with its reserve.

Each battery is a standard Statlog field (`make_field`, seeds 0 ..: 100 sites 250 m
apart, the survey's scan), flown from home with a full battery of `--range-m`; answers
drawn from the verdict's three-answer confusion (`docs/results/verdict_three_answers_
kazanlak.json`), each taking `--judge-delay` s while the aircraft flies on (the stand-in
flies `--speed` m to a second of wall time). With `--fault`, a cell fails as the first
site is judged (35 % charge left). The reference system, in the same script: the same
missions uploaded and read back by `mound mission upload`'s path (transfer.upload_verified)
on a vehicle that is not flying; a replacement adds MISSION_SET_CURRENT to it.

Prints per battery the missions uploaded, the sites judged and their answers, the charge
at landing; then min and median of mound_plan's re-plan (with the mission built), of a
replacement, and of the reference upload, and their ratio. `--figure PNG` draws the first
battery: the sites by p, the first plan, the path flown, the answers.

    MOUND_DATA=../shared/data .venv/bin/python tools/bench/bench_fly.py [--batteries 10]
        [--range-m 5000] [--fault] [--figure docs/figures/field_day_fly.png]
        [--figure-battery 0]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "python"))

from mound.classify import coarse, statlog  # noqa: E402
from mound.formats.sites import Sites  # noqa: E402
from mound.jsonio import load_json  # noqa: E402
from mound.plan.field import make_field, sites_document  # noqa: E402
from mound.recon import visit_value as vv  # noqa: E402
from mound.survey import fly  # noqa: E402
from mound.survey.context import scan_spec  # noqa: E402
from mound.survey.options import SurveyOptions  # noqa: E402
from mound.uav.mavlink import link as mavlink_link  # noqa: E402
from mound.uav.mavlink import transfer  # noqa: E402
from mound.uav.mavlink.peer import MavsdkVehicle  # noqa: E402

REPORT = ROOT / "docs/results/verdict_three_answers_kazanlak.json"


def one_battery(sites: Sites, a: argparse.Namespace, work: Path
                ) -> tuple[dict, object, list]:
    conf = vv.Confusion.from_report(load_json(REPORT), str(REPORT))
    tum = conf.tumulus_mean({c: 1.0 for c in conf.tumulus})
    state = fly.InFlight(sites, conf, tum, fly.FlyOptions(a.range_m, timeout_s=300), work)
    judge = fly.SimulatedJudge(conf, tum, seed=1, delay_s=a.judge_delay)
    with MavsdkVehicle() as v:
        o = sites.origin
        assert o is not None
        aircraft = v.fly(o.lat_deg, o.lon_deg, a.range_m, speed_m_s=a.speed)

        def judged(site: object) -> str:
            if a.fault and not aircraft.drained:
                aircraft.drain(aircraft.charge() - 0.35)
            return judge(site)  # type: ignore[arg-type]

        lk = mavlink_link.connect(v.connect_string)
        try:
            log = fly.fly(lk, state, judged, work / "fly.json")
        finally:
            lk.close()
        aircraft.stop()
    log["_sites"] = sites
    return log, aircraft, state.items


def reference_uploads(missions: list[list], reps: int = 3) -> list[float]:
    """upload_verified of each mission on a vehicle that is not flying."""
    times = []
    with MavsdkVehicle() as v:
        lk = mavlink_link.connect(v.connect_string)
        try:
            for items in missions:
                for _ in range(reps):
                    t = time.monotonic()
                    transfer.upload_verified(lk, items)
                    times.append(time.monotonic() - t)
        finally:
            lk.close()
    return times


def figure(log: dict, aircraft: object, path: str, fault: bool) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sites: Sites = log["_sites"]
    xy = np.array([[s.x_m, s.y_m] for s in sites.sites])
    p0 = np.array([s.p_mound or 0.0 for s in sites.sites])
    by_id = {s.id: k for k, s in enumerate(sites.sites)}
    fig, ax = plt.subplots(figsize=(7.2, 6.4), dpi=110)
    sc = ax.scatter(xy[:, 0], xy[:, 1], c=p0, cmap="viridis", s=22, vmin=0, vmax=1,
                    zorder=2)
    fig.colorbar(sc, ax=ax, shrink=0.8, label="p(mound) before the flight")
    first = [by_id[s] for s in log["uploads"][0]["sites"]]
    route = np.vstack([[0, 0], xy[first], [0, 0]])
    ax.plot(route[:, 0], route[:, 1], "--", color="0.55", lw=1.2,
            label="first plan (uploaded before take-off)", zorder=1)
    track = np.array(aircraft.track)  # type: ignore[attr-defined]
    ax.plot(track[:, 0], track[:, 1], "-", color="tab:red", lw=1.4,
            label="flown (missions replaced in the air)", zorder=3)
    marks = {"mound": ("^", "tab:red"), "undecided": ("o", "tab:orange"),
             "no_mound": ("x", "tab:blue")}
    for ans, (m, c) in marks.items():
        ks = [by_id[x["site"]] for x in log["answers"] if x["answer"] == ans]
        if ks:
            ax.scatter(xy[ks, 0], xy[ks, 1], marker=m, s=110, facecolors="none"
                       if m == "o" else c, edgecolors=c, linewidths=1.6, zorder=4,
                       label=f"answer: {ans}")
    ax.scatter([0], [0], marker="*", s=200, color="k", zorder=5, label="home")
    box = np.vstack([route, track[:, :2]])
    ax.set_xlim(box[:, 0].min() - 300, box[:, 0].max() + 600)
    ax.set_ylim(box[:, 1].min() - 300, box[:, 1].max() + 600)
    n = len(log["uploads"])
    ax.set_title(f"One battery with mound fly: {n} missions, {n - 1} replaced in the air"
                 + ("\n(a cell fault as the first site is judged: home at once)" if fault
                    else ""), fontsize=10)
    ax.set_xlabel("east of home (m)")
    ax.set_ylabel("north of home (m)")
    ax.set_aspect("equal")
    ax.legend(loc="upper left", fontsize=7, framealpha=0.9)
    fig.tight_layout()
    fig.savefig(path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--batteries", type=int, default=10)
    ap.add_argument("--range-m", type=float, default=5000.0)
    ap.add_argument("--speed", type=float, default=1500.0, help="m of flight a wall second")
    ap.add_argument("--judge-delay", type=float, default=0.05)
    ap.add_argument("--fault", action="store_true")
    ap.add_argument("--figure")
    ap.add_argument("--figure-battery", type=int, default=0, help="the battery drawn")
    a = ap.parse_args()
    test = statlog.load("sat.tst")
    model = coarse.load_model(None)
    plans, replaces, missions = [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for d in range(a.batteries):
            f = make_field(test, d)
            sites = sites_document(f, test, model, None, a.range_m, spacing_m=250.0,
                                   scan=scan_spec(SurveyOptions()))
            work = Path(tmp) / f"b{d}"
            work.mkdir()
            log, aircraft, items = one_battery(sites, a, work)
            missions.append(items)
            ups = [u for u in log["uploads"] if "failed" not in u]
            plans += [u["plan_s"] for u in ups[1:]]
            replaces += [u["transfer_s"] for u in ups[1:]]
            answers = [x["answer"] for x in log["answers"]]
            home = sum(1 for u in ups if u["why"].startswith("low battery"))
            print(f"battery {d}: {len(ups)} missions ({len(ups) - 1} replaced, {home} low "
                  f"battery), {len(answers)} sites judged ({answers.count('mound')} mound, "
                  f"{answers.count('undecided')} undecided), {log['status']}, landed "
                  f"{aircraft.landed} with {aircraft.charge():.0%} "  # type: ignore
                  f"(reserve {fly.FlyOptions(a.range_m).reserve:.0%}), flown "
                  f"{aircraft.flown_m:.0f} m", flush=True)  # type: ignore[attr-defined]
            if d == a.figure_battery and a.figure:
                figure(log, aircraft, a.figure, a.fault)
    print(f"\nre-plan (mound_plan and the mission built), s: min {min(plans):.3f} median "
          f"{statistics.median(plans):.3f} ({len(plans)} re-plans)")
    print(f"replacement in the air (upload, read back, current item set), s: min "
          f"{min(replaces):.3f} median {statistics.median(replaces):.3f}")
    ref = reference_uploads(missions)
    print(f"reference: the last missions uploaded and read back on a vehicle at rest "
          f"(mound mission upload's path), s: min {min(ref):.3f} median "
          f"{statistics.median(ref):.3f}; replacement / reference (medians) "
          f"{statistics.median(replaces) / statistics.median(ref):.2f}")


if __name__ == "__main__":
    main()
