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
    mound scene train SCENE.tif [...] --labels KNOWN.geojson --out MODEL.json [...]
    mound scene score SCENE.tif --model MODEL.json --out DIR [--stride-m S] [...]
    mound scene eval SCENE.tif [...] --labels KNOWN.geojson [--figure PNG] [...]

Exit codes: 0 ok, 1 internal error, 2 bad input or usage (one line on stderr), 3 valid
input that allowed no result.
"""

from __future__ import annotations

import argparse
import sys
import time

from mound import native
from mound.args import Parser, UsageError
from mound.classify import cli as classify_cli
from mound.errors import exit_for, exit_on_interrupt
from mound.grids import cli as grids_cli
from mound.photos import cli as photos_cli
from mound.plan import cli as plan_cli
from mound.recon import cli as recon_cli
from mound.scene import cli as scene_cli
from mound.sim import cli as sim_cli
from mound.uav import cli as uav_cli


def build_parser() -> argparse.ArgumentParser:
    p = Parser(prog="mound", description="mound-survey command line")
    sub = p.add_subparsers(dest="group", required=True, parser_class=Parser)
    classify_cli.add_parser(sub, Parser)
    plan_cli.add_parser(sub, Parser)
    grids_cli.add_parser(sim_cli.add_parser(sub, Parser), Parser)
    recon_cli.add_parser(sub, Parser)
    uav_cli.add_parser(sub, Parser)
    scene_cli.add_parser(sub, Parser)
    photos_cli.add_parser(sub, Parser)
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
        parser = build_parser()
        if "-h" in argv or "--help" in argv:
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
