"""In flight, on MAVLink (`mound fly --connect ...`, on a companion computer or a laptop on
the telemetry radio): each site judged while the aircraft flies on, the rest of the flight
re-planned with the battery left, the mission replaced in the air.

The loop:
1. mound_plan plans one flight over the sites (their value: mound.recon.visit_value) with
   the battery's range less the reserve; its mission (flat, heights above home) is
   uploaded, read back and compared.
2. The aircraft flies it. When MISSION_CURRENT passes a site's last scan item, the site is
   judged (the judge runs beside the loop: the aircraft does not wait). Its answer moves
   the site's p by Bayes' rule with the verdict's confusion (an undecided site may be
   flown again with `max_visits` 2).
3. After each answer, and whenever BATTERY_STATUS says the charge left cannot fly what is
   left of the mission, the rest is re-planned: the items up to the end of the site being
   flown (or approached) are kept as they are, mound_plan plans the rest from its last
   waypoint to home with the range the battery has left, and the mission is replaced with
   the mission protocol: read back, the current item made current again
   (transfer.replace). The vehicle flies its old mission until the new one is accepted.
4. Low battery: when the charge left cannot finish the site in progress and get home, the
   mission becomes the items flown so far and a return to launch at the current item.

The battery's charge is read as a share of a full battery's range (`range_m`, the
distance a full battery flies at cruise with the scan's speeds) less a reserve. Only the
simulated judge exists: it draws each answer from the verdict's measured confusion and
the site's truth (the sites file must hold it); judging a real site's photos in flight is
not built. Writes fly.json (mound.fly v1): every upload and why, every answer.
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from mound import native
from mound.errors import InputError, ToolInputError, ToolNoResultError
from mound.formats.plan import Plan
from mound.formats.sites import Node, Site, Sites
from mound.geometry.geodesy import Origin, geodetic_to_enu
from mound.jsonio import write_json
from mound.recon import visit_value as vv
from mound.survey.reward import read_confusion
from mound.survey.stages.learn import NO_ROUND_TRIP
from mound.uav import mission
from mound.uav.mavlink import link as mavlink_link
from mound.uav.mavlink import transfer
from mound.uav.mission_items import (
    DO_CHANGE_SPEED,
    FRAME_MISSION,
    NAV_COMMANDS,
    NAV_LAND,
    NAV_RETURN_TO_LAUNCH,
    NAV_TAKEOFF,
    MissionItem,
)

SCHEMA = "mound.fly"
VERSION = 1
HERE = "here"  # the re-plan's start: the last waypoint of what is kept


class Judge(Protocol):
    def __call__(self, site: Site) -> str:
        """The verdict's answer on a site just scanned: mound, undecided or no_mound."""
        ...


@dataclass
class SimulatedJudge:
    """Answers drawn from the verdict's confusion and the site's truth (a tumulus by its
    height class, else by `tumulus`, the mean over a population), after `delay_s`."""

    conf: vv.Confusion
    tumulus: np.ndarray
    seed: int = 0
    delay_s: float = 0.0
    rng: np.random.Generator = field(init=False)

    def __post_init__(self) -> None:
        self.rng = np.random.default_rng([self.seed, 69])

    def __call__(self, site: Site) -> str:
        if site.truth is None:
            raise InputError(f"sites: {site.id}.truth: missing (the simulated judge draws "
                             "its answer from the site's truth)")
        if site.truth.mound:
            h = site.truth.height_m
            rates = self.conf.tumulus[vv.height_class(h)] if h is not None else self.tumulus
        else:
            rates = np.asarray(self.conf.none)
        time.sleep(self.delay_s)
        return vv.drawn_answer(rates, float(self.rng.random()))


@dataclass
class Scan:
    """A site's scan in the mission held: its first and last item."""

    site: str
    first: int
    last: int


@dataclass
class FlyOptions:
    range_m: float            # a full battery's flight distance
    reserve: float = 0.15     # share of the range kept for landing
    max_visits: int = 1       # 2: an undecided site may be flown again, the same scan
    seed: int = 1
    timeout_s: float = 3600.0


