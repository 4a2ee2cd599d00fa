"""`python python/mission.py`: the whole survey, from satellite data to a verdict per site.

Stages, each writing into the run directory (tree.py) and skipped on a rerun when its
inputs and options are unchanged (ledger.py):

    classify   train the coarse-search classifier on Statlog sat.trn, evaluate on sat.tst
    field      the candidate sites: the paper's 10 x 10 protocol (field seed, flyable
               spacing) or the user's --sites file; p(mound), reward, scan costs
    plan       mound_plan: the orienteering tour within the budget
    mission    the tour as a MAVLink mission (.plan, .waypoints, .geojson), uploaded and
               read back with --connect
    photos     with --photos CARD: the aircraft's card sorted into the visited sites
               (mound photos sort: photos.json, photos/<site id>/); with --second-photos
               the card of the second looks too (photos_second/)
    sites3d    per visited site on Dask: its flight simulated from the site's hidden truth
               (or the photos of --photos / --images-root), mound_recon reconstruct,
               mound_recon verdict, the site's pictures; a failing site is reported and the
               rest go on. With --learn, flight by flight: after each, the verdicts
               retrain the classifier and the next flight is re-planned (stages/learn.py).
               A site the verdict leaves undecided is flown again wider (simulated, or
               from --second-photos); the missions of those second looks are written to
               second_look/
    report     final labels (the 3-D verdict where visited, the classifier's elsewhere),
               eps_MD / eps_FA, summary.json (mound.survey v1), report.html, report.md
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from typing import get_args

from mound import native
from mound.args import Parser
from mound.errors import EXIT_NO_RESULT, exit_for, exit_on_interrupt
from mound.formats.survey import SCHEMA, VERSION
from mound.jsonio import read_json
from mound.survey.context import Context
from mound.survey.ledger import Ledger
from mound.survey.options import (
    NUMBERS,
    Algo,
    DjiAircraft,
    Firmware,
    RewardKind,
    ScanPattern,
    SurveyOptions,
)
from mound.survey.stages import NAMES, run_stages
from mound.survey.tree import RunTree


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Shows defaults, except None and False (options that are off unless given)."""

    def _get_help_string(self, action: argparse.Action) -> str:
        if action.default in (None, False, argparse.SUPPRESS):
            return action.help or ""
        return super()._get_help_string(action) or ""


def build_parser() -> argparse.ArgumentParser:
    D = SurveyOptions()  # the defaults, in one place
    p = Parser(
        prog="python python/mission.py",
        description="The whole survey in one command: classifier -> candidate sites -> "
        "tour (mound_plan) -> MAVLink mission -> per visited site its flight (simulated, "
        "or your photos), mound_recon reconstruct and verdict -> final labels, eps_MD, "
        "eps_FA, summary.json and report.html. A rerun with the same options skips what "
        "is done (interrupt it any time and run it again).",
        formatter_class=HelpFormatter)
    p.add_argument("--out", default=D.out, help="run directory")
    _site_arguments(p, D)
    _flight_arguments(p, D)
    _stage3d_arguments(p, D)
    _run_arguments(p, D)
    return p


def _site_arguments(p: argparse.ArgumentParser, D: SurveyOptions) -> None:
    g = p.add_argument_group("candidate sites")
    g.add_argument("--field-seed", type=NUMBERS["field_seed"].arg(), default=D.field_seed,
                   help="the paper's protocol: a 10 x 10 field of Statlog sat.tst examples, "
                   "3-5 of them positives (mounds); seeds 0-9 are the standard fields")
    g.add_argument("--spacing", type=NUMBERS["spacing"].arg(), default=D.spacing,
                   help="distance between neighbouring sites of the field, m")
    g.add_argument("--sites", help="your own sites instead: a mound.sites JSON or a GeoJSON "
                   "FeatureCollection of points (a 'home' feature, then sites with p_mound, "
                   "optional reward and truth); see docs/survey.md")
    g.add_argument("--budget", type=NUMBERS["budget"].arg(),
                   help="flight distance budget, m (default: the "
                   "sites file's budget_m, else the aircraft's range, 14,400 m)")
    g = p.add_argument_group("satellite scene (instead of the field or --sites)")
    g.add_argument("--scene", nargs="+", help="GeoTIFF scene(s): the candidate sites are the "
                   "local maxima of p(mound) (mound scene score)")
    g.add_argument("--labels", help="known mounds (GeoJSON points, WGS84): the scene model is "
                   "learned from them, and they give the truth of the candidates near them")
    g.add_argument("--scene-model", help="a model of mound scene train instead of --labels")
    g.add_argument("--home", help="LAT,LON of the take-off point (needed with --scene; "
                   "with the field: where the field's home is, default Bin Tepe)")
    g.add_argument("--aoi", help="GeoJSON polygon(s): candidates only inside")
    g.add_argument("--band-names", help="names of the scene's bands, e.g. blue,green,red,nir")
    g.add_argument("--candidates", type=NUMBERS["candidates"].arg(), default=D.candidates,
                   help="candidate sites from the scene")
    g.add_argument("--min-separation-m", type=NUMBERS["min_separation_m"].arg(),
                   default=D.min_separation_m,
                   help="candidates at least this far apart, m")


