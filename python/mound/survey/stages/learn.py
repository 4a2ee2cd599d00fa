"""Each flight teaches the next (`python python/mission.py --flights K --learn`).

Flights are flown (simulated) one after another. Flight 1 is plan.json's first flight (the
one of highest reward). After flight k, every site it judged becomes a training example
of the coarse classifier: its Statlog features with the verdict's label, weighted by the
verdict's confidence (the probability that the verdict is right) times `--learn-weight`.
The classifier is refitted on sat.trn plus these examples; p_mound and the reward (binary
entropy) of every site are recomputed, and mound_plan re-plans the K - k flights left
over the sites not yet flown, of which flight k + 1 is the one of highest reward.

The run directory keeps, per flight, learn/flight_k/: sites.json (what was planned on),
plan.json (the flight flown), mission.plan (its MAVLink mission), model.json (the
classifier after it), sites_after.json (p_mound and rewards after it); and
learn/learn.json (mound.learn v1: per flight its sites, verdicts, the examples, the
classifier's AUC, how p changed), learn/plan_flown.json (the flights as flown, for the
report) and learn/sites_final.json (the final classifier's p_mound).

Honest evaluation: the field's sites are rows of sat.tst, and the verified ones become
training rows, so the AUC before and after is measured on sat.tst without any of the
field's 100 rows (flown or not).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from mound import native
from mound.classify import coarse, metrics, statlog
from mound.classify.model import SCHEMA as MODEL_SCHEMA
from mound.classify.model import VERSION as MODEL_VERSION
from mound.classify.model import Model
from mound.classify.reward import binary_entropy_bits
from mound.errors import InputError, ToolInputError, ToolNoResultError
from mound.formats.learn import Change, Example, FlightLearned, LearnRecord
from mound.formats.plan import Flight, Plan
from mound.formats.site_row import SiteRow
from mound.formats.sites import Sites
from mound.jsonio import read_json, write_json
from mound.survey.context import Context, card_digest, mission_terrain, run_stage
from mound.survey.reward import Reward, reward_of
from mound.survey.stages.sites3d import run_jobs, second_look_missions, site_jobs
from mound.uav import files as mission_files
from mound.uav import mission

# mound_plan's words (exit 2, naming budget_m) when no site is within a round trip of home
NO_ROUND_TRIP = "too small to leave home"


def statlog_rows(sites: Sites) -> np.ndarray:
    """The Statlog row each site of the standard field holds (its truth says which)."""
    rows = [s.truth.statlog_row if s.truth else None for s in sites.sites]
    missing = [s.id for s, r in zip(sites.sites, rows, strict=True) if r is None]
    if missing:
        raise InputError(f"sites: {missing[0]}.truth.statlog_row: missing (--learn learns on "
                         "the standard field, whose sites are Statlog rows)")
    return np.array(rows, dtype=int)


def with_model(sites: Sites, model: Model, test: statlog.Split,
               reward_of: Reward = binary_entropy_bits) -> Sites:
    """The sites with every site's p_mound and reward (`reward_of` p) from `model` (the
    site's Statlog row's features)."""
    p = model.predict(test.x[statlog_rows(sites)])
    reward = reward_of(p)
    return sites.with_sites(
        [replace(s, p_mound=float(pk), reward=float(rk))
         for s, pk, rk in zip(sites.sites, p, reward, strict=True)],
        provenance={**sites.extra.get("provenance", {}), "total_reward": float(reward.sum())})


def held_out_auc(model: Model, test: statlog.Split, field_rows: np.ndarray) -> float:
    """AUC on sat.tst without the field's rows (none of them trains or judges)."""
    keep = np.ones(len(test.cls), dtype=bool)
    keep[field_rows] = False
    return float(metrics.roc_auc(model.predict(test.x[keep]), test.y[keep]))


