"""The `mound` command line: one entry point, subcommands per stage.

    mound data fetch [--url URL]
    mound classify bands
    mound classify train [--band B | --all] [--solver gd|lbfgs] [--l2 X] --out MODEL.json
    mound classify eval MODEL.json [--json OUT.json]
    mound field make --seed S [--model MODEL.json] [--spacing M] [--budget M]
                     [--scan-cost M | --scan-pattern P [--site-diameter D] [--altitude H]]
                     --out SITES.json
    mound field standard [--model MODEL.json] --out-dir DIR
    mound sim site [--preset bin_tepe|lab] [--mound tumulus|none] --seed S --out DIR [...]
    mound sim figures DIR [--out-dir DIR] [--dpi-scale X]
    mound sim flight PLAN --out CARD_DIR [--truth FILE] [...]
    mound recon figure RECON_DIR --out PNG
    mound recon rasters RECON_DIR --out DIR [--resolution-m 0.25] [--cloud dense.ply]
    mound mission build PLAN.json [--origin LAT,LON[,ALT]] --out MISSION.plan [...]
    mound mission upload MISSION.plan --connect udpout:HOST:PORT [--verify] [...]
    mound day --out DIR [survey options] [--batteries K] [--photos CARD_1 --photos CARD_2 ...]
    mound fly --connect udpout:HOST:PORT --sites SITES.json --confusion MODEL.json
              --range-m M --out DIR [...]
    mound scene train SCENE.tif [...] --labels KNOWN.geojson --out MODEL.json [...]
    mound scene score SCENE.tif --model MODEL.json --out DIR [--stride-m S] [...]
    mound scene eval SCENE.tif [...] --labels KNOWN.geojson [--figure PNG] [...]

Exit codes: 0 ok, 1 internal error, 2 bad input or usage (one line on stderr), 3 valid
input that allowed no result.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import time

from mound import native
from mound.args import Parser, UsageError
from mound.errors import exit_for, exit_on_interrupt

# The stages' command lines, in the order of the help, and the groups each adds. A command
# imports its own stage only (a stage's imports, scipy's among them, took 0.9 s of every
# command's start when all were imported).
STAGES = (("mound.classify.cli", ("data", "classify")),
          ("mound.plan.cli", ("field", "plan", "bench")),
          ("mound.sim.cli", ("sim",)),
          ("mound.recon.cli", ("recon",)),
          ("mound.uav.cli", ("mission",)),
          ("mound.scene.cli", ("scene",)),
          ("mound.photos.cli", ("photos",)),
          ("mound.survey.fly", ("fly",)),
          ("mound.survey.day", ("day",)))


def build_parser(group: str | None = None) -> argparse.ArgumentParser:
    """The whole command line, or only the stage that adds `group` (when it is one)."""
    p = Parser(prog="mound", description="mound-survey command line")
    sub = p.add_subparsers(dest="group", required=True, parser_class=Parser)
    stages = [m for m, groups in STAGES if group in groups] or [m for m, _ in STAGES]
    for name in stages:
        added = importlib.import_module(name).add_parser(sub, Parser)
        if name == "mound.sim.cli":  # `mound sim grid ...` lives in mound.grids
            importlib.import_module("mound.grids.cli").add_parser(added, Parser)
        if name == "mound.recon.cli":  # the verdict's learning lives in mound.training
            importlib.import_module("mound.training.cli").add_commands(added)
    return p


def help_argv(parser: argparse.ArgumentParser, argv: list[str]) -> list[str]:
    """`--help` anywhere on the command line: the help of the deepest (sub)command named
    before anything else, whatever the other arguments are."""
    path: list[str] = []
    for token in argv:
        subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        if not subs or token not in subs[0].choices:
            break
        path.append(token)
        parser = subs[0].choices[token]
    return [*path, "--help"]


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    with native.sigterm_as_interrupt():
        return _main(argv)


def _main(argv: list[str]) -> int:
    try:
        if argv and argv[0] == "day":  # the survey's own options pass through
            from mound.survey import day

            return day.main(argv[1:])
        wants_help = "-h" in argv or "--help" in argv
        parser = build_parser(None if wants_help or not argv else argv[0])
        if wants_help:
            argv = help_argv(parser, argv)
        args = parser.parse_args(argv)
        scan = getattr(args, "scan_cost", None)
        budget = getattr(args, "budget", None)
        costs = [c for c in (scan if isinstance(scan, list) else [scan]) if c is not None]
        if min(costs, default=0) < 0 or (budget or 0) < 0:
            raise UsageError("--scan-cost and budgets must be >= 0")
        start = time.perf_counter()
        code: int = args.func(args)
        print(f"({time.perf_counter() - start:.2f} s)", file=sys.stderr)
        return code
    except KeyboardInterrupt as e:  # Ctrl-C or SIGTERM: the tools are ended
        return exit_on_interrupt("mound", e)
    except Exception as e:
        return exit_for("mound", e)


if __name__ == "__main__":
    sys.exit(main())
