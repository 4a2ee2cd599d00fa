"""The exact solvers (SCIP branch-and-cut, HiGHS cut loop) against the C++ dynamic
programme (Held-Karp) on small instances."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mound import native
from mound.plan import branch_cut, sites
from mound.plan import exact as exact_op

SOLVERS = {"highs": exact_op.solve, "scip": branch_cut.solve}


def random_doc(seed: int, n_sites: int, closed: bool) -> dict:
    rng = np.random.default_rng(seed)
    doc = {
        "schema": "mound.sites", "version": 1,
        "home": {"id": "home", "x_m": 0.0, "y_m": 0.0},
        "budget_m": float(rng.uniform(10, 30)),
        "sites": [{"id": f"s{i}", "x_m": float(rng.uniform(0, 10)),
                   "y_m": float(rng.uniform(0, 10)), "reward": float(rng.uniform(0, 1)),
                   "scan_cost_m": float(rng.uniform(0, 1))} for i in range(n_sites)],
    }
    if not closed:
        doc["end"] = {"id": "end", "x_m": 8.0, "y_m": 2.0}
    return doc


@pytest.mark.parametrize("solver", sorted(SOLVERS))
@pytest.mark.parametrize("seed", range(8))
def test_integer_programme_agrees_with_dynamic_programme(tmp_path: Path, seed: int,
                                                        solver: str) -> None:
    doc = random_doc(seed, 6 + seed % (5 if solver == "highs" else 11), closed=seed % 2 == 0)
    path = tmp_path / "s.json"
    path.write_text(json.dumps(doc))
    dp = native.run_json("mound_plan", [str(path), "--algo", "exact"])
    p = sites.load(path)
    r = SOLVERS[solver](p, time_limit_s=60)
    assert r.status == "optimal"
    assert r.reward == pytest.approx(dp["reward"], abs=1e-6)
    assert r.bound == pytest.approx(r.reward)
    # The route is feasible: home first, end last, each site once, within the budget.
    assert r.route[0] == 0 and r.route[-1] == p.end
    inner = r.route[1:-1]
    assert len(inner) == len(set(inner))
    assert p.route_cost(r.route) <= p.budget + 1e-6
    # No heuristic beats the proven optimum.
    for algo in ("newalg", "newalg-ls", "alns", "greedy", "tsiligirides", "glv"):
        plan = native.run_json("mound_plan", [str(path), "--algo", algo])
        assert plan["reward"] <= r.reward + 1e-9, algo


@pytest.mark.parametrize("solver", sorted(SOLVERS))
def test_time_limit_returns_a_bound_and_a_feasible_route(solver: str) -> None:
    doc = random_doc(42, 60, closed=True)
    doc["budget_m"] = 40.0
    p = sites.from_document(doc)
    r = SOLVERS[solver](p, time_limit_s=0.5)
    assert r.bound >= r.reward - 1e-9
    assert p.route_cost(r.route) <= p.budget + 1e-6


def test_cli_writes_a_plan_with_proof_and_rejects_bad_input(tmp_path: Path, capsys) -> None:
    from mound.cli import main as mound_main

    doc = random_doc(3, 8, closed=False)
    src = tmp_path / "s.json"
    src.write_text(json.dumps(doc))
    out = tmp_path / "plan.json"
    assert mound_main(["plan", "exact", str(src), "--out", str(out)]) == 0
    plan = json.loads(out.read_text())
    dp = native.run_json("mound_plan", [str(src), "--algo", "exact"])
    assert plan["schema"] == "mound.plan" and plan["solver"]["proof"] == "optimal"
    assert plan["solver"]["name"] == "scip" and plan["algo"] == "exact-bc"
    assert plan["reward"] == pytest.approx(dp["reward"], abs=1e-6)
    assert plan["tour"][0] == "home" and plan["tour"][-1] == "end"
    del doc["sites"][2]["x_m"]
    src.write_text(json.dumps(doc))
    assert mound_main(["plan", "exact", str(src), "--out", str(tmp_path / "no.json")]) == 2
    # the file and the member named (formats.sites reads it)
    assert "s.json: sites[2].x_m: expected a number" in capsys.readouterr().err
    assert not (tmp_path / "no.json").exists()


@pytest.mark.slow
def test_branch_and_cut_on_a_classic_path_and_unreachable_sites(shared_data: Path) -> None:
    """A classic benchmark path (Tsiligirides 1, budget 40: 29 sites, proven optimum in
    best_known.csv) is proven optimal (155); sites that no route within the budget reaches are
    left out of the model, and with none reachable the route is home -> end."""
    import csv

    from mound.plan.sites import from_classic_op_file

    name = "Tsiligirides_1/tsiligirides_problem_1_budget_40.txt"
    doc = from_classic_op_file(shared_data / "op" / name)
    with open(shared_data / "op" / "best_known.csv", newline="") as f:
        known = {row["instance"]: row for row in csv.DictReader(f)}
    p = sites.from_document(doc)
    r = branch_cut.solve(p, time_limit_s=120)
    assert r.status == "optimal"
    assert r.reward == pytest.approx(float(known[name]["computed_optimum"]))
    assert p.route_cost(r.route) <= p.budget + 1e-6
    tiny = sites.from_document(doc, budget=p.route_cost([0, 1]) + 1e-3)
    r = branch_cut.solve(tiny, time_limit_s=10)
    assert r.status == "optimal" and r.route == [0, 1] and r.reward == 0.0


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(8))
def test_branch_and_cut_for_several_flights_agrees_with_dynamic_programme(
        tmp_path: Path, seed: int) -> None:
    """K flights (the team orienteering problem): SCIP's branch-and-cut proves the same
    total reward as the C++ dynamic programme over subsets, its flights are each within
    the budget with no site in two, and a terrain's climb costs (sites.json extra_m) are
    priced alike."""
    flights = 2 + seed % 3
    doc = random_doc(100 + seed, 8 + seed % 5, closed=seed % 3 != 0)
    doc["budget_m"] = doc["budget_m"] / 2 + (14 if "end" in doc else 0)
    if seed % 2:
        n = len(doc["sites"]) + (2 if "end" in doc else 1)
        rng = np.random.default_rng(seed)
        e = rng.uniform(0, 3, (n, n))
        e = np.triu(e, 1)
        doc["terrain"] = {"version": 1, "extra_m": (e + e.T).tolist()}
    path = tmp_path / "s.json"
    path.write_text(json.dumps(doc))
    dp = native.run_json("mound_plan", [str(path), "--algo", "exact", "--flights", str(flights)])
    p = sites.load(str(path))
    r = branch_cut.solve_flights(p, flights, time_limit_s=120)
    assert r.status == "optimal"
    assert r.reward == pytest.approx(dp["reward"], abs=1e-6)
    seen: set[int] = set()
    for route in r.routes:
        assert p.route_cost(route) <= p.budget + 1e-6
        inner = set(route[1:-1])
        assert not inner & seen
        seen |= inner
    # ALNS-K (the default planner) reaches the proven optimum here.
    alns = native.run_json("mound_plan", [str(path), "--flights", str(flights)])
    assert alns["reward"] == pytest.approx(r.reward, abs=1e-6)
