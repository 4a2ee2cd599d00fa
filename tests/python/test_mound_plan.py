"""Integration tests of the real mound_plan binary through mound.native."""

from __future__ import annotations

import csv
import itertools
import json
import math
from pathlib import Path

import pytest

from mound import native
from mound.plan.sites import from_classic_op_file


def expanded_cost(sites: dict, tour: list[str]) -> float:
    """The INTERFACES.md cost formula, recomputed here independently of the C++ code; the
    take-off/landing climb is the home and end nodes' cost."""
    overhead = sites.get("takeoff_landing_m", 0.0)
    nodes = {sites["home"]["id"]: (sites["home"]["x_m"], sites["home"]["y_m"], overhead)}
    end = sites.get("end") or {"id": sites["home"]["id"]}
    if end["id"] != sites["home"]["id"]:
        nodes[end["id"]] = (end["x_m"], end["y_m"], overhead)
    for s in sites["sites"]:
        nodes[s["id"]] = (s["x_m"], s["y_m"], s.get("scan_cost_m", 0.0))
    total = 0.0
    for a, b in itertools.pairwise(tour):
        xa, ya, ca = nodes[a]
        xb, yb, cb = nodes[b]
        total += math.hypot(xa - xb, ya - yb) + (ca + cb) / 2
    return total


def check_plan(sites: dict, plan: dict, budget: float) -> None:
    assert plan["schema"] == "mound.plan" and plan["version"] == 1 and plan["status"] == "ok"
    tour = plan["tour"]
    home = sites["home"]["id"]
    end = (sites.get("end") or {"id": home})["id"]
    assert tour[0] == home and tour[-1] == end
    inner = tour[1:-1]
    assert len(inner) == len(set(inner)), "a site visited twice"
    rewards = {s["id"]: s["reward"] for s in sites["sites"]}
    assert set(inner) <= set(rewards)
    cost = expanded_cost(sites, tour)
    assert cost <= budget + 1e-9
    assert plan["cost_m"] == pytest.approx(cost, abs=1e-9)
    assert plan["reward"] == pytest.approx(sum(rewards[s] for s in inner), abs=1e-9)
    assert plan["budget_left_m"] == pytest.approx(budget - cost, abs=1e-9)


@pytest.mark.parametrize("algo", ["newalg", "newalg-ls", "alns"])
def test_example_field_plan_is_valid(example_sites: Path, mound_plan: Path, algo: str) -> None:
    sites = json.loads(example_sites.read_text())
    plan = native.run_json("mound_plan", [str(example_sites), "120", "--algo", algo])
    check_plan(sites, plan, 120.0)
    assert plan["algo"] == algo
    assert plan["n_visited"] > 20  # a 120 m budget reaches a good part of the 10 x 10 field
    assert [w["id"] for w in plan["waypoints"]] == plan["tour"]


def test_out_file_is_written_and_seed_is_repeatable(example_sites: Path, tmp_path: Path) -> None:
    """The default planner (ALNS-OP) repeats its plan for a seed when it stops by its
    iteration count, not by the clock (--time-limit 0: none)."""
    out1, out2 = tmp_path / "a.json", tmp_path / "b.json"
    args = [str(example_sites), "80", "--seed", "5", "--iterations", "3000", "--time-limit", "0"]
    native.run_tool("mound_plan", [*args, "--out", str(out1)])
    native.run_tool("mound_plan", [*args, "--out", str(out2)])
    a, b = json.loads(out1.read_text()), json.loads(out2.read_text())
    assert a["algo"] == "alns" and a["solver"]["stopped_by"] == "iterations"
    assert a["tour"] == b["tour"] and a["solver"]["iterations"] == 3000
    assert not list(tmp_path.glob("*.tmp.*"))


