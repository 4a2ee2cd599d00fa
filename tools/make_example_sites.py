"""Writes data/sites.json: an example field shaped like the paper's experiment.

A 10 x 10 grid of candidate sites at x, y = 1..10 m (ENU, metres), home at the origin,
scan (node) cost 1 m per site, budget 120 m. Each site gets a mound probability p drawn
from a Beta(0.5, 0.5) with a fixed seed, and the reward is the binary entropy H(p) in
bits, as the coarse-search stage assigns it. Until that stage produces real fields, this
file is the example the README and docs/install.md run.

    python3 tools/make_example_sites.py data/sites.json
"""

from __future__ import annotations

import json
import math
import random
import sys


def entropy_bits(p: float) -> float:
    if p <= 0.0 or p >= 1.0:
        return 0.0
    return -(p * math.log2(p) + (1 - p) * math.log2(1 - p))


def main(out: str) -> None:
    rng = random.Random(2026)
    sites = []
    for j in range(10):
        for i in range(10):
            p = rng.betavariate(0.5, 0.5)
            sites.append(
                {
                    "id": f"s{10 * j + i + 1:03d}",
                    "x_m": float(i + 1),
                    "y_m": float(j + 1),
                    "reward": round(entropy_bits(p), 6),
                    "scan_cost_m": 1.0,
                    "p_mound": round(p, 6),
                }
            )
    doc = {
        "schema": "mound.sites",
        "version": 1,
        "origin": {"lat": 38.5705, "lon": 27.9862, "alt_m": 95.0},
        "home": {"id": "home", "x_m": 0.0, "y_m": 0.0},
        "end": {"id": "home"},
        "budget_m": 120.0,
        "sites": sites,
        "provenance": {"tool": "tools/make_example_sites.py", "seed": 2026},
    }
    with open(out, "w", encoding="utf-8") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "data/sites.json")