def one_flight(plan: Plan, number: int) -> Plan | None:
    """The flight of highest reward of a plan (mound_plan orders flights so), as a plan of
    that one flight (`flight`: its number among the flights flown); None when no flight
    visits a site."""
    flights = [f for f in plan.flights if f.sites]
    if not flights:
        return None
    return replace(plan, flights=tuple(flights[:1]), extra={**plan.extra, "flight": number,
                                                     "n_visited": len(flights[0].sites)})


def _write_mission(ctx: Context, plan: Plan, out: Path) -> None:
    """The flight's MAVLink mission (refused, like the mission stage's, when it breaks the
    budget or, over a DEM, cannot clear the ground)."""
    if plan.origin is None:
        raise InputError("plan: origin: missing (the mission is flown in WGS84)")
    m = mission.build(plan, plan.origin,
                      None,  # the plan's own scan (Plan.scan), else the default
                      mission_terrain(ctx.args))
    mission_files.write_plan(out, m, ctx.args.firmware)


def _replan(ctx: Context, left: Sites, k: int, fdir: Path) -> tuple[Plan | None, str]:
    """Flight k's plan (mound_plan over the sites `left` for the flights left), or None and
    why no flight is left."""
    a = ctx.args
    write_json(fdir / "sites.json", left.to_doc())
    try:
        native.run_tool("mound_plan", [str(fdir / "sites.json"), "--algo", a.algo,
                                       "--seed", str(a.plan_seed), "--flights",
                                       str(a.flights - k + 1), "--out",
                                       str(fdir / "plan_all.json")],
                        timeout_s=600, log=ctx.tree.root / "log.txt")
    except (ToolInputError, ToolNoResultError) as e:
        # The sites left (a subset of valid sites, the same budget) allow no flight: every
        # one within reach was flown. mound_plan says so with exit 3, or with exit 2 naming
        # budget_m when no site left is within a round trip (INTERFACES.md); any other
        # exit 2 is a bug in the file written above and reaches the survey's main (exit 1).
        if isinstance(e, ToolInputError) and NO_ROUND_TRIP not in e.tail:
            raise RuntimeError(f"flight {k}: mound_plan refused the sites left (a bug): "
                               f"{e}") from e
        why = (e.tail.strip().splitlines() or [str(e)])[-1]
        return None, f"flight {k}: no flight over the sites left ({why})"
    return Plan.read(fdir / "plan_all.json"), ""


def _write_battery(ctx: Context, plan: Plan, sites: Sites, bdir: Path) -> list[str]:
    """A day on cards: battery k's folder DIR/battery_k/ (INTERFACES.md, `mound day`): its
    plan and the sites it was planned on (plan.json, sites.json: what `mound photos sort`
    and `mound sim flight` read) and its mission
    in every format the crew flies (the mission stage's files: .plan, .waypoints, .kmz,
    .csv, .geojson, mission.png, mission.json); a format a limit refuses is left out and
    mission.json says why."""
    from mound.survey.stages.mission import write_missions

    if plan.origin is None:
        raise InputError("plan: origin: missing (the mission is flown in WGS84)")
    m = mission.build(plan, plan.origin, None, mission_terrain(ctx.args))
    bdir.mkdir(parents=True, exist_ok=True)
    write_json(bdir / "plan.json", plan.to_doc())
    write_json(bdir / "sites.json", sites.to_doc())
    written, summary = write_missions([(None, m)], bdir, bdir, ctx.args.firmware,
                                      ctx.args.aircraft)
    write_json(bdir / "mission.json", summary.to_doc())
    root = ctx.tree.root
    return [str(p.relative_to(root))
            for p in [bdir / "plan.json", bdir / "sites.json", *written,
                      bdir / "mission.json"]]