@dataclass
class InFlight:
    """The state of a flight: the sites' p and answers, and the mission the aircraft holds."""

    sites: Sites
    conf: vv.Confusion
    tumulus: np.ndarray
    opts: FlyOptions
    work: Path
    p: dict[str, float] = field(default_factory=dict)
    answers: dict[str, str] = field(default_factory=dict)
    visits: dict[str, int] = field(default_factory=dict)
    items: list[MissionItem] = field(default_factory=list)
    scans: list[Scan] = field(default_factory=list)
    next_scans: list[Scan] = field(default_factory=list)  # those of the mission replan made
    aircraft: np.ndarray | None = None  # ENU, z above home (GLOBAL_POSITION_INT)
    log: dict[str, Any] = field(default_factory=dict)
    t0: float = field(default_factory=time.monotonic)

    def __post_init__(self) -> None:
        if self.sites.origin is None:
            raise InputError("sites: origin: missing (the mission is flown in WGS84)")
        self.origin: Origin = self.sites.origin
        for s in self.sites.sites:
            if s.p_mound is None:
                raise InputError(f"sites: {s.id}.p_mound: missing (a visit's value needs it)")
            self.p[s.id] = s.p_mound
        self.home = np.array([self.sites.home.x_m, self.sites.home.y_m])
        self.log = {"schema": SCHEMA, "version": VERSION, "status": "flying",
                    "range_m": self.opts.range_m, "reserve": self.opts.reserve,
                    "uploads": [], "answers": [], "battery": []}

    # -- planning -------------------------------------------------------------------------
    def _pool(self, busy: set[str]) -> list[Site]:
        ids = [s.id for s in self.sites.sites]
        value = vv.visit_value(np.array([self.p[i] for i in ids]), self.tumulus,
                               self.conf.none)
        return [replace(s, reward=float(v)) for s, v in zip(self.sites.sites, value,
                                                             strict=True)
                if s.id not in busy and v > 1e-9 and self.answers.get(s.id, "undecided")
                == "undecided" and self.visits.get(s.id, 0) < self.opts.max_visits]

    def _plan(self, start: np.ndarray | None, budget_m: float, busy: set[str]
              ) -> mission.Mission | None:
        """mound_plan's flight over the sites worth a visit, from `start` (None: home) to
        home within `budget_m`, as a mission; None when no site fits."""
        pool = self._pool(busy)
        if not pool or budget_m <= 0:
            return None
        home = (self.sites.home if start is None
                else Node(HERE, float(start[0]), float(start[1])))
        left = Sites(home, self.sites.home, budget_m, tuple(pool), self.origin,
                     self.sites.takeoff_landing_m, self.sites.extra)
        n = len(self.log["uploads"])
        path, out = self.work / f"sites_{n}.json", self.work / f"plan_{n}.json"
        write_json(path, left.to_doc())
        try:
            native.run_tool("mound_plan", [str(path), "--flights", "1", "--seed",
                                           str(self.opts.seed), "--out", str(out)],
                            timeout_s=120)
        except ToolNoResultError:
            return None
        except ToolInputError as e:
            if NO_ROUND_TRIP in e.tail:
                return None
            raise RuntimeError(f"mound_plan refused the sites left (a bug): {e}") from e
        plan = Plan.read(out)
        if not plan.flights or not plan.flights[0].sites:
            return None
        return mission.build(plan, self.origin)

    def first_mission(self) -> list[MissionItem]:
        m = self._plan(None, self.opts.range_m * (1 - self.opts.reserve), set())
        if m is None:
            raise InputError("sites: no site is within a flight of the battery's range "
                             "(--range-m less the reserve)")
        self.items = list(m.items)
        self.scans = [Scan(s, a, b) for s, (a, b) in m.scans.items()]
        return self.items

    # -- geometry of the mission held -----------------------------------------------------
    def _positions(self, items: list[MissionItem]) -> list[np.ndarray | None]:
        """Each item's ENU position (x, y; z above home), None for a command item."""
        out: list[np.ndarray | None] = []
        last = np.array([self.home[0], self.home[1], 0.0])
        for it in items:
            if it.command == NAV_RETURN_TO_LAUNCH:
                last = np.array([self.home[0], self.home[1], 0.0])
            elif it.command in NAV_COMMANDS:
                e = geodetic_to_enu(self.origin, np.array([[it.x * 1e-7, it.y * 1e-7, 0.0]]))[0]
                z = 0.0 if it.command == NAV_LAND else float(it.z)
                last = np.array([e[0], e[1], z]) if it.command != NAV_TAKEOFF else \
                    np.array([last[0], last[1], float(it.z)])
            else:
                out.append(None)
                continue
            out.append(last)
        return out

    def _distance(self, cur: int, end: int) -> tuple[float, np.ndarray]:
        """The flight from the aircraft (where GLOBAL_POSITION_INT last put it, else the
        last position before item `cur`) through item `end`, and where it ends."""
        pos = self._positions(self.items)
        before = [p for p in pos[:cur] if p is not None]
        at = (self.aircraft if self.aircraft is not None else before[-1] if before
              else np.array([self.home[0], self.home[1], 0.0]))
        total = 0.0
        for p in pos[cur:end + 1]:
            if p is not None:
                total += float(np.linalg.norm(p - at))
                at = p
        return total, at

    # -- the loop's decisions --------------------------------------------------------------
    def position(self, msg: Any) -> None:
        """The aircraft's position from a GLOBAL_POSITION_INT (one out of range is
        ignored)."""
        if not (abs(msg.lat) <= 900_000_000 and abs(msg.lon) <= 1_800_000_000):
            return
        e = geodetic_to_enu(self.origin, np.array([[msg.lat * 1e-7, msg.lon * 1e-7, 0.0]]))[0]
        self.aircraft = np.array([e[0], e[1], msg.relative_alt * 1e-3])

    def range_left(self, charge: float) -> float:
        return (charge - self.opts.reserve) * self.opts.range_m

    def needs_replan(self, cur: int, charge: float) -> bool:
        """True when the charge left cannot fly the rest of the mission held."""
        need, _ = self._distance(cur, len(self.items) - 1)
        return self.range_left(charge) < need

    def replan(self, cur: int, charge: float, pending: set[str]
               ) -> tuple[list[MissionItem], str] | None:
        """The new mission (the current item kept at `cur`) and why, or None to keep the
        one held."""
        ahead = next((s for s in self.scans if s.last >= cur), None)
        keep_end = ahead.last if ahead is not None else len(self.items) - 1
        if ahead is None:
            return None  # on the way home
        kept, exit_at = self._distance(cur, keep_end)
        home_leg = float(np.linalg.norm(exit_at[:2] - self.home))
        left = self.range_left(charge)
        if left < kept + home_leg:
            new = [*self.items[:cur], MissionItem(NAV_RETURN_TO_LAUNCH, FRAME_MISSION)]
            return new, f"low battery: {charge:.0%} cannot finish {ahead.site} and get home"
        # not to plan again: the sites kept ahead, and those flown whose answer is not in
        busy = {s.site for s in self.scans if cur <= s.last <= keep_end} | pending
        m = self._plan(exit_at[:2], left - kept, busy)
        if m is None:
            rest = [MissionItem(NAV_RETURN_TO_LAUNCH, FRAME_MISSION)]
            scans: list[Scan] = []
        else:
            if m.items[0].command != NAV_TAKEOFF or m.items[1].command != DO_CHANGE_SPEED:
                raise RuntimeError("mission.build: a flight no longer starts with take-off "
                                   "and cruise speed (fly.replan drops them)")
            rest = list(m.items[2:])
            base = keep_end + 1 - 2
            scans = [Scan(s, a + base, b + base) for s, (a, b) in m.scans.items()]
        new = [*self.items[:keep_end + 1], *rest]
        if len(new) == len(self.items) and all(a.same_as(b) for a, b in zip(
                new, self.items, strict=True)):
            return None
        self.next_scans = [s for s in self.scans if s.last <= keep_end] + scans
        sites = [s.site for s in scans]
        return new, f"re-planned from {ahead.site}: {len(sites)} sites after it"

    def accept(self, new: list[MissionItem], cur: int, why: str, stats: Any) -> None:
        """The vehicle holds `new` now."""
        low = why.startswith("low battery")
        self.scans = ([s for s in self.scans if s.last < cur] if low
                      else self.next_scans)
        self.items = new
        self.log["uploads"].append({
            "t_s": round(time.monotonic() - self.t0, 3), "items": len(new), "current": cur,
            "why": why, "sites": [s.site for s in self.scans if s.last >= cur],
            "upload_s": round(stats.elapsed_s, 3), "verified": bool(stats.verified)})

    def answered(self, site: str, answer: str) -> None:
        before = self.p[site]
        after = float(vv.after_answer(before, answer, self.tumulus, self.conf.none))
        self.p[site] = after
        self.answers[site] = answer
        self.log["answers"].append({"t_s": round(time.monotonic() - self.t0, 3),
                                    "site": site, "answer": answer,
                                    "visit": self.visits.get(site, 0),
                                    "p_before": before, "p_after": after})