def _flight_arguments(p: argparse.ArgumentParser, D: SurveyOptions) -> None:
    g = p.add_argument_group("flight")
    g.add_argument("--scan-pattern", choices=get_args(ScanPattern), default=D.scan_pattern,
                   help="how each site is scanned (the mission flies it, the simulator "
                   "renders it, the planner pays for it)")
    g.add_argument("--site-diameter", type=NUMBERS["site_diameter_m"].arg(),
                   default=D.site_diameter_m, dest="site_diameter_m", metavar="D",
                   help="size of the scan (and of a simulated tumulus), m")
    g.add_argument("--algo", default=D.algo, choices=get_args(Algo),
                   help="mound_plan's algorithm (default alns: ALNS-OP, 1 s at most; newalg: "
                   "the paper's)")
    g.add_argument("--reward", default=D.reward, choices=get_args(RewardKind),
                   help="what a visit is worth to the planner: entropy (the paper's binary "
                   "entropy of p, in bits) or value (the expected fall in wrong final labels "
                   "given the verdict's three-answer confusion, --confusion); it replaces "
                   "the rewards of a --sites file")
    g.add_argument("--confusion", metavar="FILE", help="--reward value: a verdict model "
                   "with trained.confusion, or an eval-verdict report (e.g. "
                   "docs/results/verdict_three_answers_kazanlak.json)")
    g.add_argument("--plan-seed", type=NUMBERS["plan_seed"].arg(),
                   default=D.plan_seed, help="mound_plan's seed")
    g.add_argument("--flights", type=NUMBERS["flights"].arg(), default=D.flights,
                   help="flights (batteries or aircraft) from home, each within the budget; "
                   "one mission each (mission_1.plan, ... ordered by reward)")
    from mound.flightplan.terrain import add_arguments as add_terrain_arguments

    add_terrain_arguments(p)
    g.add_argument("--connect", help="also upload the mission to this MAVLink vehicle and "
                   "read it back (udpout:HOST:PORT, udpin:HOST:PORT, tcp:HOST:PORT, serial)")
    g.add_argument("--firmware", choices=get_args(Firmware), default=D.firmware,
                   help="the vehicle's dialect of mission items (default: px4)")
    g.add_argument("--aircraft", choices=get_args(DjiAircraft), default=D.aircraft,
                   help="the DJI aircraft of each flight's mission.kmz (WPML for DJI Pilot 2; "
                   "mini4pro and air3 fly the Litchi mission.csv); every flight is also "
                   "written as .plan, .waypoints and .csv")


