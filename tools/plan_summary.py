"""Prints a one-line summary of each plan.json given on the command line."""

from __future__ import annotations

import json
import sys


def main(paths: list[str]) -> int:
    for path in paths:
        with open(path, encoding="utf-8") as f:
            plan = json.load(f)
        print(
            f"{path}: {plan['algo']}: {plan['n_visited']}/{plan['n_sites']} sites, "
            f"reward {plan['reward']:.3f}, cost {plan['cost_m']:.2f} of {plan['budget_m']:.1f} m "
            f"({plan['budget_left_m']:.2f} m left), {1000 * plan['elapsed_s']:.2f} ms"
        )
        print("  tour: " + " ".join(plan["tour"]))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