def fly(link: mavlink_link.Link, state: InFlight, judge: Judge, out: Path) -> dict[str, Any]:
    """Flies the day's battery over `link` until the aircraft lands (or the time-out);
    returns the log (also written to `out`)."""
    items = state.first_mission()
    stats = transfer.upload_verified(link, items)
    transfer.set_current(link, 0)
    state.log["uploads"].append({"t_s": 0.0, "items": len(items), "current": 0,
                                 "why": "first plan",
                                 "sites": [s.site for s in state.scans],
                                 "upload_s": round(stats.elapsed_s, 3), "verified": True})
    write_json(out, state.log)
    by_id = state.sites.by_id()
    cur, charge = 0, 1.0
    submitted: set[tuple[str, int]] = set()
    futures: dict[cf.Future[str], str] = {}
    deadline = time.monotonic() + state.opts.timeout_s
    low_at = 1.0  # the charge at the last re-plan the battery asked for
    with cf.ThreadPoolExecutor(max_workers=1) as pool:
        while time.monotonic() < deadline:
            msg = link.recv(["MISSION_CURRENT", "BATTERY_STATUS", "MISSION_ITEM_REACHED",
                             "GLOBAL_POSITION_INT"], 0.05)
            replan = False
            if msg is not None and msg.get_type() == "GLOBAL_POSITION_INT":
                state.position(msg)
            elif msg is not None and msg.get_type() == "MISSION_CURRENT" and \
                    msg.seq < len(state.items):
                cur = int(msg.seq)
            elif msg is not None and msg.get_type() == "BATTERY_STATUS" and \
                    0 <= msg.battery_remaining <= 100:  # -1: the vehicle does not know
                charge = msg.battery_remaining / 100
                # a re-plan the battery asks for, once per 2 % of charge lost
                replan = charge <= low_at - 0.02 and state.needs_replan(cur, charge)
                if replan:
                    low_at = charge
                    state.log["battery"].append({"t_s": round(time.monotonic() - state.t0, 3),
                                                 "charge": charge, "current": cur})
            elif msg is not None and msg.get_type() == "MISSION_ITEM_REACHED" and \
                    msg.seq == len(state.items) - 1 and \
                    state.items[-1].command in (NAV_RETURN_TO_LAUNCH, NAV_LAND):
                break
            for s in state.scans:
                key = (s.site, s.first)
                if s.last < cur and key not in submitted:
                    submitted.add(key)
                    state.visits[s.site] = state.visits.get(s.site, 0) + 1
                    futures[pool.submit(judge, by_id[s.site])] = s.site
            for f in [f for f in futures if f.done()]:
                state.answered(futures.pop(f), f.result())
                replan = True
            if replan:
                _replace(link, state, cur, charge, set(futures.values()))
                write_json(out, state.log)
        else:
            state.log["status"] = "failed"
            state.log["why"] = f"the aircraft had not landed after {state.opts.timeout_s:g} s"
        for f, site in futures.items():
            state.answered(site, f.result())
    if state.log["status"] == "flying":
        state.log["status"] = "ok"
    state.log["sites"] = {s.id: {"answer": state.answers.get(s.id), "p": state.p[s.id],
                                 "visits": state.visits.get(s.id, 0)}
                          for s in state.sites.sites}
    write_json(out, state.log)
    return state.log