def _flight_jobs(ctx: Context, k: int, flight: Plan, current: Sites, fdir: Path,
                 outputs: list[str]) -> list[Any] | None:
    """Flight k's site jobs: simulated, or on a day on cards (--cards) its battery's folder
    written and its card's photos (None: its card is not there yet)."""
    a = ctx.args
    if a.cards is None:
        _write_mission(ctx, flight, fdir / "mission.plan")
        return site_jobs(ctx, flight)
    bdir = ctx.tree.root / f"battery_{k}"
    outputs += _write_battery(ctx, flight, current, bdir)
    if k > len(a.cards):
        return None
    return site_jobs(ctx, flight, _battery_photos(ctx, a.cards[k - 1], bdir, flight))


def _battery_photos(ctx: Context, card: str, bdir: Path, flight: Plan) -> dict[str, Path]:
    """Battery k's card sorted into its sites: bdir/photos/<id> (and photos.json)."""
    from mound.photos.sort import SortSpec, sort_card

    a = ctx.args
    doc = sort_card(card, str(bdir / "plan.json"), str(bdir / "photos"),
                    SortSpec(site_diameter_m=a.site_diameter_m), a.camera)
    ok = sum(1 for v in doc.sites.values() if v.status == "ok")
    ctx.say(f"[learn] {card}: {doc.files} files, {ok} of {len(doc.sites)} "
            "sites with enough photos")
    return {sid: bdir / "photos" / sid for sid in flight.visited()}


def _examples(rows: dict[str, SiteRow], ids: list[str]) -> list[Example]:
    """The training examples of a flight's sites: each judged site's two-answer verdict and
    its confidence (an undecided site, no evidence either way, is not learned)."""
    out = []
    for sid in ids:
        r = rows.get(sid)
        v = r.verdict if r is not None and r.ok else None
        if v is None or v.label == "undecided":
            continue
        if v.confidence is None:  # a judged site's verdict always states one
            raise RuntimeError(f"site {sid}: its row has no confidence")
        out.append(Example(sid, v.two_answer, v.confidence))
    return out


def _changes(before: Sites, after: Sites, flown: list[str]
             ) -> tuple[list[Change], int]:
    """How p_mound of the sites not flown changed, largest first, and how many of the
    classifier's labels flipped."""
    p0 = {s.id: float(s.p_mound or 0.0) for s in before.sites}  # with_model sets each
    changes = sorted((Change(s.id, p0[s.id], float(s.p_mound or 0.0))
                      for s in after.sites if s.id not in flown),
                     key=lambda c: -abs(c.p_after - c.p_before))
    flips = sum(1 for c in changes
                if metrics.says_mound(c.p_before) != metrics.says_mound(c.p_after))
    return changes, flips


def _write_flown(ctx: Context, flights: list[Flight], n_visited: int, sites: Sites) -> None:
    """learn/plan_flown.json (the plan as flown: its flights one after another; none flown:
    one flight from home to its end) and learn/sites_final.json (the final classifier's
    p_mound)."""
    t = ctx.tree
    planned = Plan.read(t.plan)
    flown = flights or [Flight((planned.home, planned.end), 0.0, 0.0, planned.budget_m)]
    write_json(t.final_plan(True), replace(planned, flights=tuple(flown), extra={
        **planned.extra, "n_visited": n_visited}).to_doc())
    write_json(t.final_sites(True), sites.to_doc())


