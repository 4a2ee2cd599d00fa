"""A field day battery by battery (`mound day`; INTERFACES.md, "A field day").

    mound day --out DIR [survey options] [--batteries K] [--photos CARD_1 --photos CARD_2 ...]

The survey (python/mission.py) run with `--learn --flights K --cards CARD_1 ...`: battery
k's missions are written to DIR/battery_k/ in every format the crew flies (.plan,
.waypoints, .kmz, .csv; plan.json, mission.json); after it lands, the same command with
its card added sorts the card into its sites (DIR/battery_k/photos/), judges them, refits
the coarse classifier with the verdicts (weighted by their confidence), re-plans the
batteries left over the sites not flown, and writes battery k+1's missions. The sites its
verdicts left undecided with a second look advised get the survey's second-look missions
(DIR/second_look/, a scan as wide as the verdicts asked: not the battery's scan, so they
are a mission of their own). DIR/day.json (mound.day v1) says per battery the plan flown,
the sites judged, the second looks added and the plan of the batteries left. The same
flags give the same day: every stage is kept by its inputs' digests, so a run with one
more card reuses the batteries judged before.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from mound.args import Parser, UsageError
from mound.bounds import FLIGHTS
from mound.formats.day import SCHEMA, VERSION, Battery, DayDoc, NextBattery
from mound.formats.learn import LearnRecord
from mound.formats.mission import MissionSummary
from mound.formats.plan import Plan
from mound.formats.survey import SurveyAnswers
from mound.jsonio import write_json

SET_BY_DAY = ("--learn", "--flights", "--cards", "--photos", "--second-photos",
              "--images-root")


DESCRIPTION = ("A field day battery by battery: each battery's missions written, its card "
               "judged after it lands, the batteries left re-planned")
EPILOG = ("Every other option is the survey's (python python/mission.py --help); --learn, "
          "--flights and --cards are set by the day.")


def _arguments(p: Any) -> None:
    p.add_argument("--out", required=True, help="the day's folder (the survey's run folder)")
    p.add_argument("--batteries", type=FLIGHTS.arg(), default=4,
                   help="batteries (flights) the day has (default 4)")
    p.add_argument("--photos", action="append", default=[], metavar="CARD_K",
                   help="battery k's card, in the order flown (once per battery landed)")


def parser() -> Parser:
    p = Parser(prog="mound day", description=DESCRIPTION, epilog=EPILOG)
    _arguments(p)
    return p


def add_parser(sub: Any, parser_class: type) -> None:
    """`mound day` in `mound --help` (mound.cli hands its arguments to main(), where the
    survey's options pass through)."""
    _arguments(sub.add_parser("day", help="a field day battery by battery",
                              description=DESCRIPTION, epilog=EPILOG))


def main(argv: list[str]) -> int:
    from mound.survey import driver

    known, rest = parser().parse_known_args(argv)
    for flag in SET_BY_DAY:
        if any(r == flag or r.startswith(flag + "=") for r in rest):
            raise UsageError(f"{flag}: mound day sets it (give --batteries and one --photos "
                             "per battery landed)")
    if len(known.photos) > known.batteries:
        raise UsageError(f"--photos: {len(known.photos)} cards for --batteries "
                         f"{known.batteries}")
    code = driver.main(["--out", known.out, *rest, "--learn", "--flights",
                        str(known.batteries), "--cards", *known.photos])
    out = Path(known.out)
    if code not in (0, 3) or not (out / "learn" / "learn.json").is_file():
        return code
    doc = day_doc(out, known.batteries, known.photos)
    write_json(out / "day.json", doc)
    nxt = doc["next"]
    print(f"day: {len(doc['flown'])} of {known.batteries} batteries judged"
          + (f"; battery {nxt['battery']} to fly: {nxt['folder']}/ ({len(nxt['sites'])} "
             f"sites)" if nxt else "") + f" -> {out / 'day.json'}")
    return code


def _flights(path: Path) -> list[list[str]]:
    """The sites of each flight of a plan file (none when it is missing)."""
    if not path.is_file():
        return []
    return [list(f.sites) for f in Plan.read(path).flights]


def day_doc(out: Path, batteries: int, cards: list[str]) -> DayDoc:
    """day.json from the run's files: learn/learn.json, learn/flight_K/plan_all.json (the
    batteries left, re-planned), battery_K/plan.json, second_look/mission.json (the second
    looks the verdicts advised) and summary.json (each site's answer)."""
    learn = LearnRecord.read(out / "learn" / "learn.json")
    summary = SurveyAnswers.read(out / "summary.json")
    answer = summary.answers
    sl_path = out / "second_look" / "mission.json"
    sl = MissionSummary.read(sl_path).second_look if sl_path.is_file() else None
    advised = set(sl.sites if sl else ())
    rows: list[Battery] = []
    for f in learn.flights:
        k = f.flight
        left = _flights(out / "learn" / f"flight_{k + 1}" / "plan_all.json")
        rows.append({"battery": k, "card": cards[k - 1] if k <= len(cards) else None,
                     "folder": f"battery_{k}",
                     "plan": {"sites": list(f.sites), "cost_m": f.cost_m},
                     "judged": [{"id": sid, "answer": answer.get(sid)} for sid in f.sites],
                     "second_looks_added": [sid for sid in f.sites if sid in advised],
                     "plan_left": left})
    waiting = learn.waiting_for_battery
    nxt: NextBattery | None = None
    if waiting is not None:
        nxt = {"battery": waiting, "folder": f"battery_{waiting}",
               "sites": [s for fl in _flights(out / f"battery_{waiting}" / "plan.json")
                         for s in fl]}
    return {"schema": SCHEMA, "version": VERSION, "status": summary.status,
            "batteries": batteries, "flown": rows, "next": nxt,
            "second_looks": {"folder": "second_look", "sites": sorted(advised),
                             "scan_factor": sl.scan_factor,
                             "refused": [r.to_doc() for r in sl.refused]} if sl else None,
            "stopped": learn.stopped,
            "learn_weight": learn.learn_weight}