def test_default_is_alns_up_to_1000_sites_newalg_above(example_sites: Path,
                                                       tmp_path: Path) -> None:
    small = native.run_json("mound_plan", [str(example_sites), "80"])
    assert small["algo"] == "alns"
    assert small["solver"]["algo_chosen"].startswith("default")
    newalg = native.run_json("mound_plan", [str(example_sites), "80", "--algo", "newalg"])
    assert small["reward"] >= newalg["reward"] - 1e-9  # ALNS-OP starts from NewAlg's plan
    doc = json.loads(example_sites.read_text())
    base = doc["sites"][0]
    doc["sites"] = [{**base, "id": f"g{k}", "x_m": float(k % 40), "y_m": float(k // 40),
                     "reward": 0.1 + (k % 7) / 10} for k in range(1001)]
    big = tmp_path / "big.json"
    big.write_text(json.dumps(doc))
    plan = native.run_json("mound_plan", [str(big), "60"])
    assert plan["algo"] == "newalg" and "algo_chosen" in plan["solver"]
    check_plan(doc, plan, 60.0)


@pytest.mark.parametrize(
    "instance",
    [
        "Tsiligirides_1/tsiligirides_problem_1_budget_40.txt",
        "Tsiligirides_2/tsiligirides_problem_2_budget_25.txt",
        "ChaoSet_64/set_64_1_60.txt",
        "Tsiligirides_3/tsiligirides_problem_3_budget_035.txt",
    ],
)
def test_classic_op_paths_respect_end_node_and_proven_optimum(
    shared_data: Path, tmp_path: Path, instance: str
) -> None:
    sites = from_classic_op_file(shared_data / "op" / instance)
    tmax = sites["budget_m"]
    path = tmp_path / "sites.json"
    path.write_text(json.dumps(sites))
    with open(shared_data / "op" / "best_known.csv", newline="") as f:
        known = {row["instance"]: row for row in csv.DictReader(f)}
    optimum = float(known[instance]["computed_optimum"])
    for algo in ("newalg", "newalg-ls"):
        plan = native.run_json("mound_plan", [str(path), "--algo", algo])
        check_plan(sites, plan, tmax)
        assert plan["reward"] <= optimum + 1e-9  # a heuristic never beats a proven optimum
        if algo == "newalg-ls":
            assert plan["reward"] >= 0.9 * optimum


def test_tsp_subcommand_reaches_eil51_optimum(shared_data: Path) -> None:
    result = native.run_json("mound_plan", ["tsp", str(shared_data / "tsplib" / "eil51.tsp")])
    assert result["length"] == 426
    assert sorted(result["tour"]) == list(range(1, 52))


def good_sites() -> dict:
    return {
        "schema": "mound.sites",
        "version": 1,
        "home": {"id": "home", "x_m": 0.0, "y_m": 0.0},
        "budget_m": 40.0,
        "sites": [
            {"id": "a", "x_m": 3.0, "y_m": 4.0, "reward": 0.5, "scan_cost_m": 1.0},
            {"id": "b", "x_m": 6.0, "y_m": 8.0, "reward": 0.7},
        ],
    }


BAD_CASES = [
    ("missing budget", lambda d: d.pop("budget_m"), "budget_m"),
    ("negative reward", lambda d: d["sites"][1].update(reward=-0.1), "sites[1].reward"),
    ("duplicate id", lambda d: d["sites"][1].update(id="a"), "sites[1].id"),
    ("unknown version", lambda d: d.update(version=3), "version"),
    ("empty sites", lambda d: d.update(sites=[]), "sites"),
    ("budget cannot leave home", lambda d: d.update(budget_m=1.0), "budget_m"),
    ("missing coordinate", lambda d: d["sites"][0].pop("y_m"), "sites[0].y_m"),
]


@pytest.mark.parametrize(("name", "edit", "field"), BAD_CASES, ids=[c[0] for c in BAD_CASES])
def test_bad_input_exit_2_names_field_and_writes_nothing(
    tmp_path: Path, mound_plan: Path, name: str, edit, field: str
) -> None:
    doc = good_sites()
    edit(doc)
    src = tmp_path / "sites.json"
    src.write_text(json.dumps(doc))
    out = tmp_path / "plan.json"
    with pytest.raises(native.ToolError) as err:
        native.run_tool("mound_plan", [str(src), "--out", str(out)])
    assert err.value.code == native.EXIT_BAD_INPUT
    lines = err.value.stderr.strip().splitlines()
    assert len(lines) == 1 and field in lines[0], err.value.stderr
    assert not out.exists()
    assert not list(tmp_path.glob("*.tmp.*"))


def test_python_nan_and_non_json_are_rejected(tmp_path: Path, mound_plan: Path) -> None:
    doc = good_sites()
    doc["sites"][0]["reward"] = float("nan")  # json.dumps writes NaN, which is not JSON
    src = tmp_path / "nan.json"
    src.write_text(json.dumps(doc))
    with pytest.raises(native.ToolError) as err:
        native.run_tool("mound_plan", [str(src)])
    assert err.value.code == 2 and "reward" in err.value.stderr and "NaN" in err.value.stderr
    src.write_text("this is not json")
    with pytest.raises(native.ToolError) as err:
        native.run_tool("mound_plan", [str(src)])
    assert err.value.code == 2 and "nan.json" in err.value.stderr


def test_classic_op_file_errors_name_the_file(tmp_path: Path) -> None:
    from mound.errors import InputError

    bad = tmp_path / "bad.txt"
    bad.write_text("15\t1\n0\t-7\tx\n")
    with pytest.raises(InputError, match="bad.txt: not a classic OP file"):
        from_classic_op_file(bad)
    bad.write_text("15\t1\n0\t-7\t0\n")
    with pytest.raises(InputError, match="start and an end"):
        from_classic_op_file(bad)