def _replace(link: mavlink_link.Link, state: InFlight, cur: int, charge: float,
             pending: set[str]) -> None:
    t = time.monotonic()
    r = state.replan(cur, charge, pending)
    if r is None:
        return
    new, why = r
    t_plan = time.monotonic()
    try:
        stats = transfer.replace(link, new, min(cur, len(new) - 1))
    except mavlink_link.LinkError as e:  # the vehicle flies the mission it held
        state.log["uploads"].append({"t_s": round(time.monotonic() - state.t0, 3),
                                     "why": why, "failed": str(e)})
        return
    state.accept(new, cur, why, stats)
    state.log["uploads"][-1].update(plan_s=round(t_plan - t, 3),
                                    transfer_s=round(time.monotonic() - t_plan, 3))


def cmd_fly(args: argparse.Namespace) -> int:
    sites = Sites.read(args.sites)
    untold = next((s.id for s in sites.sites if s.truth is None), None)
    if untold is not None:
        raise InputError(f"{args.sites}: sites: {untold}.truth: missing (--judge simulate "
                         "draws each answer from the site's truth)")
    conf = read_confusion(args.confusion)
    tumulus = conf.tumulus_mean({c: 1.0 for c in conf.tumulus})
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    state = InFlight(sites, conf, tumulus, FlyOptions(
        args.range_m, args.reserve, args.max_visits, args.seed, args.timeout), out)
    judge = SimulatedJudge(conf, tumulus, args.seed, args.judge_delay)
    key = mavlink_link.signing_key(args.signing_key, args.signing_passphrase)
    try:
        lk = mavlink_link.connect(args.connect, key, args.accept_unsigned)
    except mavlink_link.LinkError as e:
        raise InputError(str(e)) from e
    try:
        log = fly(lk, state, judge, out / "fly.json")
    except mavlink_link.LinkError as e:
        raise InputError(str(e)) from e
    finally:
        lk.close()
    n = sum(1 for u in log["uploads"] if "failed" not in u)
    print(f"{n} missions uploaded ({n - 1} replaced in flight); "
          f"{len(log['answers'])} answers; {log['status']}: {out / 'fly.json'}")
    return 0 if log["status"] == "ok" else 3