def _stage3d_arguments(p: argparse.ArgumentParser, D: SurveyOptions) -> None:
    g = p.add_argument_group("3-D stage")
    g.add_argument("--photos", metavar="CARD_DIR", help="the aircraft's photo card (or a copy "
                   "of it): sorted into the visited sites by EXIF GPS and time (mound photos "
                   "sort), each site's folder reconstructed; default: simulate each visited "
                   "site's flight from its hidden truth")
    g.add_argument("--second-photos", metavar="CARD_DIR", help="with --photos: the card of "
                   "the second looks the first verdicts advised (second_look/mission.plan of "
                   "the run before), sorted by second_look/plan.json; each such site is then "
                   "decided by both flights")
    g.add_argument("--camera", help="with --photos: the camera (mound.camera v1) instead of "
                   "the photos' EXIF")
    g.add_argument("--images-root", help="the UAV's photos sorted by hand: one folder per "
                   "site id (with camera.json / poses.json when known, else EXIF)")
    g.add_argument("--learn", action="store_true",
                   help="with --flights K on the field: after each flight, the verdicts "
                   "(weighted by their confidence) retrain the coarse classifier, p_mound "
                   "and rewards are recomputed and the next flight is re-planned over the "
                   "sites not yet flown")
    g.add_argument("--cards", nargs="*", metavar="CARD_DIR", default=D.cards,
                   help="with --learn: the day battery by battery on real flights. Each "
                   "battery's missions (.plan, .kmz, .csv) are written to battery_K/; "
                   "run again with battery K's card added (--cards CARD1 ... CARDK): it is "
                   "sorted into that battery's sites and judged, the classifier learns, and "
                   "battery K+1 is re-planned. --cards alone: battery 1's missions only "
                   "(`mound day` runs this)")
    g.add_argument("--learn-weight", type=NUMBERS["learn_weight"].arg(), default=D.learn_weight,
                   help="--learn: training examples a verified site counts as (times the "
                   "verdict's confidence)")
    g.add_argument("--image-size", type=NUMBERS["image_size"].arg(), nargs=2, default=D.image_size,
                   metavar=("W", "H"), help="simulated image size, px")
    g.add_argument("--sim-seed", type=NUMBERS["sim_seed"].arg(),
                   default=D.sim_seed, help="seed of the simulated sites")
    g.add_argument("--max-features", type=NUMBERS["max_features"].arg(), default=D.max_features,
                   help="SIFT features per image at the simulated sites' SIFT contrast 0.04 "
                   "(mound_recon reconstruct; default: 4000 for simulated sites, and for "
                   "photos from a card (--photos, --images-root) the tool's defaults: 6000 "
                   "at contrast 0.01, COLMAP's density)")
    g.add_argument("--dense-size", type=NUMBERS["dense_size"].arg(),
                   default=D.dense_size, metavar="PX",
                   help="depth maps of mound_recon densify, longer side px (default: the "
                   "verdict model's training clouds, 320 for the built-in one; 0: no dense "
                   "cloud, the site's GeoTIFFs then come from the sparse one)")
    g.add_argument("--reference", help="judge by the paper's test against this reference "
                   "mound (PLY) instead of the reference-free dome detector")
    g.add_argument("--verdict-model", metavar="FILE",
                   help="the dense cloud's verdict model (mound.verdict_model v1) in place of "
                   "the built-in one, e.g. one remade by `mound recon train-verdict`; one "
                   "with a second_look asks for second looks")
    g.add_argument("--site-timeout", type=NUMBERS["site_timeout"].arg(), default=D.site_timeout,
                   help="limit per tool run of a site, s")


def _run_arguments(p: argparse.ArgumentParser, D: SurveyOptions) -> None:
    g = p.add_argument_group("scale-out")
    g.add_argument("--scheduler", help="address of a running Dask scheduler "
                   "(tcp://HOST:8786); default: a local cluster")
    g.add_argument("--workers", type=NUMBERS["workers"].arg(),
                   help="local cluster: worker processes "
                   "(default: one per core)")
    g.add_argument("--site-threads", type=NUMBERS["site_threads"].arg(), default=D.site_threads,
                   help="threads of each site's tools (one task per worker thread)")
    g = p.add_argument_group("report")
    g.add_argument("--basemap", metavar="URL", help="map.html: tiles from your own tile server "
                   "under the overlays (https://HOST/{z}/{x}/{y}.png); default: none, the "
                   "page works offline")
    g = p.add_argument_group("run")
    g.add_argument("--force", action="store_true", help="redo every stage")
    g.add_argument("--rerun-from", choices=NAMES,
                   help="redo this stage and those after it")
    g.add_argument("--no-progress", action="store_true", help="no progress bar")


def run(argv: list[str]) -> int:
    args = SurveyOptions.from_namespace(build_parser().parse_args(argv))
    args.check()
    tree = RunTree(Path(args.out))
    tree.root.mkdir(parents=True, exist_ok=True)
    ctx = Context(args, tree, Ledger(tree.ledger))
    ctx.redo_from = NAMES[0] if args.force else args.rerun_from
    ctx.say(f"survey -> {tree.root} ({os.cpu_count()} cores)")
    run_stages(ctx)
    total = time.time() - ctx.started
    summary = read_json(tree.summary, SCHEMA, VERSION)
    ctx.say(f"done in {total:.1f} s ({summary['status']}): {tree.summary}, {tree.report_html}")
    return EXIT_NO_RESULT if summary["status"] == "failed" else 0


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    try:
        with native.sigterm_as_interrupt():
            return run(argv)
    except KeyboardInterrupt as e:  # Ctrl-C or SIGTERM: the tools are ended
        return exit_on_interrupt("mission.py", e, "run the same command again to resume")
    except Exception as e:
        return exit_for("mission.py", e)