def stage_learn(ctx: Context) -> str:
    """The sites3d stage, flight by flight, with the classifier learning in between."""
    a = ctx.args
    t = ctx.tree

    def work() -> tuple[list[str], str, bool]:
        train, test = statlog.load("sat.trn"), statlog.load("sat.tst")
        model = Model.from_doc(read_json(t.model, MODEL_SCHEMA, MODEL_VERSION), str(t.model))
        sites0 = Sites.read(t.sites)
        field_rows = statlog_rows(sites0)
        row_of = dict(zip((s.id for s in sites0.sites), field_rows.tolist(), strict=True))
        auc0 = held_out_auc(model, test, field_rows)
        current = sites0
        plan = Plan.read(t.plan)
        first_plan = [list(f.sites) for f in plan.flights if f.sites]
        flown: list[str] = []
        ex_rows: list[int] = []
        ex_y: list[float] = []
        ex_w: list[float] = []
        history: list[FlightLearned] = []
        flights_flown: list[Flight] = []
        outputs: list[str] = []
        latest: dict[str, SiteRow] = {}  # each site's row
        waiting: int | None = None        # a day on cards: the battery whose card is due
        complete, stopped, root = True, "", t.root.resolve()
        for k in range(1, a.flights + 1):
            fdir = t.learn / f"flight_{k}"
            fdir.mkdir(parents=True, exist_ok=True)
            if k > 1:
                left = [s for s in current.sites if s.id not in flown]
                if not left:
                    break
                replanned, stopped = _replan(ctx, current.with_sites(left), k, fdir)
                if replanned is None:
                    break
                plan = replanned
            else:
                write_json(fdir / "sites.json", current.to_doc())
            flight = one_flight(plan, k)
            if flight is None:
                stopped = f"flight {k}: no site within the budget"
                break
            write_json(fdir / "plan.json", flight.to_doc())
            jobs = _flight_jobs(ctx, k, flight, current, fdir, outputs)
            if jobs is None:
                waiting = k
                stopped = (f"battery {k}: its missions are in battery_{k}/; fly it and "
                           "run again with its card added")
                break
            rows, note, done = run_jobs(ctx, jobs, f"flight {k}")
            complete = complete and done
            latest.update(rows)
            outputs += [str(j.tree.result.relative_to(root)) for j in jobs]
            ids = [j.site.id for j in jobs]
            flown += ids
            examples = _examples(rows, ids)
            ex_rows += [row_of[e.id] for e in examples]
            ex_y += [1.0 if e.verdict == "mound" else -1.0 for e in examples]
            ex_w += [e.confidence * a.learn_weight for e in examples]
            before = current
            model = coarse.train(train, model.band, l2=model.l2,
                                 extra=(test.x[np.array(ex_rows, dtype=int)],
                                        np.array(ex_y), np.array(ex_w)))
            write_json(fdir / "model.json", model.to_doc())
            current = with_model(sites0, model, test, reward_of(a.reward, a.confusion))
            write_json(fdir / "sites_after.json", current.to_doc())
            changes, flips = _changes(before, current, flown)
            auc = held_out_auc(model, test, field_rows)
            history.append(FlightLearned(
                k, ids, flight.reward, first_plan[k - 1] if k <= len(first_plan) else [],
                flight.cost_m, note, examples, auc, flips, changes))
            flights_flown.append(flight.flights[0])
            ctx.say(f"[learn] flight {k}: {note}; held-out AUC {auc:.4f} "
                    f"(before any flight {auc0:.4f}), {flips} classifier labels flipped")
        _write_flown(ctx, flights_flown, len(flown), current)
        write_json(t.learn / "learn.json", LearnRecord(
            a.learn_weight, auc0, history[-1].held_out_auc if history else auc0,
            int(len(test.cls) - len(field_rows)), "sat.tst without the field's rows",
            tuple(history), stopped, waiting).to_doc())
        outputs += ["learn/learn.json", "learn/plan_flown.json", "learn/sites_final.json"]
        made, said = second_look_missions(ctx, list(latest.values()), t.final_plan(True),
                                          t.final_sites(True))
        outputs += made
        note = (f"{len(history)} flights, {len(flown)} sites flown, "
                f"{len(ex_y)} verdicts learned; held-out AUC {auc0:.4f} -> "
                f"{history[-1].held_out_auc if history else auc0:.4f}"
                + (f"; {stopped}" if stopped else "") + said)
        return outputs, note, complete

    return run_stage(ctx, "sites3d", {"plan": ctx.keys["plan"], "photos": ctx.keys["photos"],
                                      "learn": a.learn_weight, "flights": a.flights,
                                      "algo": a.algo, "seed": a.plan_seed,
                                      "cards": None if a.cards is None else
                                      [card_digest(Path(c)) for c in a.cards],
                                      "first": [j.key for j in site_jobs(ctx)]}, work)
