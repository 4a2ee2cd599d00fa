"""Measurement (not a test): a field day battery by battery (issue 69) — does re-planning
after each battery leave fewer tumuli unknown than planning the day once?

Each day is a standard Statlog field (`make_field`, seeds 0 ..: 100 sites 250 m apart, 3-5
holding a positive example, the survey's scan and classifier), its tumuli given heights
drawn from the Kazanlak inventory. A visit's verdict is drawn from the three-answer
confusion an `eval-verdict` report measured (`--confusion`, default the three-answer model
on 319 held-out Kazanlak sites; or a model's own, `trained.confusion`): a tumulus by its
height class, a bare site as a whole.
The same batteries (`--batteries` K of `--budget` m each) and the same draws (a site's
k-th visit answers alike under every policy) for every policy:

- `once-entropy`: today — mound_plan plans the K flights at once on the paper's reward
  (the binary entropy of p); all are flown;
- `once-value`: planned once on the value of a visit (mound.recon.visit_value: the expected
  fall in wrong final labels given the verdict's confusion);
- `battery`: after each battery the verdicts are learned (the classifier refitted with
  the decided sites as examples weighted by how sure the answer makes them), every site's
  p and value recomputed, an undecided site's p moved by Bayes' rule and kept as a node
  for a second look, and the batteries left re-planned; the first of them is flown;
- `battery-no-revisit`: the same without second looks;
- `oracle` (a ceiling, not a policy): as `battery`, planned on the truth (a tumulus's
  value as if p were 1, a bare site's as if 0): the most tumuli these batteries and this
  verdict could confirm;
- `in-flight`: as `battery`, and within each battery the rest of it re-planned after each
  site's answer (`mound fly`'s loop): the site's p moved by Bayes' rule, mound_plan
  planning from the site just flown to home with the distance left, the first site of
  that plan flown next.

A second look answers as a first look does (no grid has flown second looks with the
three-answer model: an assumption, stated). Printed per policy over the days: tumuli
found, tumuli left unknown (not confirmed: missed, undecided or unvisited), confident false
alarms, undecided left, flight used, the paper's eps_MD and eps_FA (unvisited and
undecided sites by the classifier's label), mean and median; and the tumuli left unknown
against `once-entropy` (the issue's goal: 25 % fewer, false alarms not higher).

    .venv/bin/python tools/bench/bench_day.py [--days 20] [--batteries 4] [--budget 5000]
        [--confusion docs/results/verdict_three_answers_kazanlak.json] [--out DIR]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "python"))

from mound.classify import coarse, statlog  # noqa: E402
from mound.classify.model import Model  # noqa: E402
from mound.classify.reward import binary_entropy_bits  # noqa: E402
from mound.formats.plan import Plan  # noqa: E402
from mound.formats.sites import Node, Sites  # noqa: E402
from mound.jsonio import write_json  # noqa: E402
from mound.plan.field import make_field, sites_document  # noqa: E402
from mound.recon import visit_value as vv  # noqa: E402
from mound.sim.population import population_path, read_population  # noqa: E402
from mound.survey.context import scan_spec  # noqa: E402
from mound.survey.options import SurveyOptions  # noqa: E402
from mound.survey.reward import kazanlak_mix, read_confusion  # noqa: E402
from mound.survey.stages.learn import NO_ROUND_TRIP  # noqa: E402

POLICIES = ("once-entropy", "once-value", "battery", "battery-no-revisit", "in-flight",
            "oracle")
LEARN_WEIGHT = 100.0  # training examples a verified site counts as (bench_learn's best)
MAX_VISITS = 3


@dataclass
class Day:
    seed: int
    sites: Sites
    rows: np.ndarray       # Statlog row of each site
    tumulus: np.ndarray    # bool
    klass: list[str]       # height class of each tumulus ("" for none)
    u: np.ndarray          # (sites, MAX_VISITS) uniform draws: the k-th visit's answer


@dataclass
class Outcome:
    answers: dict[int, str] = field(default_factory=dict)  # site index -> last answer
    visits: dict[int, int] = field(default_factory=dict)
    used_m: float = 0.0
    flights: int = 0
    p_final: np.ndarray | None = None


def answer(day: Day, conf: vv.Confusion, k: int, visit: int) -> str:
    rates = conf.tumulus[day.klass[k]] if day.tumulus[k] else conf.none
    return vv.drawn_answer(rates, day.u[k, min(visit, MAX_VISITS - 1)])


def plan(sites: Sites, keep: list[int], rewards: np.ndarray, flights: int, work: Path,
         start: tuple[float, float] | None = None, budget_m: float | None = None
         ) -> Plan | None:
    """mound_plan's K flights over the sites `keep` with `rewards` (None: none possible);
    from `start` to home with `budget_m` when given (a flight under way)."""
    chosen = [replace(sites.sites[k], reward=float(rewards[k])) for k in keep
              if rewards[k] > 1e-9]
    if not chosen or (budget_m is not None and budget_m <= 0):
        return None
    path = work / "sites.json"
    doc = sites.with_sites(chosen)
    if start is not None:
        doc = replace(doc, home=Node("here", *start), end=sites.home)
    if budget_m is not None:
        doc = replace(doc, budget_m=budget_m)
    write_json(path, doc.to_doc())
    r = subprocess.run([str(ROOT / "build" / "mound_plan"), str(path), "--flights",
                        str(flights), "--seed", "1", "--out", str(work / "plan.json")],
                       capture_output=True, text=True)
    if r.returncode == 3 or (r.returncode == 2 and NO_ROUND_TRIP in r.stderr):
        return None  # no flight over these sites (mound_plan's words, as the survey reads them)
    if r.returncode != 0:
        raise SystemExit(f"mound_plan exit {r.returncode}: {r.stderr[-500:]}")
    return Plan.read(work / "plan.json")


def fly(day: Day, conf: vv.Confusion, out: Outcome, ids: list[str]) -> list[int]:
    index = {s.id: k for k, s in enumerate(day.sites.sites)}
    flown = []
    for sid in ids:
        k = index[sid]
        v = out.visits.get(k, 0)
        out.answers[k] = answer(day, conf, k, v)
        out.visits[k] = v + 1
        flown.append(k)
    return flown


def fly_replanning(day: Day, conf: vv.Confusion, tum: np.ndarray, out: Outcome,
                   planned: list[str], p: np.ndarray, work: Path) -> list[int]:
    """One battery flown as `mound fly` flies it: the first site of the battery's plan,
    then after each answer (p moved by Bayes' rule, in `p`) the rest re-planned from there
    with the distance left. The distance used goes to `out`."""
    sites = day.sites.sites
    index = {s.id: k for k, s in enumerate(sites)}
    at = (day.sites.home.x_m, day.sites.home.y_m)
    left = day.sites.budget_m - day.sites.takeoff_landing_m
    flown: list[int] = []
    nxt = index[planned[0]]
    while True:
        s = sites[nxt]
        leg = float(np.hypot(s.x_m - at[0], s.y_m - at[1])) + s.scan_cost_m
        flown += fly(day, conf, out, [s.id])
        p[nxt] = float(vv.after_answer(p[nxt], out.answers[nxt], tum, conf.none))
        left -= leg
        out.used_m += leg
        at = (s.x_m, s.y_m)
        keep = [i for i in range(len(sites)) if i not in out.answers
                or (out.answers[i] == "undecided" and out.visits[i] < MAX_VISITS)]
        pl = plan(day.sites, keep, vv.visit_value(p, tum, conf.none), 1, work, at,
                  left + day.sites.takeoff_landing_m)
        if pl is None or not pl.flights[0].sites:
            break
        nxt = index[pl.flights[0].sites[0]]
    home = float(np.hypot(at[0] - day.sites.home.x_m, at[1] - day.sites.home.y_m))
    out.used_m += home + day.sites.takeoff_landing_m
    return flown


def run(policy: str, day: Day, conf: vv.Confusion, tum: np.ndarray, model0: Model,
        train: statlog.Split, test: statlog.Split, k_flights: int, work: Path) -> Outcome:
    n = len(day.sites.sites)
    p = model0.predict(test.x[day.rows])
    out = Outcome()
    if policy.startswith("once"):
        r = binary_entropy_bits(p) if policy == "once-entropy" else vv.visit_value(
            p, tum, conf.none)
        pl = plan(day.sites, list(range(n)), r, k_flights, work)
        for f in (pl.flights if pl else ()):
            if f.sites:
                fly(day, conf, out, list(f.sites))
                out.used_m += f.cost_m
                out.flights += 1
        out.p_final = p
        return out
    revisit = policy in ("battery", "in-flight", "oracle")
    truth = day.tumulus.astype(float)
    ex_rows: list[int] = []
    ex_y: list[float] = []
    ex_w: list[float] = []
    model = model0
    for k in range(k_flights):
        keep = [i for i in range(n) if i not in out.answers
                or (revisit and out.answers[i] == "undecided"
                    and out.visits[i] < MAX_VISITS)]
        pl = plan(day.sites, keep, vv.visit_value(truth if policy == "oracle" else p, tum,
                                                  conf.none), k_flights - k, work)
        first = next((f for f in pl.flights if f.sites), None) if pl else None
        if first is None:
            break
        if policy == "in-flight":
            flown = fly_replanning(day, conf, tum, out, list(first.sites), p, work)
        else:
            flown = fly(day, conf, out, list(first.sites))
            out.used_m += first.cost_m
        out.flights += 1
        # learn the decided answers, each weighted by how sure it makes the site
        for i in flown:
            a = out.answers[i]
            if a == "undecided":
                continue
            post = float(vv.after_answer(p[i], a, tum, conf.none))
            ex_rows.append(int(day.rows[i]))
            ex_y.append(1.0 if a == "mound" else -1.0)
            ex_w.append(LEARN_WEIGHT * (post if a == "mound" else 1 - post))
        model = coarse.train(train, model0.band, l2=model0.l2,
                             extra=(test.x[np.array(ex_rows, dtype=int)], np.array(ex_y),
                                    np.array(ex_w))) if ex_rows else model
        p = model.predict(test.x[day.rows])
        for i, a in out.answers.items():  # an undecided visit's evidence, every one of them
            if a == "undecided":
                for _ in range(out.visits[i]):
                    p[i] = float(vv.after_answer(p[i], "undecided", tum, conf.none))
    out.p_final = p
    return out


def score(day: Day, out: Outcome) -> dict[str, float]:
    t = day.tumulus
    found = sum(1 for k, a in out.answers.items() if a == "mound" and t[k])
    fa = sum(1 for k, a in out.answers.items() if a == "mound" and not t[k])
    label = np.array(out.p_final >= 0.5)
    for k, a in out.answers.items():
        if a != "undecided":
            label[k] = a == "mound"
    return {"tumuli": int(t.sum()), "found": found, "unknown": int(t.sum()) - found,
            "false_alarms": fa,
            "undecided": sum(1 for a in out.answers.values() if a == "undecided"),
            "visits": sum(out.visits.values()), "flown_m": out.used_m,
            "eps_md": float(np.mean(~label[t])) if t.any() else 0.0,
            "eps_fa": float(np.mean(label[~t]))}


def make_day(seed: int, test: statlog.Split, model: Model, budget: float, heights: np.ndarray
             ) -> Day:
    f = make_field(test, seed)
    sites = sites_document(f, test, model, None, budget, spacing_m=250.0,
                           scan=scan_spec(SurveyOptions()))
    rng = np.random.default_rng([seed, 69])
    klass = [vv.height_class(float(rng.choice(heights))) if pos else "" for pos in f.positive]
    return Day(seed, sites, f.rows, f.positive.copy(), klass,
               rng.random((len(f.rows), MAX_VISITS)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--days", type=int, default=20)
    ap.add_argument("--batteries", type=int, default=4)
    ap.add_argument("--budget", type=float, default=5000.0, help="m per battery")
    ap.add_argument("--confusion",
                    default=str(ROOT / "docs/results/verdict_three_answers_kazanlak.json"),
                    help="an eval-verdict report, or a verdict model trained since "
                    "2026-11-29 (its trained.confusion)")
    ap.add_argument("--policies", default=",".join(POLICIES),
                    help="those to run, comma-separated (once-entropy, the base, always)")
    ap.add_argument("--out", help="per-day results (JSON)")
    a = ap.parse_args()
    conf = read_confusion(a.confusion)
    heights = np.array([r.height_m for r in read_population(str(population_path(
        "kazanlak"))).rows])
    tum = conf.tumulus_mean(kazanlak_mix())
    train, test = statlog.load("sat.trn"), statlog.load("sat.tst")
    model0 = coarse.load_model(None)
    print(f"{a.days} days, {a.batteries} batteries of {a.budget:.0f} m; confusion "
          f"{Path(a.confusion).name}: a tumulus (Kazanlak mix) mound/undecided/no_mound "
          f"{tum[0]:.3f}/{tum[1]:.3f}/{tum[2]:.3f}, a bare site {conf.none[0]:.4f}/"
          f"{conf.none[1]:.3f}/{conf.none[2]:.3f}", flush=True)
    chosen = ["once-entropy"] + [q for q in a.policies.split(",") if q != "once-entropy"]
    unknown = [q for q in chosen if q not in POLICIES]
    if unknown:
        raise SystemExit(f"--policies: {unknown[0]!r} is not one of {', '.join(POLICIES)}")
    rows: dict[str, list[dict[str, float]]] = {p: [] for p in chosen}
    with tempfile.TemporaryDirectory() as tmp:
        for d in range(a.days):
            day = make_day(d, test, model0, a.budget, heights)
            line = [f"day {d}: {int(day.tumulus.sum())} tumuli"]
            for pol in chosen:
                s = score(day, run(pol, day, conf, tum, model0, train, test, a.batteries,
                                   Path(tmp)))
                rows[pol].append(s)
                line.append(f"{pol} {s['found']} found {s['false_alarms']} FA "
                            f"{s['undecided']} und")
            print("; ".join(line), flush=True)
    base = sum(r["unknown"] for r in rows["once-entropy"])
    base_fa = sum(r["false_alarms"] for r in rows["once-entropy"])
    print(f"\n{'policy':20s} {'found':>6s} {'unknown':>8s} {'vs today':>9s} {'FA':>4s} "
          f"{'undec':>6s} {'visits':>7s} {'km (mean, median)':>19s} {'eps_MD':>7s} "
          f"{'eps_FA':>7s}")
    for pol, rs in rows.items():
        unk = sum(r["unknown"] for r in rs)
        km = [r["flown_m"] / 1000 for r in rs]
        print(f"{pol:20s} {sum(r['found'] for r in rs):6d} {unk:8d} "
              f"{(unk - base) / base:+9.1%} {sum(r['false_alarms'] for r in rs):4d} "
              f"{sum(r['undecided'] for r in rs):6d} {sum(r['visits'] for r in rs):7d} "
              f"{statistics.mean(km):9.1f} {statistics.median(km):9.1f} "
              f"{statistics.mean(r['eps_md'] for r in rs):7.3f} "
              f"{statistics.mean(r['eps_fa'] for r in rs):7.4f}")
    print(f"goal: unknown >= 25 % fewer than once-entropy ({base}), false alarms not above "
          f"{base_fa}")
    if a.out:
        Path(a.out).write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