def add_parser(sub: Any, parser_class: type) -> None:
    from mound.bounds import Bound

    p = sub.add_parser("fly", help="in flight on MAVLink: sites judged as they are flown, the "
                       "rest re-planned with the battery left and the mission replaced")
    p.add_argument("--connect", required=True, help="udpout:HOST:PORT, tcp:HOST:PORT, ...")
    p.add_argument("--sites", required=True, help="mound.sites v1 (with origin, p_mound and, "
                   "for the simulated judge, truth)")
    p.add_argument("--confusion", required=True, help="a verdict model (trained.confusion) or "
                   "an eval-verdict report")
    p.add_argument("--range-m", type=Bound(100, 1e6).arg(), required=True,
                   help="a full battery's flight distance, m")
    p.add_argument("--reserve", type=Bound(0, 0.9).arg(), default=0.15,
                   help="share of the range kept for landing (default 0.15)")
    p.add_argument("--max-visits", type=Bound(1, 5, integer=True).arg(), default=1,
                   help="visits of a site in the flight (default 1; 2: an undecided site "
                   "may be flown again with the same scan, which the verdict's second look "
                   "does not ask for: it asks for a wider one)")
    p.add_argument("--judge", choices=("simulate",), default="simulate",
                   help="simulate: answers drawn from the confusion and the sites' truth")
    p.add_argument("--judge-delay", type=Bound(0, 600).arg(), default=0.0,
                   help="seconds a simulated answer takes")
    p.add_argument("--seed", type=Bound(0, 2**31, integer=True).arg(), default=1)
    p.add_argument("--timeout", type=Bound(1, 86400).arg(), default=3600.0,
                   help="give up after this many seconds")
    p.add_argument("--signing-key", help="64 hex digits")
    p.add_argument("--signing-passphrase")
    p.add_argument("--accept-unsigned", action="store_true")
    p.add_argument("--out", required=True, help="directory for fly.json and the plans")
    p.set_defaults(func=cmd_fly)

